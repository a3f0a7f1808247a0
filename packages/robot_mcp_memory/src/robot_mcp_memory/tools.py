"""The ``memory`` MCP server: its tools, written for the mission planner LLM.

Every tool returns a JSON string. A failure the caller can act on is a tool error whose text is
JSON ``{"error": code, "detail": sentence}``; codes: ``invalid_document``, ``invalid_argument``,
``not_found``, ``timeout``, ``store_unavailable``, ``internal_error``, and for ``save_process``
``approval_required`` / ``approval_invalid``.

``save_process`` (teaching: the planner follows what it stores) stores only with an operator's
approval of that exact call, signed by the brain with this server's approval secret
(``MCP_APPROVAL_SECRET``) and used once (:mod:`robot_mcp_kit.approvals`), whoever calls.
"""

from __future__ import annotations

import json
from collections.abc import Awaitable, Callable
from typing import Annotated, Any

import structlog
from mcp.server.mcpserver import MCPServer
from pydantic import Field

from robot_mcp_kit.annotations import READ_ONLY, RECORDS
from robot_mcp_kit.approvals import ApprovalVerifier, require_approval
from robot_mcp_kit.caller import install_caller_context
from robot_mcp_kit.mcp_runtime import install_json_tool_errors, tool_error
from robot_mcp_memory.config import SERVER_NAME
from robot_mcp_memory.documents import FORMAT_SPEC
from robot_mcp_memory.service import MAX_K, MemoryServiceError, ProcessMemory

log = structlog.get_logger("robot_mcp_memory")

INSTRUCTIONS = (
    "Process memory of this robot: documents that say how past missions were done, what went "
    "wrong and what fixed it. find_processes before planning a physical task; save_process to "
    "store a distilled process; record_outcome after a mission that used a process."
)

SAVE_PROCESS_DESCRIPTION = (
    "Call this to store a process document distilled from a mission (teaching). Saving an id "
    "that exists stores a NEW VERSION and keeps the old ones: the newest is what find_processes "
    "and get_process return, older ones stay readable with get_process(id, version=N). Saving "
    "text identical to the current version stores nothing. A malformed document is rejected "
    'with error "invalid_document" naming every problem; fix them and send the whole document '
    "again. Needs an operator's approval of this exact call (the robot's brain attaches it); "
    'without one: error "approval_required". Returns {id, version, created, title, message}.'
    "\n\n" + FORMAT_SPEC
)


async def _answer(tool: str, work: Callable[[], Awaitable[dict[str, Any]]]) -> str:
    try:
        return json.dumps(await work(), ensure_ascii=False)
    except MemoryServiceError as exc:
        raise tool_error(exc.code, exc.detail) from exc
    except Exception as exc:  # tool boundary: the LLM gets a readable error, we get the trace
        log.exception("tool_failed", tool=tool)
        raise tool_error(
            "internal_error", f"{tool} failed unexpectedly; the server logged the cause"
        ) from exc


def build_server(memory: ProcessMemory, approvals: ApprovalVerifier | None = None) -> MCPServer:
    """The MCP server named ``memory`` with its five tools bound to ``memory``. ``approvals``:
    the approval check (``serve_mcp`` installs one from ``MCP_APPROVAL_SECRET``; tests pass
    one)."""
    server: MCPServer = MCPServer(SERVER_NAME, instructions=INSTRUCTIONS)
    install_json_tool_errors(server)  # error results carry only {"error", "detail"} JSON
    install_caller_context(server, approvals)

    @server.tool(annotations=READ_ONLY)
    async def find_processes(
        query: Annotated[str, Field(description="The task in plain words, e.g. the instruction.")],
        k: Annotated[int, Field(ge=1, le=MAX_K, description="How many processes at most.")] = 3,
    ) -> str:
        """Call this at the start of a physical task to get process documents from similar
        past missions (steps, pitfalls & fixes, operator notes). Treat them as advice, not a
        script. Results are best first: {"results": [{id, title, score, task_pattern, version,
        tags, successes, failures, markdown}]}; an empty list means nothing similar is stored.
        score = text relevance (BM25) × outcome boost (past successes raise it, failures lower
        it). Remember the ids you used and report them with record_outcome at the end."""
        return await _answer("find_processes", lambda: memory.find(query, k))

    @server.tool(description=SAVE_PROCESS_DESCRIPTION, annotations=RECORDS)
    async def save_process(
        markdown: Annotated[str, Field(description="The whole process document (markdown).")],
    ) -> str:
        approval = require_approval()  # before anything is read or stored; logged either way
        log.info("process_save_approved", approval_id=approval.approval_id, by=approval.by)
        return await _answer("save_process", lambda: memory.save(markdown))

    @server.tool(annotations=RECORDS)
    async def record_outcome(
        process_id: Annotated[str, Field(description="Id of a process used in the mission.")],
        success: Annotated[bool, Field(description="True if the mission succeeded.")],
        note: Annotated[
            str, Field(description="One or two sentences: what worked or what went wrong.")
        ] = "",
    ) -> str:
        """Call this once per used process when a mission ends, with whether the mission
        succeeded and a short note. Outcomes count against the process's current version and
        change how find_processes ranks it. Returns {id, version, successes, failures}."""
        return await _answer(
            "record_outcome", lambda: memory.record_outcome(process_id, success, note)
        )

    @server.tool(annotations=READ_ONLY)
    async def get_process(
        id: Annotated[str, Field(description="The process id (slug).")],
        version: Annotated[
            int | None, Field(ge=1, description="A past version; omit for the current one.")
        ] = None,
    ) -> str:
        """Call this to read one process document in full: the current version by default, or
        an older version (1 = first saved; see current_version). Returns {id, version,
        current_version, title, task_pattern, tags, successes, failures, recent_outcomes,
        markdown}; error "not_found" if the id or version does not exist."""
        return await _answer("get_process", lambda: memory.get(id, version))

    @server.tool(annotations=READ_ONLY)
    async def list_processes(
        limit: Annotated[int, Field(ge=1, le=500, description="Page size.")] = 100,
        offset: Annotated[int, Field(ge=0, description="Processes to skip.")] = 0,
    ) -> str:
        """Call this to see which processes this robot knows (current versions, most recently
        updated first, without the markdown): {robot_id, total, offset, processes: [{id, title,
        task_pattern, tags, current_version, successes, failures, updated_at}]}."""
        return await _answer("list_processes", lambda: memory.list_processes(limit, offset))

    return server
