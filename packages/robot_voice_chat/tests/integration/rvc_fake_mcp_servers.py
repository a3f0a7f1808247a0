"""Small MCP servers built with the official SDK for the end-to-end mission test.

``python rvc_fake_mcp_servers.py navigation <port> <events_url> <secret> <outbox>`` (sse) or
``python rvc_fake_mcp_servers.py memory <port> [sse]`` (streamable-http unless sse).
Navigation returns a TaskInfo and then posts real signed events through
``robot_mcp_kit.EventPoster``.
"""

from __future__ import annotations

import asyncio
import json
import sys
import uuid
from typing import Any

from mcp.server.mcpserver import MCPServer

from robot_mcp_kit.poster import EventPoster


def navigation(port: int, events_url: str, secret: str, outbox: str) -> None:
    server = MCPServer("navigation")
    tasks: dict[str, str] = {}
    poster = EventPoster(events_url, "navigation", secret, outbox, backoff_initial_s=0.05)
    background: set[asyncio.Task[None]] = set()
    started: list[bool] = []

    async def drive(task_id: str) -> None:
        await asyncio.sleep(0.3)
        await poster.emit(task_id, "navigate_to", "progress", {"pct": 50.0, "eta_s": 12.0})
        await asyncio.sleep(0.2)
        trigger = {"type": "eta_below", "seconds": 10}
        await poster.emit(
            task_id, "navigate_to", "trigger_fired", {"eta_s": 9.4, "trigger": trigger}
        )
        await asyncio.sleep(0.4)
        if tasks.get(task_id) == "running":
            tasks[task_id] = "succeeded"
            await poster.emit(task_id, "navigate_to", "task_done", {"result": {"arrived": True}})

    @server.tool()
    async def navigate_to(location: str, triggers: list[dict[str, Any]] | None = None) -> str:
        """Drive to a named location (async task)."""
        if not started:  # start lazily, inside the server's event loop
            started.append(True)
            await poster.start()
        task_id = "nav-" + uuid.uuid4().hex[:4]
        tasks[task_id] = "running"
        task = asyncio.create_task(drive(task_id))
        background.add(task)
        return json.dumps({"task_id": task_id, "state": "running", "est_duration_s": 1.0})

    @server.tool()
    async def cancel_task(task_id: str) -> str:
        """Cancel a task."""
        tasks[task_id] = "cancelled"
        return json.dumps({"task_id": task_id, "state": "cancelled"})

    @server.tool()
    async def list_tasks(states: list[str] | None = None) -> str:
        """Tasks by state."""
        return json.dumps(
            {
                "tasks": [
                    {"task_id": t, "state": s}
                    for t, s in tasks.items()
                    if not states or s in states
                ]
            }
        )

    @server.tool()
    async def stop_navigation() -> str:
        """Safety stop."""
        return json.dumps({"stopped": True})

    server.run("sse", host="127.0.0.1", port=port)


def memory(port: int, transport: str = "streamable-http") -> None:
    server = MCPServer("memory")
    saved: dict[str, str] = {"mailroom-run": "---\nid: mailroom-run\n---\n## Steps\n1. drive"}

    @server.tool()
    async def find_processes(query: str, k: int = 3) -> str:
        """Rank stored processes."""
        rows = [{"id": i, "title": i, "score": 1.0, "markdown": m} for i, m in saved.items()]
        return json.dumps({"processes": rows[:k]})

    @server.tool()
    async def record_outcome(process_id: str, success: bool, note: str = "") -> str:
        """Record how a process went."""
        return json.dumps({"ok": True, "process_id": process_id, "success": success})

    @server.tool()
    async def save_process(markdown: str) -> str:
        """Store a process document."""
        saved["new"] = markdown
        return json.dumps({"id": "new"})

    server.run(transport, host="127.0.0.1", port=port)  # type: ignore[arg-type]


if __name__ == "__main__":
    kind, port = sys.argv[1], int(sys.argv[2])
    if kind == "navigation":
        navigation(port, sys.argv[3], sys.argv[4], sys.argv[5])
    else:
        memory(port, *sys.argv[3:4])
