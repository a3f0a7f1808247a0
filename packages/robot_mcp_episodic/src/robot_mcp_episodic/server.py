"""The ``episodic`` MCP server: the robot's memory of what it saw, where it was and what
happened, written for the mission planner.

Every tool returns a JSON object as ``structuredContent`` (the text block mirrors it). Times
are given as ISO 8601, relative (``-30s``, ``-10m``, ``-2h``), a clock time today (``15:00``)
or ``now``, each optionally with one offset (``3pm -5m``); the server resolves them. Failures
are tool errors whose text is JSON ``{"error": code, "detail": sentence}`` with code
``invalid_time``, ``invalid_range``, ``unknown_place``, ``invalid_argument``,
``store_unavailable`` or ``internal_error``.

``forget`` with ``dry_run=false`` deletes only for the robot's brain (over HTTP: the brain's
credential, ``MCP_AUTH_TOKEN``; over stdio or in-process: the parent process) and only with an
operator's approval of that exact call, signed by the brain with this server's approval secret
(``MCP_APPROVAL_SECRET``) and used once (:mod:`robot_mcp_kit.approvals`); otherwise
``not_permitted``, ``approval_required`` or ``approval_invalid``, nothing deleted. The
approving operator is written to the forget audit.
"""

from __future__ import annotations

import asyncio
import json
from collections.abc import Callable
from typing import Annotated, Any

import structlog
from mcp.server.mcpserver import MCPServer
from pydantic import Field

from robot_mcp_episodic.config import SERVER_NAME
from robot_mcp_episodic.service import DIGEST_KINDS, Episodic, EpisodicError
from robot_mcp_episodic.store.base import StoreError
from robot_mcp_kit.annotations import DELETES, READ_ONLY, RECORDS
from robot_mcp_kit.approvals import ApprovalError, ApprovalVerifier, require_approval
from robot_mcp_kit.caller import BRAIN, LOCAL, Caller, current_caller, install_caller_context
from robot_mcp_kit.mcp_runtime import install_json_tool_errors, tool_error

logger = structlog.get_logger(__name__)

INSTRUCTIONS = (
    "The robot's episodic memory: what it saw (sightings with first/last seen, place, box), "
    "where it was (pose track, named places) and what happened (scene notes, missions, "
    "conversation). Pass times as -30s / -10m / -2h, ISO 8601, a clock time (15:00, 3 pm: the "
    "site's local time, pass it as the user said it) or now, each optionally with one offset "
    "('3pm -5m' to '3pm +5m' is around 3 pm), and places as the map's names: the "
    "server does the time arithmetic. Answers carry ISO UTC times, the site's local clock, "
    "'N s ago' and record ids; an 'answer' sentence can be read to the user as is."
)

TimeText = Annotated[
    str,
    Field(
        description="ISO 8601, relative (-30s, -10m, -2h, -1d), a clock time in the site's "
        "time zone (15:00, 3 pm) or now; optionally one offset after it (3pm -5m, 15:00 +10m)"
    ),
]
PlaceName = Annotated[
    str | None, Field(description="A named place on the map (e.g. kitchen); omit for anywhere")
]


DELETERS = frozenset({BRAIN, LOCAL})


def deletion_refusal(caller: Caller) -> tuple[str, str] | None:
    """Why ``caller`` may not delete memories (code, sentence), or None when its principal
    may (the approval is checked next, by :func:`require_approval`)."""
    if caller.principal not in DELETERS:
        return (
            "not_permitted",
            f"only the robot's brain may delete memories; this client is {caller.principal!r}",
        )
    return None


def _jsonable(answer: dict[str, Any]) -> dict[str, Any]:
    decoded: dict[str, Any] = json.loads(json.dumps(answer, default=str))
    return decoded


async def _answer(tool: str, work: Callable[[], dict[str, Any]]) -> dict[str, Any]:
    try:
        return _jsonable(await asyncio.to_thread(work))
    except EpisodicError as exc:
        raise tool_error(exc.code, exc.detail) from exc
    except StoreError as exc:
        logger.warning("tool_failed", tool=tool, error="store_unavailable", detail=str(exc))
        raise tool_error("store_unavailable", str(exc)) from exc
    except Exception as exc:  # tool boundary: a readable error for the model, the trace for us
        logger.exception("tool_failed", tool=tool)
        raise tool_error(
            "internal_error", f"{tool} failed unexpectedly; the server logged the cause"
        ) from exc


