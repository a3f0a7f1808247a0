"""Start-up guard: never serve a non-loopback address without operator login."""

from __future__ import annotations

import ipaddress


class PublicBindRefusedError(RuntimeError):
    """Binding a network-reachable address with auth disabled."""


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:  # a host name other than localhost: may resolve to anything
        return False


def ensure_bind_allowed(host: str, auth_enabled: bool) -> None:
    """Raise :class:`PublicBindRefusedError` for a non-loopback ``host`` when auth is off."""
    if not auth_enabled and not is_loopback(host):
        raise PublicBindRefusedError(
            f"refusing to listen on {host} without operator login: set auth.enabled=true "
            "(RVC_DEPLOYMENT=robot) with ADMIN_PASSWORD_HASH and ADMIN_SECRET_KEY, "
            "or bind 127.0.0.1"
        )
