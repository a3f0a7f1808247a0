"""SocketSessions: a socket is bound to the session it was opened with and closed when that
session expires, even if it never sends another event."""

from __future__ import annotations

from typing import Any

from pydantic import SecretStr

from robot_stack_testing import async_wait_until
from robot_voice_chat.api.auth import AdminSecrets, OperatorAuth, hash_password
from robot_voice_chat.api.socket_sessions import SocketSessions
from robot_voice_chat.settings import AuthConfig

HASH = hash_password("socket sessions")


class FakeManager:
    def eio_sid_from_sid(self, sid: str, namespace: str) -> str:
        return f"eio-{sid}"


class FakeEngine:
    def __init__(self) -> None:
        self.closed: list[str] = []

    async def disconnect(self, sid: str) -> None:
        self.closed.append(sid)


class FakeSio:
    """The two python-socketio calls SocketSessions makes, recorded."""

    def __init__(self) -> None:
        self.manager = FakeManager()
        self.eio = FakeEngine()
        self.disconnected: list[str] = []

    async def disconnect(self, sid: str) -> None:
        self.disconnected.append(sid)


def auth(ttl_s: int) -> OperatorAuth:
    secrets_ = AdminSecrets(password_hash=SecretStr(HASH), secret_key=SecretStr("k" * 40))
    return OperatorAuth.from_env(AuthConfig(enabled=True, session_ttl_s=ttl_s), secrets_)


def environ(token: str) -> dict[str, Any]:
    return {"HTTP_COOKIE": f"other=1; rvc_session={token}"}


async def test_a_socket_is_closed_when_its_session_expires() -> None:
    sio, operator = FakeSio(), auth(ttl_s=1)
    sessions = SocketSessions(sio, operator)
    assert sessions.attach("s1", environ(operator.issue())) is not None
    assert sessions.valid("s1")
    await async_wait_until(lambda: sio.disconnected == ["s1"], 10, "the expiry closing s1")
    # the transport is closed by a task of its own, after the socket
    await async_wait_until(lambda: sio.eio.closed == ["eio-s1"], 10, "the transport closed")
    assert not sessions.valid("s1")


async def test_only_the_logged_out_sessions_sockets_are_closed() -> None:
    sio, operator = FakeSio(), auth(ttl_s=3600)
    sessions = SocketSessions(sio, operator)
    mine, other = operator.issue(), operator.issue()
    session = sessions.attach("a", environ(mine))
    sessions.attach("b", environ(mine))
    sessions.attach("c", environ(other))
    assert session is not None
    operator.revoke(mine)
    assert not sessions.valid("a")
    await sessions.close_session(session.session_id)
    assert sorted(sio.disconnected) == ["a", "b"]
    assert sessions.valid("c")
    sessions.detach("c")  # its timer is cancelled with it


async def test_a_socket_without_a_valid_session_is_not_attached() -> None:
    sessions = SocketSessions(FakeSio(), auth(ttl_s=60))
    assert sessions.attach("x", {}) is None
    assert sessions.attach("y", environ("forged")) is None
    assert not sessions.valid("x")
