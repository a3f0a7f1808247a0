"""Who may read the artifacts endpoint's pictures: a bearer token (issue 35).

The camera frame (``/frames/latest.jpg``), masks and overlays show the inside of the building
the robot works in; any local process could fetch them before. They now need
``Authorization: Bearer <token>`` — the same scheme as the MCP servers' ``MCP_AUTH_TOKEN``
(``robot_mcp_kit.service_auth``; not imported: the vision node does not depend on the MCP kit
and its framework). ``/healthz`` stays open: readiness checks (systemd, the local stack, a
load balancer) carry no credential, and it shows no pixels.

Environment (read by :func:`artifacts_auth_from_env`):

- ``ARTIFACTS_AUTH_TOKEN``: the credential (≥ 32 bytes); the brain's copy is
  ``VISION_ARTIFACTS_TOKEN`` (its camera proxy sends it). ``deploy/install.sh`` generates one
  into ``vision.env`` and ``brain.env``; the local stack draws a fresh one per run.
- ``ARTIFACTS_AUTH=off``: pictures open to every local process (a throwaway dev node; logged
  ``artifacts_auth_disabled``; refused together with a token).
- Neither: the node starts (every preset boots as shipped) but refuses every picture with
  401 saying no credential is configured — closed, never open by omission.

The token is a ``SecretStr``, never logged; a refusal logs ``artifacts_auth_rejected`` with
why (``missing`` / ``invalid`` / ``unconfigured``), the path and the client — never what was
presented.
"""

from __future__ import annotations

import hmac
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal

from pydantic import SecretStr

from robot_mcp_perception.settings import StartupError

# names of variables, not secrets
ENV_TOKEN = "ARTIFACTS_AUTH_TOKEN"  # noqa: S105
ENV_MODE = "ARTIFACTS_AUTH"
MIN_TOKEN_BYTES = 32
NEW_TOKEN_HINT = "python3 -c 'import secrets; print(secrets.token_urlsafe(32))'"  # noqa: S105

Verdict = Literal["ok", "missing", "invalid", "unconfigured"]


@dataclass(frozen=True)
class ArtifactsAuth:
    """The credential pictures need; ``open`` only with ``ARTIFACTS_AUTH=off``. The default
    (no token, not open) refuses every picture."""

    token: SecretStr | None = None
    open: bool = False

    def __post_init__(self) -> None:
        if self.open and self.token is not None:
            raise StartupError(f"{ENV_MODE}=off but {ENV_TOKEN} is set: remove one of them")

    def check(self, authorization: str | None) -> Verdict:
        """Whether a request with this ``Authorization`` header value may read a picture
        (the token compared in constant time)."""
        if self.open:
            return "ok"
        if self.token is None:
            return "unconfigured"
        presented = bearer_token(authorization)
        if presented is None:
            return "missing"
        expected = self.token.get_secret_value().encode()
        return "ok" if hmac.compare_digest(presented.encode(), expected) else "invalid"


def bearer_token(header: str | None) -> str | None:
    """The token of an ``Authorization: Bearer <token>`` value (scheme case-insensitive)."""
    if header is None:
        return None
    scheme, _, token = header.strip().partition(" ")
    if scheme.lower() != "bearer" or not token.strip():
        return None
    return token.strip()


def artifacts_auth_from_env(env: Mapping[str, str]) -> ArtifactsAuth:
    """The credential from the environment (module doc); a bad setting is a
    :class:`StartupError` (exit code 2, one line naming the variable)."""
    mode = env.get(ENV_MODE, "required").strip().lower() or "required"
    if mode not in ("required", "off"):
        raise StartupError(f"{ENV_MODE} must be 'required' or 'off', got {mode!r}")
    token = env.get(ENV_TOKEN, "").strip()
    if mode == "off":
        return ArtifactsAuth(SecretStr(token) if token else None, open=True)
    if not token:
        return ArtifactsAuth()
    size = len(token.encode())
    if size < MIN_TOKEN_BYTES:
        raise StartupError(
            f"{ENV_TOKEN} is {size} bytes; at least {MIN_TOKEN_BYTES} are required "
            f"({NEW_TOKEN_HINT})"
        )
    return ArtifactsAuth(SecretStr(token))
