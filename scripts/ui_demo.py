"""`make demo`: the whole local stack with the operator UI at http://127.0.0.1:8000.

Starts every service of ``deploy/local-stack.yaml`` as its own OS process (embedded defaults:
no keys, no GPU; the brain on its dev preset with recorded replies), stores the taught mailroom
process in memory, prints the URL and keeps running until Ctrl+C; every process is stopped by
PID on the way out. Type (or say) "Please fetch the package from the mailroom and bring it to
reception." in the page to watch the mission plan, fail at the closed door, replan, pick the
package up, carry it (the status bar shows what the robot holds), put it down at reception and
look: the camera shows it there, and the History panel lists it at reception. The
terminal-narrated run is ``make demo-mission`` (scripts/demo.py).

Each run keeps its state (logs, outboxes, memory, episodic store, mission traces, the latch) in
a directory of its own, ``build/ui-demo/run-<time>-<random>/`` (0700), and never deletes
another run's: a second demo started beside a running one (``--free-ports``) cannot wipe it.
``rm -r build/ui-demo`` clears old runs once no demo is running.

    uv run python scripts/ui_demo.py [--nav-time-scale 3] [--free-ports]
"""

from __future__ import annotations

import argparse
import asyncio
import os
import signal
import sys
import tempfile
import time
from pathlib import Path

from robot_stack_testing.mission_driver import FETCH_REQUEST, mailroom_stack, seed_memory
from robot_stack_testing.stack import PortsBusyError, StackError, free_port_overrides

ROOT = Path(__file__).resolve().parents[1]
STACK_FILE = ROOT / "deploy" / "local-stack.yaml"
VAR_DIR = ROOT / "build" / "ui-demo"  # one directory per run below it
OWNER_FILE = "demo.pid"
STATIC = ROOT / "packages" / "robot_voice_chat" / "src" / "robot_voice_chat" / "static"


def say(text: str) -> None:
    print(text, flush=True)


def new_run_directory(base: Path) -> Path:
    """A fresh directory for this run's state under ``base`` (0700, named by its start time
    and a random suffix) that names this process as its owner. Nothing else is touched."""
    base.mkdir(parents=True, exist_ok=True, mode=0o700)
    run = Path(tempfile.mkdtemp(prefix=time.strftime("run-%Y%m%d-%H%M%S-"), dir=base))
    (run / OWNER_FILE).write_text(f"{os.getpid()}\n")
    return run


def running_demos(base: Path) -> list[tuple[Path, int]]:
    """Other runs under ``base`` whose owner process is still alive (directory, PID)."""
    found = []
    for owner in sorted(base.glob(f"run-*/{OWNER_FILE}")):
        try:
            pid = int(owner.read_text().strip())
            os.kill(pid, 0)
        except (OSError, ValueError):
            continue
        if pid != os.getpid():
            found.append((owner.parent, pid))
    return found


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
    for other, pid in running_demos(VAR_DIR):
        say(f"demo: another demo is running (pid {pid}, state in {other}); it is left alone")
    var_dir = new_run_directory(VAR_DIR)
    say(f"demo: starting {STACK_FILE.relative_to(ROOT)} (first start takes ~30 s)")
    started = time.monotonic()
    try:
        ports = free_port_overrides(STACK_FILE) if args.free_ports else {}
        # The brain runs the dev preset as shipped (rules chat + rules planner), so a person
        # can type any command it understands, not only the recorded mission's sentence.
        overrides = {**ports, "nav_time_scale": args.nav_time_scale, "brain_config_overrides": ""}
        with mailroom_stack(ROOT, var_dir, overrides, stack_file=STACK_FILE) as stack:
            for name, process in stack.services.items():
                say(f"demo:   {name:<12} pid {process.pid}")
            asyncio.run(seed_memory(stack))
            say(f"demo: stack up in {time.monotonic() - started:.1f}s")
            say("")
            say(f"    Open {stack.brain_url}/ in a browser")
            say(f'    and type: "{FETCH_REQUEST}"')
            say('    or "go to the kitchen", "find the scissors", "what do you see", "stop"')
            say("")
            say(f"demo: logs and mission traces in {var_dir} — Ctrl+C stops everything")
            signal.pause()  # until Ctrl+C (SIGINT raises KeyboardInterrupt)
    except PortsBusyError as exc:
        say(f"demo: {exc}. Stop the other stack first.")
        return 2
    except StackError as exc:
        say(f"demo: FAILED — {exc} (service logs in {var_dir})")
        return 1
    except KeyboardInterrupt:
        say("demo: stopped")
    return 0


if __name__ == "__main__":
    sys.exit(main())
