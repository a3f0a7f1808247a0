"""Which Socket.IO connection belongs to which operator session — and closing it when that
session ends: at logout, at expiry (a timer), and on any event sent after either."""

from __future__ import annotations

import asyncio
from collections.abc import Coroutine
from typing import Any

import structlog

from robot_voice_chat.api.auth import OperatorAuth, Session
from robot_voice_chat.api.auth_middleware import cookie_value

logger = structlog.get_logger(__name__)
TRANSPORT_CLOSE_WAIT_S = 10.0  # for the client to fetch the close packet (polling)


class SocketSessions:
    def __init__(self, sio: Any, auth: OperatorAuth) -> None:
        self._sio = sio
        self._auth = auth
        self._tokens: dict[str, str] = {}  # socket id → session token
        self._session_ids: dict[str, str] = {}  # socket id → session id
        self._timers: dict[str, asyncio.TimerHandle] = {}
        self._closing: set[asyncio.Task[None]] = set()

    def attach(self, sid: str, environ: dict[str, Any]) -> Session | None:
        """Bind socket ``sid`` to the session in its Cookie header; None when there is none."""
        token = cookie_value(str(environ.get("HTTP_COOKIE", "")), self._auth.config.cookie_name)
        session = self._auth.session(token)
        if session is None or token is None:
            return None
        self._tokens[sid] = token
        self._session_ids[sid] = session.session_id
        delay = max(0.0, session.expires_at - self._auth.clock())
        loop = asyncio.get_running_loop()
        self._timers[sid] = loop.call_later(delay, self.close_soon, sid, "session_expired")
        return session

    def valid(self, sid: str) -> bool:
        """Whether ``sid``'s session is still valid (not logged out, not expired)."""
        return self._auth.session(self._tokens.get(sid)) is not None

    def detach(self, sid: str) -> None:
        self._tokens.pop(sid, None)
        self._session_ids.pop(sid, None)
        timer = self._timers.pop(sid, None)
        if timer is not None:
            timer.cancel()

    async def close(self, sid: str, reason: str) -> None:
        """Leave the Socket.IO namespace now (no event reaches ``sid`` after this returns),
        then close the transport in the background: Engine.IO waits until the client has
        fetched the close packet, which an idle long-polling client never does."""
        logger.info("socket_session_closed", sid=sid, reason=reason)
        self.detach(sid)
        eio_sid = self._sio.manager.eio_sid_from_sid(sid, "/")
        await self._sio.disconnect(sid)
        if eio_sid is not None:  # the transport too: a raw client cannot re-join on it
            self._spawn(self._close_transport(sid, eio_sid))

    async def _close_transport(self, sid: str, eio_sid: str) -> None:
        try:
            async with asyncio.timeout(TRANSPORT_CLOSE_WAIT_S):
                await self._sio.eio.disconnect(eio_sid)
        except TimeoutError:
            # closed on our side already; Engine.IO drops it from its table by itself
            logger.info("socket_transport_close_unfetched", sid=sid)

    async def close_session(self, session_id: str) -> None:
        """Disconnect every socket opened with ``session_id`` (called at logout); returns
        once none of them receives events, without waiting for any client."""
        sids = [s for s, sess in self._session_ids.items() if sess == session_id]
        await asyncio.gather(*(self.close(sid, "logout") for sid in sids))

    def _spawn(self, work: Coroutine[Any, Any, None]) -> None:
        task = asyncio.get_running_loop().create_task(work)
        self._closing.add(task)
        task.add_done_callback(self._closing.discard)

    def close_soon(self, sid: str, reason: str) -> None:
        """Close ``sid`` from a task of its own (safe from inside that socket's handlers)."""
        self._spawn(self.close(sid, reason))
