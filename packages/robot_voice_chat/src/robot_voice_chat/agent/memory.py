"""MemoryClient: the executor's thin wrapper over the memory MCP server (via the ToolBackend)."""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from typing import Any

import structlog

from robot_voice_chat.services.tools.base import ToolBackend

logger = structlog.get_logger(__name__)


@dataclass
class ProcessDoc:
    id: str
    title: str
    score: float | None
    text: str


class MemoryError(RuntimeError):
    pass


def _items(data: Any) -> list[dict[str, Any]]:
    if isinstance(data, dict):
        data = data.get("processes", data.get("results", data.get("items", [])))
    return [d for d in data if isinstance(d, dict)] if isinstance(data, list) else []


class MemoryClient:
    def __init__(self, tools: ToolBackend, server: str, timeout_s: float = 30.0) -> None:
        self._tools = tools
        self._server = server
        self._timeout_s = timeout_s

    @property
    def enabled(self) -> bool:
        return bool(self._server)

    async def find_processes(self, query: str, k: int) -> list[ProcessDoc]:
        if not self.enabled:
            return []
        outcome = await self._tools.call_tool(
            f"{self._server}.find_processes", {"query": query, "k": k}, self._timeout_s
        )
        if outcome.is_error:
            logger.warning("processes_retrieval_failed", error=outcome.text[:200])
            return []
        try:
            data = json.loads(outcome.text)
        except ValueError:
            return []
        docs = []
        for item in _items(data)[:k]:
            doc_id = item.get("id") or item.get("process_id")
            if not doc_id:
                continue
            body = item.get("markdown") or item.get("body") or item.get("text") or ""
            score = item.get("score")
            docs.append(
                ProcessDoc(
                    id=str(doc_id),
                    title=str(item.get("title", doc_id)),
                    score=float(score) if isinstance(score, int | float) else None,
                    text=str(body),
                )
            )
        return docs

    async def record_outcome(self, process_id: str, success: bool, note: str) -> None:
        if not self.enabled:
            return
        outcome = await self._tools.call_tool(
            f"{self._server}.record_outcome",
            {"process_id": process_id, "success": success, "note": note},
            self._timeout_s,
        )
        if outcome.is_error:
            logger.warning("record_outcome_failed", process_id=process_id, error=outcome.text)

    async def save_process(self, markdown: str) -> str:
        if not self.enabled:
            raise MemoryError("no memory server configured")
        outcome = await self._tools.call_tool(
            f"{self._server}.save_process", {"markdown": markdown}, self._timeout_s
        )
        if outcome.is_error:
            raise MemoryError(outcome.text)
        try:
            data = json.loads(outcome.text)
        except ValueError:
            data = None
        if isinstance(data, dict) and (data.get("id") or data.get("process_id")):
            return str(data.get("id") or data.get("process_id"))
        match = re.search(r"[A-Za-z0-9][\w\-]+", outcome.text)
        if match is None:
            raise MemoryError(f"save_process returned no id: {outcome.text[:200]}")
        return match.group(0)
