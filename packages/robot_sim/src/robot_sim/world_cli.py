"""``robot-sim-world``: change a running robot-sim's world from a shell (no ``ros2`` CLI here).

    robot-sim-world kitchen "green bottle" "white plate"   # someone took the mug
    robot-sim-world kitchen                                 # the kitchen is empty
    robot-sim-world --active false                          # the navigator rejects goals
    robot-sim-world --door mailroom_west_door=open          # open (or close) a door

It sets the node's parameters (``places.<place>.objects``, ``doors.<door>.closed``,
``active``) through the standard
parameter service, like ``ros2 param set /robot_sim …``. Exit 0 when the node accepted the
change, 1 when it refused it (the reason is printed), 2 when no robot-sim answered in time.
"""

from __future__ import annotations

import argparse
import sys
import threading
from collections.abc import Callable, Sequence
from typing import Any

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient

from robot_sim.node import NODE_NAME
from robot_sim.world_params import ACTIVE, door_parameter, objects_parameter


def _door(text: str) -> tuple[str, bool]:
    door, _, state = text.partition("=")
    if not door or state not in ("open", "closed"):
        raise argparse.ArgumentTypeError(f"{text!r}: write DOOR=open or DOOR=closed")
    return door, state == "closed"


def parameters_from(args: argparse.Namespace) -> list[Parameter[Any]]:
    changes: list[Parameter[Any]] = []
    for door, closed in args.door or []:
        changes.append(Parameter(door_parameter(door), Parameter.Type.BOOL, closed))
    if args.place is not None:
        changes.append(
            Parameter(objects_parameter(args.place), Parameter.Type.STRING_ARRAY, args.objects)
        )
    if args.active is not None:
        changes.append(Parameter(ACTIVE, Parameter.Type.BOOL, args.active == "true"))
    return changes


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="robot-sim-world", description=__doc__.split("\n")[0])
    parser.add_argument("place", nargs="?", help="a map location, e.g. kitchen")
    parser.add_argument("objects", nargs="*", help="catalogue labels standing there now")
    parser.add_argument("--active", choices=["true", "false"], help="accept navigation goals")
    parser.add_argument(
        "--door",
        action="append",
        type=_door,
        metavar="DOOR=open|closed",
        help="open or close a door",
    )
    parser.add_argument("--node", default=NODE_NAME, help="the robot-sim node's name")
    parser.add_argument("--timeout", type=float, default=10.0, help="seconds to wait for it")
    args = parser.parse_args(argv)
    changes = parameters_from(args)
    if not changes:
        parser.error("name a place (and its objects), --door and/or --active")
    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node("robot_sim_world", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    try:
        client = AsyncParameterClient(node, args.node)
        if not client.wait_for_services(timeout_sec=args.timeout):
            sys.stderr.write(f"no {args.node} node answered within {args.timeout} s\n")
            return 2
        # A request sent right after discovery can be answered before the node's reply
        # writer has matched this new client (rmw then drops the reply), so the same
        # (idempotent) change is sent once more if the first half of the wait passes.
        for _attempt in range(2):
            answered = threading.Event()
            future = client.set_parameters_atomically(changes)
            future.add_done_callback(_setter(answered))
            if answered.wait(args.timeout / 2):
                break
        else:
            sys.stderr.write(f"{args.node} did not answer within {args.timeout} s\n")
            return 2
        reply = future.result()
        if reply is None or not reply.result.successful:
            reason = reply.result.reason if reply is not None else "no reply"
            sys.stderr.write(f"refused: {reason}\n")
            return 1
        sys.stdout.write("ok: " + ", ".join(f"{p.name}={p.value}" for p in changes) + "\n")
        return 0
    finally:
        executor.shutdown(timeout_sec=2.0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)


if __name__ == "__main__":
    sys.exit(main())


def _setter(event: threading.Event) -> Callable[[object], None]:
    """A done callback that sets ``event`` (one per attempt)."""
    return lambda _future: event.set()
