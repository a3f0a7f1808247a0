"""Local tools of the fast path (intercepted by the dispatcher, never sent to MCP)."""

from __future__ import annotations

from robot_voice_chat.services.llm.base import ToolDefinition

START_MISSION = ToolDefinition(
    name="start_mission",
    description=(
        "Call this when the user asks for a multi-step physical task (fetch, deliver, patrol, "
        "find-and-bring …) rather than a question or a single gesture. `instruction` is the "
        "task restated with all context resolved; `ack` is one short sentence to say immediately."
    ),
    parameters={
        "type": "object",
        "properties": {"instruction": {"type": "string"}, "ack": {"type": "string"}},
        "required": ["instruction", "ack"],
    },
)
STOP_MISSION = ToolDefinition(
    name="stop_mission",
    description="Call this when the user wants the robot to stop moving or stop its task.",
    parameters={"type": "object", "properties": {}},
)
RESUME_MISSION = ToolDefinition(
    name="resume_mission",
    description=(
        "Call this when the user says continue / carry on / go on / resume and no mission is "
        "running: it answers whether there is anything to continue (or that a software stop is "
        "latched and an operator must clear it). It never moves the robot."
    ),
    parameters={"type": "object", "properties": {}},
)
FAST_LOCAL_TOOLS = [START_MISSION, STOP_MISSION, RESUME_MISSION]
