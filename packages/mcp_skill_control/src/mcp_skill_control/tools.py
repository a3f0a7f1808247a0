"""What the six (+ prewarm) MCP tools do, independent of MCP: plain async methods that
return JSON-able dicts and raise :class:`CatalogError` / ``RosBridgeError`` on failure.

skill ids: the vision node keys skills by name. A template's skill is named after the
template; if that name is already running, a counter suffix is added (``find_object_2``) and
the mapping skill_id -> template/params is kept for :meth:`running_skills`.
"""

from __future__ import annotations

import asyncio
from dataclasses import dataclass
from typing import Any

import structlog

from mcp_skill_control.catalog import Catalog, CatalogError, validate_skill
from mcp_skill_control.reconcile import CreateReconciler
from robot_ros_bridge import RemoteError, ServiceTimeoutError
from robot_ros_bridge.vision_tasks import VisionTasks
from robot_skill_schema import is_topic_token

logger = structlog.get_logger(__name__)

TOPIC_NS = "/vision"
WATCH_SERVER = "perception"
"""The server that evaluates watchers and owns their task tools (ARCHITECTURE.md §4.4)."""
WATCH_TOOL = "instantiate_skill"
"""The ``tool`` of a watcher task and of its ``watch_event``s: the tool that started it."""
MAX_SUFFIX = 999


def watch_task_id(skill_id: str) -> str:
    return f"watch-{skill_id}"


@dataclass(frozen=True)
class _Origin:
    template: str | None
    params: dict[str, Any]