def build_server(memory: Episodic, approvals: ApprovalVerifier | None = None) -> MCPServer:
    """The ``episodic`` MCP server bound to ``memory``. ``approvals``: the approval check
    (``serve_mcp`` installs one from ``MCP_APPROVAL_SECRET`` when it serves; tests pass one)."""
    server: MCPServer = MCPServer(SERVER_NAME, instructions=INSTRUCTIONS)

    @server.tool(annotations=READ_ONLY)
    async def what_happened(
        start: TimeText = "-10m",
        end: TimeText = "now",
        kinds: Annotated[
            list[str] | None,
            Field(description=f"Any of {', '.join(DIGEST_KINDS)}; omit for all"),
        ] = None,
        place: PlaceName = None,
        max_items: Annotated[int, Field(ge=1, le=500)] = 50,
    ) -> dict[str, Any]:
        """Call this for "what happened while I was away / in the last 10 minutes" or "what
        did you see a minute ago": a chronological digest of sightings, scene notes, mission
        events, conversation and places visited between start and end. Returns {"start",
        "end", "items": [{"time", "ago", "kind", "id", "text", "place", ...}], "count",
        "truncated", "summary"}; an empty list means nothing was recorded then (say so)."""
        return await _answer(
            "what_happened", lambda: memory.what_happened(start, end, kinds, place, max_items)
        )

    @server.tool(annotations=READ_ONLY)
    async def last_seen(
        query: Annotated[str, Field(description="What to look for, e.g. 'red mug'")],
        before: TimeText = "now",
        place: PlaceName = None,
        n: Annotated[int, Field(ge=1, le=50)] = 3,
    ) -> dict[str, Any]:
        """Call this for "when / where did you last see X": the newest sightings of X (before
        `before`), newest first, each with first and last seen (ISO time and "N s ago"), how
        long, the robot's place and pose, the box, the skill, and absent_since when the robot
        looked there again and X was gone. Returns {"found", "results", "answer"}; found=false
        means X was never seen (say so, do not guess)."""
        return await _answer("last_seen", lambda: memory.last_seen(query, before, place, n))

    @server.tool(annotations=READ_ONLY)
    async def search_memory(
        query: Annotated[str, Field(description="Words to look for in notes and labels")],
        start: Annotated[str | None, Field(description="Earliest time; omit for all")] = None,
        end: Annotated[str | None, Field(description="Latest time; omit for now")] = None,
        place: PlaceName = None,
        k: Annotated[int, Field(ge=1, le=100)] = 10,
    ) -> dict[str, Any]:
        """Call this to find anything the robot noted or saw by words (scene descriptions,
        what people said, mission notes, object labels); the time and place filters apply
        before ranking. Returns {"results": [{"time", "ago", "kind", "id", "text", "score"}],
        "found"}."""
        return await _answer(
            "search_memory", lambda: memory.search_memory(query, start, end, place, k)
        )

    @server.tool(annotations=READ_ONLY)
    async def pose_at(time: TimeText) -> dict[str, Any]:
        """Call this for "where were you at 3 pm / 10 minutes ago": the robot's recorded pose
        and named place nearest that time and the mission running then. Returns {"found",
        "place", "pose", "sample", "mission", "answer"}."""
        return await _answer("pose_at", lambda: memory.pose_at(time))

    @server.tool(annotations=READ_ONLY)
    async def known_labels() -> dict[str, Any]:
        """Call this to know which things the robot has ever seen (the labels of its
        sightings, sorted). Returns {"labels", "count"}."""
        return await _answer("known_labels", memory.known_labels)

    @server.tool(annotations=READ_ONLY)
    async def memory_status() -> dict[str, Any]:
        """Call this to know how far back memory goes and whether recording works: rows and
        time span per kind, size of index and recordings, retention horizon, last write per
        stream, recording gaps and the forget audit log."""
        return await _answer("memory_status", memory.memory_status)

    @server.tool(annotations=DELETES)
    async def forget(
        start: TimeText,
        end: TimeText,
        label: Annotated[str | None, Field(description="Only sightings of this label")] = None,
        place: PlaceName = None,
        dry_run: Annotated[
            bool, Field(description="true (default) previews; false deletes for good")
        ] = True,
    ) -> dict[str, Any]:
        """Call this only when a person asks the robot to forget something. With dry_run=true
        it returns what would be deleted ({"would_delete": counts}); ask the person to confirm,
        then call again with dry_run=false to delete it from the index and the recordings.
        Every deletion is audited (see memory_status)."""
        caller = current_caller()
        approved_by: str | None = None
        if not dry_run:
            refusal = deletion_refusal(caller)
            if refusal is not None:
                logger.warning("forget_refused", principal=caller.principal, error=refusal[0])
                raise tool_error(*refusal)
            try:
                approved_by = require_approval(caller).by  # verified once, logged
            except ApprovalError as refused:
                logger.warning("forget_refused", principal=caller.principal, error=refused.code)
                raise
        return await _answer(
            "forget", lambda: memory.forget(start, end, label, place, dry_run, approved_by)
        )

    @server.tool(annotations=RECORDS)
    async def record_note(
        kind: Annotated[
            str,
            Field(
                description="scene | mission_started | mission_finished | user | robot | "
                "event | observation"
            ),
        ],
        text: Annotated[str, Field(description="The note, one or a few sentences")],
        mission_id: str | None = None,
    ) -> dict[str, Any]:
        """Call this to remember an event: a mission started or finished, what the user said,
        what the robot said, a scene description. Stamped with the current time and place.
        Returns {"id", "time", "kind", "place"}."""
        return await _answer("record_note", lambda: memory.record_note(kind, text, mission_id))

    return install_caller_context(install_json_tool_errors(server), approvals)
