"""/api/auth/* — operator login, logout and "who am I" for the UI."""

from __future__ import annotations

import asyncio
import math
from collections.abc import Awaitable, Callable

import structlog
from fastapi import APIRouter, Request, Response
from fastapi.responses import JSONResponse
from pydantic import BaseModel, Field

from robot_voice_chat.api.auth import OperatorAuth
from robot_voice_chat.api.auth_middleware import session_cookie
from robot_voice_chat.api.auth_throttle import (
    LoginThrottle,
    PasswordChecksBusyError,
    PasswordCheckSlots,
)

logger = structlog.get_logger(__name__)

# Called with the session id a logout revoked (closes that session's open sockets).
LogoutListener = Callable[[str], Awaitable[None]]


class LoginRequest(BaseModel):
    username: str = Field(min_length=1, max_length=128)
    password: str = Field(min_length=1, max_length=1024)


class OperatorInfo(BaseModel):
    auth_enabled: bool
    operator: str | None


def _address(request: Request) -> str:
    # X-Forwarded-For has replaced this only for the proxy's connections (api/forwarded.py).
    return request.client.host if request.client else "?"


def _secure(request: Request, auth: OperatorAuth) -> bool:
    mode = auth.config.cookie_secure
    return mode == "always" or (mode == "auto" and request.url.scheme == "https")


def _too_many(detail: str, retry_after: float) -> JSONResponse:
    return JSONResponse(
        {"detail": detail},
        status_code=429,
        headers={"Retry-After": str(max(1, math.ceil(retry_after)))},
    )


def build_router(auth: OperatorAuth | None, on_logout: LogoutListener | None = None) -> APIRouter:
    router = APIRouter(prefix="/api/auth", tags=["auth"])
    throttle = (
        LoginThrottle(auth.config.login_max_failures, auth.config.login_window_s) if auth else None
    )
    slots = (
        PasswordCheckSlots(auth.config.login_concurrency, auth.config.login_queue) if auth else None
    )

    @router.post("/login", operation_id="login", response_model=OperatorInfo)
    async def login(body: LoginRequest, request: Request) -> Response:
        if auth is None or throttle is None or slots is None:
            return JSONResponse({"detail": "operator login is disabled"}, status_code=404)
        address = _address(request)
        # The attempt is counted before the slow check: parallel requests cannot outrun it.
        wait = throttle.reserve(address)
        if wait > 0:
            logger.warning("login_throttled", client=address)
            return _too_many("too many failed logins; try again later", wait)
        try:
            async with slots.slot():
                ok = await asyncio.to_thread(auth.check_password, body.username, body.password)
        except PasswordChecksBusyError:
            logger.warning("login_busy", client=address, checks=slots.admitted)
            return _too_many("too many logins at once; try again in a moment", 1)
        if not ok:
            # the typed user name is never logged (it is often a password typed in the wrong box)
            logger.warning("login_failed", client=address)
            return JSONResponse({"detail": "wrong username or password"}, status_code=401)
        throttle.succeeded(address)
        logger.info("login_succeeded", client=address, operator=auth.username)
        response = JSONResponse(
            OperatorInfo(auth_enabled=True, operator=auth.username).model_dump()
        )
        response.set_cookie(
            auth.config.cookie_name,
            auth.issue(),
            max_age=auth.config.session_ttl_s,
            path="/",
            httponly=True,
            samesite="strict",
            secure=_secure(request, auth),
        )
        return response

    @router.post("/logout", operation_id="logout", response_model=OperatorInfo)
    async def logout(request: Request) -> Response:
        response = JSONResponse(
            OperatorInfo(auth_enabled=auth is not None, operator=None).model_dump()
        )
        if auth is not None:
            session = auth.revoke(session_cookie(request.scope, auth.config.cookie_name))
            if session is not None:
                logger.info("logout", operator=session.operator)
                if on_logout is not None:
                    await on_logout(session.session_id)
            response.delete_cookie(
                auth.config.cookie_name,
                path="/",
                httponly=True,
                samesite="strict",
                secure=_secure(request, auth),
            )
        return response

    @router.get("/me", operation_id="whoami", response_model=OperatorInfo)
    async def me(request: Request) -> Response:
        if auth is None:
            return JSONResponse(OperatorInfo(auth_enabled=False, operator=None).model_dump())
        operator = auth.operator_for(session_cookie(request.scope, auth.config.cookie_name))
        if operator is None:
            return JSONResponse({"detail": "login required"}, status_code=401)
        return JSONResponse(OperatorInfo(auth_enabled=True, operator=operator).model_dump())

    return router
