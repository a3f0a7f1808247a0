from __future__ import annotations

import hashlib
import hmac
import shutil
import subprocess

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from robot_mcp_kit.signing import (
    HEADER_SIGNATURE,
    HEADER_TIMESTAMP,
    SIGNATURE_PREFIX,
    SignatureError,
    sign,
    signed_headers,
    verify,
    verify_headers,
)

secrets = st.binary(min_size=1, max_size=64) | st.text(min_size=1, max_size=40)
bodies = st.binary(max_size=512)
timestamps = st.integers(0, 10**11)


def reason_of(call: object) -> str:
    assert callable(call)
    with pytest.raises(SignatureError) as info:
        call()
    return info.value.reason


@given(secret=secrets, ts=timestamps, body=bodies)
def test_a_signature_verifies_against_its_own_secret_time_and_body(
    secret: str | bytes, ts: int, body: bytes
) -> None:
    signature = sign(secret, ts, body)
    assert signature.startswith(SIGNATURE_PREFIX)
    assert len(signature) == 7 + 64
    verify(secret, str(ts), body, signature, now=ts)
    verify(secret, ts, body, signature.upper().replace("SHA256=", "sha256="), now=ts + 300)


@given(secret=secrets, ts=timestamps, body=bodies, flip=st.integers(0, 10**6))
def test_any_change_to_the_body_breaks_the_signature(
    secret: str | bytes, ts: int, body: bytes, flip: int
) -> None:
    if body:
        index = flip % len(body)
        tampered = body[:index] + bytes([body[index] ^ 0x01]) + body[index + 1 :]
    else:
        tampered = b"x"
    signature = sign(secret, ts, body)
    assert reason_of(lambda: verify(secret, ts, tampered, signature, now=ts)) == "bad_signature"


@given(a=secrets, b=secrets, ts=timestamps, body=bodies)
def test_another_secret_or_timestamp_breaks_the_signature(
    a: str | bytes, b: str | bytes, ts: int, body: bytes
) -> None:
    key_a = a.encode() if isinstance(a, str) else a
    key_b = b.encode() if isinstance(b, str) else b
    assume(key_a != key_b)
    signature = sign(a, ts, body)
    assert reason_of(lambda: verify(b, ts, body, signature, now=ts)) == "bad_signature"
    assert reason_of(lambda: verify(a, ts + 1, body, signature, now=ts)) == "bad_signature"


@given(ts=timestamps, skew=st.integers(301, 10**6), sign_of_skew=st.sampled_from([-1, 1]))
def test_timestamps_outside_the_tolerance_are_clock_skew(
    ts: int, skew: int, sign_of_skew: int
) -> None:
    signature = sign("k", ts, b"{}")
    now = ts + sign_of_skew * skew
    assert reason_of(lambda: verify("k", ts, b"{}", signature, now=now)) == "clock_skew"
    verify("k", ts, b"{}", signature, now=now, tolerance_s=skew)


@pytest.mark.parametrize(
    "signature",
    ["", "sha256=", "sha1=" + "0" * 64, "sha256=" + "g" * 64, "sha256=" + "0" * 63, "0" * 64],
)
def test_a_malformed_signature_header_is_named_as_such(signature: str) -> None:
    assert reason_of(lambda: verify("k", 1, b"", signature, now=1)) == "malformed_header"


@pytest.mark.parametrize("ts", ["", "abc", "1.5", "-5", "1e9", " ", "12345678901234567"])
def test_a_malformed_timestamp_is_named_as_such(ts: str) -> None:
    signature = sign("k", 1, b"")
    assert reason_of(lambda: verify("k", ts, b"", signature, now=1)) == "malformed_timestamp"
    assert reason_of(lambda: sign("k", ts, b"")) == "malformed_timestamp"


def test_an_empty_secret_is_a_configuration_error() -> None:
    with pytest.raises(ValueError, match="empty"):
        sign("", 1, b"")
    with pytest.raises(ValueError, match="empty"):
        verify(b"", 1, b"", "sha256=" + "0" * 64)


def test_the_signature_matches_the_documented_recipe() -> None:
    body = b'{"event_id":"abc","seq":0}'
    expected = hmac.new(b"s3cret", b"1700000000." + body, hashlib.sha256).hexdigest()
    assert sign("s3cret", 1700000000, body) == "sha256=" + expected


@pytest.mark.skipif(shutil.which("openssl") is None, reason="openssl CLI not installed")
@settings(max_examples=25, deadline=None)
@given(
    secret=st.text(st.characters(min_codepoint=0x21, max_codepoint=0x7E), min_size=1, max_size=32),
    ts=timestamps,
    body=st.binary(max_size=256),
)
def test_the_signature_agrees_with_the_openssl_cli(secret: str, ts: int, body: bytes) -> None:
    openssl = shutil.which("openssl")
    assert openssl is not None
    out = subprocess.run(
        [openssl, "dgst", "-sha256", "-hmac", secret, "-r"],
        input=f"{ts}.".encode() + body,
        capture_output=True,
        check=True,
        timeout=10,
    ).stdout.decode()
    assert sign(secret, ts, body) == "sha256=" + out.split()[0]


@given(secret=st.binary(min_size=1, max_size=64), ts=timestamps, body=bodies)
def test_the_signature_agrees_with_the_cryptography_hmac(
    secret: bytes, ts: int, body: bytes
) -> None:
    from cryptography.hazmat.primitives import hashes
    from cryptography.hazmat.primitives import hmac as crypto_hmac

    mac = crypto_hmac.HMAC(secret, hashes.SHA256())
    mac.update(str(ts).encode() + b"." + body)
    assert sign(secret, ts, body) == "sha256=" + mac.finalize().hex()


def test_signed_headers_verify_by_header_lookup_in_any_case() -> None:
    body = b'{"x":1}'
    headers = signed_headers("perception", "p-secret", body, now=1_700_000_123.9)
    assert headers[HEADER_TIMESTAMP] == "1700000123"
    lowered = {k.lower(): v for k, v in headers.items()}
    secrets_by_server = {"perception": "p-secret", "navigation": None}
    assert verify_headers(lowered, body, secrets_by_server, now=1_700_000_123) == "perception"


def test_verify_headers_names_missing_headers_and_unknown_servers() -> None:
    body = b"{}"
    good = signed_headers("navigation", "n", body, now=100)
    secrets_by_server: dict[str, str | bytes | None] = {"navigation": "n", "memory": None}

    def check(headers: dict[str, str]) -> str:
        return reason_of(lambda: verify_headers(headers, body, secrets_by_server, now=100))

    assert check({k: v for k, v in good.items() if k != "X-RVC-Server"}) == "malformed_header"
    assert check({k: v for k, v in good.items() if k != HEADER_TIMESTAMP}) == "malformed_timestamp"
    assert check({k: v for k, v in good.items() if k != HEADER_SIGNATURE}) == "malformed_header"
    assert check({**good, "X-RVC-Server": "vacuum"}) == "unknown_server"
    assert check({**good, "X-RVC-Server": "memory"}) == "unknown_server"
    assert check({**good, HEADER_TIMESTAMP: "101"}) == "bad_signature"