class SkillControl:
    """The application service behind the MCP tools."""

    def __init__(
        self, catalog: Catalog, tasks: VisionTasks, reconciler: CreateReconciler | None = None
    ) -> None:
        self._catalog = catalog
        self._tasks = tasks
        self._reconciler = reconciler or CreateReconciler(tasks, confirm_s=5.0, sweep_s=60.0)
        self._origins: dict[str, _Origin] = {}
        self._create_lock = asyncio.Lock()
        # Watcher skill ids are never reused in this process life: the task id is
        # "watch-<skill_id>" (ARCHITECTURE §4.4), so a new watcher never shares it with a
        # finished one whose late events may still be on their way (issue 23 item 6).
        self._watcher_ids: set[str] = set()

    # -- discovery -----------------------------------------------------------------------
    def templates(self) -> dict[str, Any]:
        return {"templates": [t.summary() for t in self._catalog.list()]}

    async def running_skills(self) -> dict[str, Any]:
        skills = []
        for info in await self._tasks.list():
            name = str(info.get("name", ""))
            origin = self._origins.get(name)
            entry: dict[str, Any] = {
                "skill_id": name,
                "name": name,
                "topic": f"{TOPIC_NS}/{name}/detections",
                "semantic_topics": _semantic_topics(name, info.get("outputs", [])),
                "enabled": bool(info.get("enabled", True)),
                "mode": info.get("mode"),
                "once": bool(info.get("once", False)),
            }
            if origin is not None:
                entry["template"] = origin.template
                entry["params"] = origin.params
            if isinstance(info.get("watch"), dict):
                entry["watch"] = info["watch"]
                entry["task_id"] = watch_task_id(name)
            skills.append(entry)
        return {"skills": skills}

    # -- creation ------------------------------------------------------------------------
    async def instantiate(self, template: str, params: dict[str, Any]) -> dict[str, Any]:
        skill = self._catalog.fill(template, params)
        return await self._create(skill, _Origin(template, dict(params)))

    async def instantiate_raw(self, skill: dict[str, Any]) -> dict[str, Any]:
        if not isinstance(skill.get("name"), str) or not skill.get("name"):
            skill = {**skill, "name": f"raw_{skill.get('mode', 'skill')}"}
        return await self._create(validate_skill(skill), _Origin(None, {}))

    async def prewarm(self, template: str, params: dict[str, Any]) -> dict[str, Any]:
        skill = self._catalog.fill(template, params)
        if not str(skill.get("grounding", "")).strip():
            raise CatalogError(
                "nothing_to_prewarm",
                f"template {template!r} has no grounding to cache; prewarm a grounding "
                "template such as find_object or free_space",
            )
        skill.pop("watch", None)
        skill.update(name=f"prewarm_{template}", prewarm=True, once=True)
        created = await self._create(validate_skill(skill), _Origin(template, dict(params)))
        return {
            "skill_id": created["skill_id"],
            "prewarm": True,
            "grounding": skill["grounding"],
            "note": (
                "the grounding is cached on the vision node; instantiate the same template "
                "with the same params soon to reuse it (one grounder call)"
            ),
        }

    async def _create(self, skill: dict[str, Any], origin: _Origin) -> dict[str, Any]:
        base = str(skill["name"])
        async with self._create_lock:
            taken = {str(s.get("name")) for s in await self._tasks.list()}
            watcher = isinstance(skill.get("watch"), dict)
            if watcher:
                taken |= self._watcher_ids
            for _attempt in range(3):
                skill_id = _free_name(base, taken)
                try:
                    await self._create_or_adopt({**skill, "name": skill_id})
                    break
                except RemoteError as error:
                    if error.code != "duplicate_name":
                        raise
                    taken.add(skill_id)  # created by someone else in between: next suffix
            else:
                raise CatalogError("name_collision", f"could not find a free name for {base!r}")
            self._origins[skill_id] = origin
            if watcher:
                self._watcher_ids.add(skill_id)
        logger.info("skill_instantiated", skill_id=skill_id, template=origin.template)
        result: dict[str, Any] = {
            "skill_id": skill_id,
            "name": skill_id,
            "topic": f"{TOPIC_NS}/{skill_id}/detections",
            "meta_topic": f"{TOPIC_NS}/{skill_id}/detections_meta",
            "semantic_topics": _semantic_topics(skill_id, skill.get("outputs", [])),
            "mode": skill["mode"],
            "once": bool(skill.get("once", False)),
        }
        if origin.template is not None:
            result["template"] = origin.template
        watch = skill.get("watch")
        if isinstance(watch, dict):
            result.update(
                task_id=watch_task_id(skill_id),
                state="running",
                est_duration_s=None,
                server=WATCH_SERVER,
                tool=WATCH_TOOL,
                watch=watch,
            )
        return result

    async def _create_or_adopt(self, skill: dict[str, Any]) -> None:
        """Create ``skill``; after a timeout adopt it if the node lists it, else report the
        timeout and make sure a late creation is removed (no orphan skill)."""
        name = str(skill["name"])
        try:
            await self._tasks.create(skill)
        except ServiceTimeoutError as error:
            if await self._reconciler.find(skill):
                logger.warning("skill_create_reconciled", skill_id=name, outcome="adopted")
                return
            self._reconciler.sweep_later(skill)
            logger.error("skill_create_reconciled", skill_id=name, outcome="not_created")
            raise ServiceTimeoutError(
                f"{error.detail}; the skill {name!r} did not appear in the node's list either, "
                "so it is not running (if the node creates it late it is removed). Check the "
                "vision node and retry."
            ) from error
        self._reconciler.cancel_sweep(name)

    async def close(self) -> None:
        await self._reconciler.close()

    # -- control -------------------------------------------------------------------------
    async def stop(self, skill_id: str) -> dict[str, Any]:
        await self._tasks.manage(skill_id, "delete")
        self._origins.pop(skill_id, None)
        return {"skill_id": skill_id, "stopped": True}

    async def set_enabled(self, skill_id: str, enabled: bool) -> dict[str, Any]:
        await self._tasks.manage(skill_id, "enable" if enabled else "disable")
        return {"skill_id": skill_id, "enabled": enabled}


def _free_name(base: str, taken: set[str]) -> str:
    if base not in taken:
        return base
    for counter in range(2, MAX_SUFFIX + 1):
        suffix = f"_{counter}"
        candidate = base[: 63 - len(suffix)] + suffix
        if candidate not in taken and is_topic_token(candidate):
            return candidate
    raise CatalogError("name_collision", f"too many skills named {base!r}")


def _semantic_topics(skill_id: str, outputs: Any) -> list[str]:
    if not isinstance(outputs, list):
        return []
    return [
        f"{TOPIC_NS}/{skill_id}/{o['name']}"
        for o in outputs
        if isinstance(o, dict) and isinstance(o.get("name"), str)
    ]
