"""HMAC-SHA256 signing of pushed events (ARCHITECTURE §4.3).

The signed message is the ASCII timestamp, a dot and the exact body bytes::

    sha256=<hex of HMAC-SHA256(secret, ts_ascii + b"." + raw_body)>

``ts`` is unix seconds as a decimal string, sent in ``X-RVC-Timestamp``; the receiver rejects
timestamps more than ``tolerance_s`` away from its own clock.
"""

from __future__ import annotations

import hashlib
import hmac
import re
import time
from collections.abc import Mapping
from typing import Literal

SIGNATURE_PREFIX = "sha256="
HEADER_SERVER = "X-RVC-Server"
HEADER_TIMESTAMP = "X-RVC-Timestamp"
HEADER_SIGNATURE = "X-RVC-Signature"
DEFAULT_TOLERANCE_S = 300.0

SignatureReason = Literal[
    "malformed_header", "malformed_timestamp", "clock_skew", "bad_signature", "unknown_server"
]

_TIMESTAMP = re.compile(r"[0-9]{1,15}")
_SIGNATURE = re.compile(r"sha256=([0-9a-fA-F]{64})")


class SignatureError(ValueError):
    """A request whose signature cannot be accepted; ``reason`` says why."""

    def __init__(self, reason: SignatureReason, message: str) -> None:
        super().__init__(message)
        self.reason: SignatureReason = reason


def _secret_bytes(secret: str | bytes) -> bytes:
    key = secret.encode("utf-8") if isinstance(secret, str) else bytes(secret)
    if not key:
        raise ValueError("the signing secret is empty; configure a real secret")
    return key


def _timestamp_text(ts: int | str) -> str:
    if isinstance(ts, bool) or not isinstance(ts, int | str):
        raise SignatureError("malformed_timestamp", f"timestamp must be int or str, got {ts!r}")
    text = str(ts)
    if not _TIMESTAMP.fullmatch(text):
        raise SignatureError(
            "malformed_timestamp", f"timestamp must be unix seconds as digits, got {text[:40]!r}"
        )
    return text


def _digest(key: bytes, ts_text: str, raw_body: bytes) -> str:
    message = ts_text.encode("ascii") + b"." + raw_body
    return hmac.new(key, message, hashlib.sha256).hexdigest()


def sign(secret: str | bytes, ts: int | str, raw_body: bytes) -> str:
    """The ``X-RVC-Signature`` value for ``raw_body`` sent at unix second ``ts``."""
    return SIGNATURE_PREFIX + _digest(_secret_bytes(secret), _timestamp_text(ts), raw_body)


def verify(
    secret: str | bytes,
    ts: str | int,
    raw_body: bytes,
    signature: str,
    now: float | None = None,
    tolerance_s: float = DEFAULT_TOLERANCE_S,
) -> None:
    """Accept (return None) or raise :class:`SignatureError` with a reason.

    Checks, in order: the header shape (``malformed_header``), the timestamp shape
    (``malformed_timestamp``), the HMAC in constant time (``bad_signature``), then the clock
    (``clock_skew``: ``|now - ts| > tolerance_s``).
    """
    key = _secret_bytes(secret)
    match = _SIGNATURE.fullmatch(signature.strip()) if isinstance(signature, str) else None
    if match is None:
        raise SignatureError(
            "malformed_header",
            f"{HEADER_SIGNATURE} must be 'sha256=' followed by 64 hex digits",
        )
    ts_text = _timestamp_text(ts.strip() if isinstance(ts, str) else ts)
    expected = _digest(key, ts_text, raw_body)
    if not hmac.compare_digest(expected, match.group(1).lower()):
        raise SignatureError("bad_signature", "the signature does not match the body and secret")
    current = time.time() if now is None else now
    skew = current - int(ts_text)
    if abs(skew) > tolerance_s:
        raise SignatureError(
            "clock_skew",
            f"timestamp is {skew:+.0f}s away from the receiver's clock "
            f"(tolerance ±{tolerance_s:.0f}s)",
        )


def signed_headers(
    server: str, secret: str | bytes, raw_body: bytes, now: float | None = None
) -> dict[str, str]:
    """The three ``X-RVC-*`` headers for posting ``raw_body`` as ``server``."""
    ts = int(time.time() if now is None else now)
    return {
        HEADER_SERVER: server,
        HEADER_TIMESTAMP: str(ts),
        HEADER_SIGNATURE: sign(secret, ts, raw_body),
    }


def verify_headers(
    headers: Mapping[str, str],
    raw_body: bytes,
    secrets: Mapping[str, str | bytes | None],
    now: float | None = None,
    tolerance_s: float = DEFAULT_TOLERANCE_S,
) -> str:
    """Framework-free receiver check: verify a request by its headers; return the server name.

    ``secrets`` maps server names to their event secret; a server that is missing or has no
    secret is rejected with ``unknown_server``. Header names are matched case-insensitively.
    """
    lowered = {name.lower(): value for name, value in headers.items()}
    server = lowered.get(HEADER_SERVER.lower())
    ts = lowered.get(HEADER_TIMESTAMP.lower())
    signature = lowered.get(HEADER_SIGNATURE.lower())
    if not server:
        raise SignatureError("malformed_header", f"missing {HEADER_SERVER} header")
    if ts is None:
        raise SignatureError("malformed_timestamp", f"missing {HEADER_TIMESTAMP} header")
    if signature is None:
        raise SignatureError("malformed_header", f"missing {HEADER_SIGNATURE} header")
    secret = secrets.get(server)
    if not secret:
        raise SignatureError(
            "unknown_server", f"no event secret is configured for server {server[:64]!r}"
        )
    verify(secret, ts, raw_body, signature, now=now, tolerance_s=tolerance_s)
    return server
