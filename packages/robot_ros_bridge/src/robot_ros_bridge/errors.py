"""Errors the bridge raises; each carries a stable ``code`` and a human ``detail``."""

from __future__ import annotations


class RosBridgeError(Exception):
    """Base class: a ROS call that did not produce a usable answer."""

    code = "ros_error"

    def __init__(self, detail: str) -> None:
        super().__init__(detail)
        self.detail = detail


class ServiceUnavailableError(RosBridgeError):
    """No server answers on the service name (node down or not discovered yet)."""

    code = "service_unavailable"


class ServiceTimeoutError(RosBridgeError):
    """The service was there but did not answer within the call's deadline."""

    code = "service_timeout"


class BridgeClosedError(RosBridgeError):
    """The bridge was shut down; no more ROS calls can be made."""

    code = "bridge_closed"


class RemoteError(RosBridgeError):
    """The service answered ``success=false`` with a ``{"error", "detail"}`` payload."""

    def __init__(self, code: str, detail: str) -> None:
        super().__init__(detail)
        self.code = code
