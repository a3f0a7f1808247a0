"""MCP-native confirmation of motion for third-party hosts (``NAV_CONFIRM_MOTION=elicit``).

Before each ``navigate_to`` the server asks the connected client, through MCP elicitation, to
have a person confirm the drive, the destination in the question. Only an accepted answer with
``confirm: true`` drives. A client that cannot be asked (no elicitation capability) gets a clean
refusal saying how to enable motion — never an automatic yes.
"""

from __future__ import annotations

from mcp.server.mcpserver import Context
from mcp.shared.exceptions import NoBackChannelError
from mcp.types import ClientCapabilities, ElicitationCapability
from pydantic import BaseModel, Field

from robot_mcp_kit.mcp_runtime import tool_error
from robot_mcp_navigation.map import NavMap

CONFIRMATION_UNAVAILABLE = "MOTION_CONFIRMATION_UNAVAILABLE"
NOT_CONFIRMED = "MOTION_NOT_CONFIRMED"


class DriveConfirmation(BaseModel):
    confirm: bool = Field(description="Yes: the robot may drive there now")


def question(nav_map: NavMap, location: str) -> str:
    name = nav_map.resolve(location) or location
    known = nav_map.locations.get(name)
    where = f"{name} ({known.description})" if known is not None and known.description else name
    return (
        f"The robot is asked to drive to {where}. It will move among people and things. "
        "Confirm only if the way is clear. Drive there now?"
    )


def _unavailable(why: str) -> Exception:
    return tool_error(
        CONFIRMATION_UNAVAILABLE,
        "This navigation server asks a person to confirm every drive "
        f"(NAV_CONFIRM_MOTION=elicit), and this MCP client cannot ask ({why}). The robot did "
        "not move. To enable motion, connect with a client that supports MCP elicitation, or "
        "have the robot's operator run this server with NAV_CONFIRM_MOTION=off behind a host "
        "that asks itself.",
    )


class MotionConfirmer:
    """Asks a person, through the MCP client, to confirm each drive."""

    def __init__(self, nav_map: NavMap) -> None:
        self.nav_map = nav_map

    async def confirm(self, ctx: Context, location: str) -> None:
        """Return when a person said yes; else raise a tool error (the robot did not move)."""
        session = ctx.request_context.session
        wanted = ClientCapabilities(elicitation=ElicitationCapability())
        if not session.check_client_capability(wanted):
            raise _unavailable("it does not support MCP elicitation")
        try:
            answer = await ctx.elicit(question(self.nav_map, location), DriveConfirmation)
        except NoBackChannelError as exc:  # a connection that cannot carry the question
            raise _unavailable("this connection cannot carry a question to it") from exc
        if answer.action == "accept" and answer.data.confirm:
            return
        said = "declined" if answer.action != "cancel" else "cancelled the question"
        raise tool_error(
            NOT_CONFIRMED,
            f"The person {said}: the drive to {location!r} was not confirmed and the robot "
            "did not move. Ask them before trying again.",
        )
