"""Console entry point: ``robot-voice-chat --host 127.0.0.1 --port 8000``.

``robot-voice-chat hash-password`` prints the argon2 hash for ``ADMIN_PASSWORD_HASH``.
"""

from __future__ import annotations

import argparse
import shlex
import socket
import sys
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

import structlog
import uvicorn

from robot_voice_chat.api.app import create_asgi_app
from robot_voice_chat.api.auth_cli import hash_password_command
from robot_voice_chat.api.auth_guard import PublicBindRefusedError, ensure_bind_allowed
from robot_voice_chat.api.forwarded import unix_listener
from robot_voice_chat.api.socket import end_socket_sessions
from robot_voice_chat.composition import ConfigError, bootstrap, compose_config, one_line
from robot_voice_chat.logging import configure_logging
from robot_voice_chat.settings import EnvSettings


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["hash-password"]:
        return hash_password_command(argv[1:])
    parser = argparse.ArgumentParser(prog="robot-voice-chat", description=__doc__)
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=8000)
    parser.add_argument(
        "--proxy-socket",
        type=Path,
        help="also listen on this Unix socket for the TLS reverse proxy (its forwarded headers "
        "are believed; deploy/Caddyfile)",
    )
    parser.add_argument("overrides", nargs="*", help="Hydra overrides, e.g. agent.max_llm_steps=20")
    args = parser.parse_args(argv)
    env = EnvSettings()
    configure_logging(env.log_level, env.log_format)
    logger = structlog.get_logger("robot_voice_chat.main")
    # RVC_CONFIG_OVERRIDES="llm_planner=anthropic agent.max_llm_steps=20" (like the vision
    # node's overrides); command-line overrides come last and win.
    overrides = [*shlex.split(env.config_overrides), *args.overrides]
    try:
        config = compose_config(env.deployment, overrides)
        ensure_bind_allowed(args.host, config.auth.enabled)
        container = bootstrap(config)
    except (ConfigError, ValueError, PublicBindRefusedError) as exc:
        logger.error("startup_refused", deployment=env.deployment, error=one_line(str(exc)))
        return 2
    sockets = []
    if args.proxy_socket is not None:
        try:
            sockets.append(unix_listener(args.proxy_socket))
        except (OSError, ValueError) as exc:
            logger.error("startup_refused", deployment=env.deployment, error=one_line(str(exc)))
            return 2
        logger.info("proxy_socket_listening", path=str(args.proxy_socket))
    server = BrainServer(
        server_config(create_asgi_app(container), args.host, args.port),
        before_shutdown=lambda: end_socket_sessions(container.sio),
    )
    server.run(sockets=[server.config.bind_socket(), *sockets])
    return 0


GRACEFUL_SHUTDOWN_S = 10  # then open requests (a long poll) are cut: systemd stops at 15 s


class BrainServer(uvicorn.Server):
    """uvicorn that first ends what would hold its graceful stop open (Socket.IO's long polls)
    and then stops as usual: a stop takes as long as the open requests need, not
    ``GRACEFUL_SHUTDOWN_S``."""

    def __init__(
        self, config: uvicorn.Config, before_shutdown: Callable[[], Awaitable[None]]
    ) -> None:
        super().__init__(config)
        self._before_shutdown = before_shutdown

    async def shutdown(self, sockets: list[socket.socket] | None = None) -> None:
        for server in self.servers:  # no new connections while the sessions end
            server.close()
        await self._before_shutdown()
        await super().shutdown(sockets=sockets)


def server_config(app: Any, host: str, port: int) -> uvicorn.Config:
    """uvicorn without its own proxy-header handling: the app believes forwarded headers from
    the proxy socket and ``auth.trusted_proxies`` only (api/forwarded.py); a stop never waits
    on a client for longer than ``GRACEFUL_SHUTDOWN_S``."""
    return uvicorn.Config(
        app,
        host=host,
        port=port,
        log_config=None,
        proxy_headers=False,
        timeout_graceful_shutdown=GRACEFUL_SHUTDOWN_S,
    )


if __name__ == "__main__":
    sys.exit(main())
