"""`make demo`: the whole local stack with the operator UI at http://127.0.0.1:8000.

Starts every service of ``deploy/local-stack.yaml`` as its own OS process (embedded defaults:
no keys, no GPU; the brain on its dev preset with recorded replies), stores the taught mailroom
process in memory, prints the URL and keeps running until Ctrl+C; every process is stopped by
PID on the way out. Type (or say) "Please fetch the package from the mailroom and bring it to
reception." in the page to watch the mission plan, fail at the closed door, replan, pick the
package up, carry it (the status bar shows what the robot holds), put it down at reception and
look: the camera shows it there, and the History panel lists it at reception. The
terminal-narrated run is ``make demo-mission`` (scripts/demo.py).

    uv run python scripts/ui_demo.py [--nav-time-scale 3] [--free-ports]
"""

from __future__ import annotations

import argparse
import asyncio
import os
import shutil
import signal
import sys
import time
from pathlib import Path

from robot_stack_testing.mission_driver import FETCH_REQUEST, mailroom_stack, seed_memory
from robot_stack_testing.stack import PortsBusyError, StackError, free_port_overrides

ROOT = Path(__file__).resolve().parents[1]
STACK_FILE = ROOT / "deploy" / "local-stack.yaml"
VAR_DIR = ROOT / "build" / "ui-demo"
STATIC = ROOT / "packages" / "robot_voice_chat" / "src" / "robot_voice_chat" / "static"


def say(text: str) -> None:
    print(text, flush=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--nav-time-scale", default="3", help="simulated base speed-up (the tests use 10)"
    )
    parser.add_argument(
        "--free-ports", action="store_true", help="free ports instead of 8000/91xx/92xx"
    )
    args = parser.parse_args(argv)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    # Ctrl+C, and SIGINT or SIGTERM by PID, stop the stack; a shell that starts the demo in the
    # background hands it SIGINT ignored, and Python then keeps ignoring it unless told
    for stop_signal in (signal.SIGINT, signal.SIGTERM):
        signal.signal(stop_signal, signal.default_int_handler)
    if not (STATIC / "index.html").is_file():
        say("demo: the UI is not built — run `make setup` (needs Node 20 + npm)")
        return 2
    shutil.rmtree(VAR_DIR, ignore_errors=True)
    say(f"demo: starting {STACK_FILE.relative_to(ROOT)} (first start takes ~30 s)")
    started = time.monotonic()
    try:
        ports = free_port_overrides(STACK_FILE) if args.free_ports else {}
        # The brain runs the dev preset as shipped (rules chat + rules planner), so a person
        # can type any command it understands, not only the recorded mission's sentence.
        overrides = {**ports, "nav_time_scale": args.nav_time_scale, "brain_config_overrides": ""}
        with mailroom_stack(ROOT, VAR_DIR, overrides, stack_file=STACK_FILE) as stack:
            for name, process in stack.services.items():
                say(f"demo:   {name:<12} pid {process.pid}")
            asyncio.run(seed_memory(stack))
            say(f"demo: stack up in {time.monotonic() - started:.1f}s")
            say("")
            say(f"    Open {stack.brain_url}/ in a browser")
            say(f'    and type: "{FETCH_REQUEST}"')
            say('    or "go to the kitchen", "find the scissors", "what do you see", "stop"')
            say("")
            say(f"demo: logs and mission traces in {VAR_DIR} — Ctrl+C stops everything")
            signal.pause()  # until Ctrl+C (SIGINT raises KeyboardInterrupt)
    except PortsBusyError as exc:
        say(f"demo: {exc}. Stop the other stack first.")
        return 2
    except StackError as exc:
        say(f"demo: FAILED — {exc} (service logs in {VAR_DIR})")
        return 1
    except KeyboardInterrupt:
        say("demo: stopped")
    return 0


if __name__ == "__main__":
    sys.exit(main())
