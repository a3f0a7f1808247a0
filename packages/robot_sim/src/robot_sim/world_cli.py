"""``robot-sim-world``: change a running robot-sim's world from a shell (no ``ros2`` CLI here).

    robot-sim-world kitchen "green bottle" "white plate"   # someone took the mug
    robot-sim-world kitchen                                 # the kitchen is empty
    robot-sim-world --active false                          # the navigator rejects goals
    robot-sim-world --door mailroom_west_door=open          # open (or close) a door
    robot-sim-world --fail-grasps 1                         # the next grasp fails
    robot-sim-world --out-of-reach "yellow package"         # the arm cannot reach it
    robot-sim-world --held ""                               # the gripper is empty
    robot-sim-world --show                                  # print the world as JSON

It sets the node's parameters (``places.<place>.objects``, ``doors.<door>.closed``,
``active``, ``gripper.*``) through the standard
parameter service, like ``ros2 param set /robot_sim …``. Exit 0 when the node accepted the
change, 1 when it refused it (the reason is printed), 2 when no robot-sim answered within
``--timeout`` (30 s: a request is sent again every 2 s until an answer comes, as a busy machine
may drop or delay one; issue 31). ``--show`` reads the same parameters back and prints
``{"places": {...}, "held": ...}``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter, parameter_value_to_python
from rclpy.parameter_client import AsyncParameterClient
from rclpy.task import Future

from robot_sim.node import NODE_NAME
from robot_sim.world_params import (
    ACTIVE,
    FAIL_GRASPS,
    HELD,
    OUT_OF_REACH,
    door_parameter,
    objects_parameter,
)

DEFAULT_TIMEOUT_S = 30.0  # discovery + answer on a busy machine (2 cores saturated: ~seconds)
RESEND_S = 2.0  # the same (idempotent) request again when no answer came (a dropped reply)


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
    if args.fail_grasps is not None:
        changes.append(Parameter(FAIL_GRASPS, Parameter.Type.INTEGER, args.fail_grasps))
    if args.out_of_reach is not None:
        # [""] rather than []: an empty list reaches the node untyped
        reach = args.out_of_reach or [""]
        changes.append(Parameter(OUT_OF_REACH, Parameter.Type.STRING_ARRAY, reach))
    if args.held is not None:
        changes.append(Parameter(HELD, Parameter.Type.STRING, args.held))
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
    parser.add_argument("--fail-grasps", type=int, help="that many next grasps fail")
    parser.add_argument(
        "--out-of-reach", nargs="*", metavar="LABEL", help="labels the arm cannot reach"
    )
    parser.add_argument("--held", metavar="LABEL", help='what the gripper holds ("": nothing)')
    parser.add_argument("--show", action="store_true", help="print what stands where (JSON)")
    parser.add_argument("--node", default=NODE_NAME, help="the robot-sim node's name")
    parser.add_argument(
        "--timeout", type=float, default=DEFAULT_TIMEOUT_S, help="seconds to wait for it in all"
    )
    args = parser.parse_args(argv)
    changes = parameters_from(args)
    if not changes and not args.show:
        parser.error("name a place (and its objects), --door, --active, --fail-grasps, …")
    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node("robot_sim_world", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    deadline = time.monotonic() + args.timeout
    try:
        client = AsyncParameterClient(node, args.node)
        if not client.wait_for_services(timeout_sec=args.timeout):
            sys.stderr.write(f"no {args.node} node answered within {args.timeout} s\n")
            return 2
        if args.show:
            return _show(executor, client, deadline)
        reply = _ask(executor, lambda: client.set_parameters_atomically(changes), deadline)
        if reply is None:
            sys.stderr.write(f"{args.node} did not answer within {args.timeout} s\n")
            return 2
        if not reply.result.successful:
            sys.stderr.write(f"refused: {reply.result.reason}\n")
            return 1
        sys.stdout.write("ok: " + ", ".join(f"{p.name}={p.value}" for p in changes) + "\n")
        return 0
    finally:
        # no spin thread: nothing runs on the node while it is destroyed, and nothing is left
        # running when the interpreter exits
        executor.shutdown(timeout_sec=1.0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)


def _ask(executor: SingleThreadedExecutor, send: Callable[[], Future[Any]], deadline: float) -> Any:
    """The first answer to ``send()`` before ``deadline`` (None: no answer).

    A request sent right after discovery can be answered before the node's reply writer has
    matched this new client (rmw then drops the reply), and a busy machine delays either side:
    the same idempotent request is sent again every ``RESEND_S`` until one answer comes."""
    sent: list[Future[Any]] = []
    while (answered := next((f for f in sent if f.done()), None)) is None:
        now = time.monotonic()
        if now >= deadline:
            return None
        sent.append(send())
        resend_at = min(deadline, now + RESEND_S)
        while time.monotonic() < resend_at and not any(f.done() for f in sent):
            executor.spin_once(timeout_sec=min(0.1, max(0.0, resend_at - time.monotonic())))
    return answered.result()


def _show(executor: SingleThreadedExecutor, client: AsyncParameterClient, deadline: float) -> int:
    """Print the world as robot-sim's parameters say it is."""
    listing: Any = _ask(
        executor, lambda: client.list_parameters(["places", "gripper"], 3), deadline
    )
    if listing is None:
        sys.stderr.write("robot-sim did not answer in time\n")
        return 2
    names = [n for n in listing.result.names if n.endswith(".objects") or n == HELD]
    answer: Any = _ask(executor, lambda: client.get_parameters(names), deadline)
    if answer is None:
        sys.stderr.write("robot-sim did not answer in time\n")
        return 2
    values = dict(zip(names, answer.values, strict=True))
    places: dict[str, Any] = {
        name.removeprefix("places.").removesuffix(".objects"): parameter_value_to_python(value)
        for name, value in values.items()
        if name != HELD
    }
    held = parameter_value_to_python(values[HELD]) if HELD in values else ""
    sys.stdout.write(json.dumps({"places": places, "held": held or None}) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
