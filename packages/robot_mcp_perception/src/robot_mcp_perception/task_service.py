"""The configure surface behind ``~/create_vision_task``, ``~/manage_vision_task`` and
``~/list_vision_tasks`` (spec 000 §6.3, ARCHITECTURE §4.1), free of ROS types.

Each operation takes the request JSON and returns the reply payload, or raises
:class:`SkillError`; :func:`serve` turns both into ``(success, message)``.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from typing import Any

import structlog

from robot_mcp_perception.registry import SkillRegistry, SkillState, topics_for
from robot_mcp_perception.skills import Skill, SkillError, parse_json_object

logger = structlog.get_logger("robot_mcp_perception.services")

ACTIONS = ("enable", "disable", "delete")
Operation = Callable[[str], dict[str, Any]]


class TaskService:
    def __init__(
        self,
        registry: SkillRegistry,
        namespace: str,
        *,
        attach: Callable[[SkillState], None],
        detach: Callable[[SkillState], None],
        make_state: Callable[[Skill], SkillState] | None = None,
    ) -> None:
        """``attach`` creates a state's publishers; ``detach`` destroys them."""
        self.registry = registry
        self.namespace = namespace
        self._attach = attach
        self._detach = detach
        self._make_state = make_state or (
            lambda skill: SkillState(skill, topics_for(namespace, skill))
        )

    def create(self, data: str) -> dict[str, Any]:
        skill = Skill.from_json(data)
        if skill.name in self.registry:
            raise SkillError(
                "duplicate_name",
                f"a skill named {skill.name!r} already exists; delete it first or pick "
                "another name.",
            )
        state = self._make_state(skill)
        self._attach(state)
        try:
            self.registry.add(state)
        except SkillError:
            self._detach(state)
            raise
        logger.info("skill_created", skill=skill.name, mode=skill.mode, once=skill.once)
        return {"name": skill.name, "topics": state.topics.as_dict()}

    def manage(self, data: str) -> dict[str, Any]:
        request = parse_json_object(data, "request")
        name = request.get("task_name", request.get("name"))
        action = request.get("action")
        if not isinstance(name, str) or not name:
            raise SkillError("missing_field", "the request needs a 'task_name' string.")
        if action not in ACTIONS:
            raise SkillError(
                "invalid_action", f"action must be one of {', '.join(ACTIONS)}, got {action!r}."
            )
        if action == "delete":
            state = self.registry.remove(name)
            state.enabled = False
            self._detach(state)
            logger.info("skill_deleted", skill=name)
            return {"name": name, "action": action, "deleted": True}
        state = self.registry.get(name)
        state.enabled = action == "enable"
        if state.enabled:
            state.next_due = 0.0
        logger.info("skill_" + ("enabled" if state.enabled else "disabled"), skill=name)
        return {"name": name, "action": action, "enabled": state.enabled}

    def list(self, data: str) -> dict[str, Any]:
        if data.strip():
            parse_json_object(data, "request")
        return {"skills": [state.describe() for state in self.registry.states()]}


def serve(service: str, operation: Operation, data: str) -> tuple[bool, str]:
    """Run one service request; never raises (this is the service's process boundary)."""
    started = time.perf_counter()
    try:
        reply = operation(data)
    except SkillError as error:
        logger.warning(
            "vision_task_rejected",
            service=service,
            error=error.code,
            detail=error.detail,
            duration_ms=_ms(started),
        )
        return False, error.to_json()
    except Exception:
        logger.exception("vision_task_failed", service=service, duration_ms=_ms(started))
        detail = "the vision node failed to handle the request; see its log."
        return False, json.dumps({"error": "internal_error", "detail": detail})
    logger.info("vision_task_served", service=service, duration_ms=_ms(started))
    return True, json.dumps(reply, default=str)


def _ms(started: float) -> float:
    return round((time.perf_counter() - started) * 1000.0, 3)
