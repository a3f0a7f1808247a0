"""An MCP server's question to its client (elicitation) becomes the same approval card.

Our servers ask yes/no questions (e.g. navigation's NAV_CONFIRM_MOTION=elicit): one boolean
field. The brain answers such a question only with an operator's explicit yes on the approval
card (or a typed/spoken yes); a deny, a timeout, a stop or any other kind of form declines.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import structlog

from robot_voice_chat.control.approvals import ApprovalBroker
from robot_voice_chat.control.context import DispatchContext
from robot_voice_chat.services.tools.base import ElicitationAnswer, ElicitationHandler

logger = structlog.get_logger(__name__)


def yes_no_field(schema: dict[str, Any]) -> str | None:
    """The one boolean field of a yes/no question, else None (a form we cannot answer)."""
    fields = schema.get("properties") or {}
    if len(fields) != 1:
        return None
    ((name, spec),) = fields.items()
    return name if isinstance(spec, dict) and spec.get("type") == "boolean" else None


def approval_elicitation(
    broker: ApprovalBroker,
    current_mission: Callable[[], str | None],
    call_timeout_s: float | None = None,
) -> ElicitationHandler:
    """``call_timeout_s``: the deadline of the tool call the question arrives in; the card
    expires (denied) a little before it, so no answer can come after the call gave up."""
    ask_timeout = max(1.0, call_timeout_s * 0.9) if call_timeout_s is not None else None

    async def answer(server: str, message: str, schema: dict[str, Any]) -> ElicitationAnswer:
        field = yes_no_field(schema)
        if field is None:
            logger.warning("elicitation_declined", server=server, reason="not a yes/no question")
            return "decline", None
        context = DispatchContext(mission_id=current_mission())
        verdict = await broker.ask(
            f"{server}.elicitation",
            {"question": message},
            f"the {server} server asks",
            context,
            timeout_s=ask_timeout,
        )
        logger.info("elicitation_answered", server=server, approved=verdict.approved)
        return ("accept", {field: True}) if verdict.approved else ("decline", None)

    return answer
