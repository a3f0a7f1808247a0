"""Console entry point: ``robot-voice-chat --host 127.0.0.1 --port 8000``."""

from __future__ import annotations

import argparse
import shlex
import sys

import structlog
import uvicorn

from robot_voice_chat.api.app import create_asgi_app
from robot_voice_chat.composition import ConfigError, bootstrap, compose_config, one_line
from robot_voice_chat.logging import configure_logging
from robot_voice_chat.settings import EnvSettings


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="robot-voice-chat", description=__doc__)
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=8000)
    parser.add_argument("overrides", nargs="*", help="Hydra overrides, e.g. agent.max_llm_steps=20")
    args = parser.parse_args(argv)
    env = EnvSettings()
    configure_logging(env.log_level, env.log_format)
    logger = structlog.get_logger("robot_voice_chat.main")
    # RVC_CONFIG_OVERRIDES="llm_planner=anthropic agent.max_llm_steps=20" (like the vision
    # node's overrides); command-line overrides come last and win.
    overrides = [*shlex.split(env.config_overrides), *args.overrides]
    try:
        container = bootstrap(compose_config(env.deployment, overrides))
    except (ConfigError, ValueError) as exc:
        logger.error("startup_refused", deployment=env.deployment, error=one_line(str(exc)))
        return 2
    uvicorn.run(create_asgi_app(container), host=args.host, port=args.port, log_config=None)
    return 0


if __name__ == "__main__":
    sys.exit(main())
