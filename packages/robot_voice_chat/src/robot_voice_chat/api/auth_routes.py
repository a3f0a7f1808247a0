"""/api/auth/* — operator login, logout and "who am I" for the UI."""

from __future__ import annotations

import asyncio
import math

import structlog
from fastapi import APIRouter, Request, Response
from fastapi.responses import JSONResponse
from pydantic import BaseModel, Field

from robot_voice_chat.api.auth import OperatorAuth
from robot_voice_chat.api.auth_middleware import session_cookie
from robot_voice_chat.api.auth_throttle import LoginThrottle

logger = structlog.get_logger(__name__)


class LoginRequest(BaseModel):
    username: str = Field(min_length=1, max_length=128)
    password: str = Field(min_length=1, max_length=1024)


class OperatorInfo(BaseModel):
    auth_enabled: bool
    operator: str | None


def _address(request: Request) -> str:
    # uvicorn has already replaced this with X-Forwarded-For when the peer is a trusted proxy.
    return request.client.host if request.client else "?"


def _secure(request: Request, auth: OperatorAuth) -> bool:
    mode = auth.config.cookie_secure
    return mode == "always" or (mode == "auto" and request.url.scheme == "https")


def build_router(auth: OperatorAuth | None) -> APIRouter:
    router = APIRouter(prefix="/api/auth", tags=["auth"])
    throttle = (
        LoginThrottle(auth.config.login_max_failures, auth.config.login_window_s) if auth else None
    )

    @router.post("/login", operation_id="login", response_model=OperatorInfo)
    async def login(body: LoginRequest, request: Request) -> Response:
        if auth is None or throttle is None:
            return JSONResponse({"detail": "operator login is disabled"}, status_code=404)
        address = _address(request)
        wait = throttle.retry_after(address)
        if wait > 0:
            logger.warning("login_throttled", client=address, username=body.username)
            return JSONResponse(
                {"detail": "too many failed logins; try again later"},
                status_code=429,
                headers={"Retry-After": str(math.ceil(wait))},
            )
        if not await asyncio.to_thread(auth.check_password, body.username, body.password):
            throttle.failed(address)
            logger.warning("login_failed", client=address, username=body.username)
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
            token = session_cookie(request.scope, auth.config.cookie_name)
            operator = auth.operator_for(token)
            auth.revoke(token)
            if operator is not None:
                logger.info("logout", operator=operator)
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
