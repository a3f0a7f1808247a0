"""``robot-sim-world``: change a running robot-sim's world from a shell (no ``ros2`` CLI here).

    robot-sim-world kitchen "green bottle" "white plate"   # someone took the mug
    robot-sim-world kitchen                                 # the kitchen is empty
    robot-sim-world --active false                          # the navigator rejects goals

It sets the node's parameters (``places.<place>.objects``, ``active``) through the standard
parameter service, like ``ros2 param set /robot_sim …``. Exit 0 when the node accepted the
change, 1 when it refused it (the reason is printed), 2 when no robot-sim answered within
``--timeout`` (30 s: the request is sent again every 2 s until an answer comes, as a busy
machine may drop or delay one).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from typing import Any

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from rclpy.task import Future

from robot_sim.node import NODE_NAME
from robot_sim.world_params import ACTIVE, objects_parameter

DEFAULT_TIMEOUT_S = 30.0  # discovery + answer on a busy machine (2 cores saturated: ~seconds)
RESEND_S = 2.0  # the same change again when no answer came (a dropped reply)


def parameters_from(args: argparse.Namespace) -> list[Parameter[Any]]:
    changes: list[Parameter[Any]] = []
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
    parser.add_argument("--node", default=NODE_NAME, help="the robot-sim node's name")
    parser.add_argument(
        "--timeout", type=float, default=DEFAULT_TIMEOUT_S, help="seconds to wait for it in all"
    )
    args = parser.parse_args(argv)
    changes = parameters_from(args)
    if not changes:
        parser.error("name a place (and its objects) and/or --active")
    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node("robot_sim_world", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        return _apply(node, executor, args.node, changes, time.monotonic() + args.timeout)
    finally:
        # no spin thread: nothing can still run on the node while it is destroyed
        executor.shutdown(timeout_sec=1.0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)


def _apply(
    node: Node,
    executor: SingleThreadedExecutor,
    target: str,
    changes: list[Parameter[Any]],
    deadline: float,
) -> int:
    """Set ``changes`` on ``target`` before ``deadline``: 0 accepted, 1 refused, 2 no answer.

    A request sent right after discovery can be answered before the node's reply writer has
    matched this new client (rmw then drops the reply), and a busy machine delays either side:
    the same (idempotent) change is sent again every ``RESEND_S`` until one answer comes."""
    client = AsyncParameterClient(node, target)
    if not client.wait_for_services(timeout_sec=max(0.0, deadline - time.monotonic())):
        sys.stderr.write(f"no {target} node answered in time\n")
        return 2
    sent: list[Future[Any]] = []
    while (answered := next((f for f in sent if f.done()), None)) is None:
        now = time.monotonic()
        if now >= deadline:
            sys.stderr.write(f"{target} did not answer in time ({len(sent)} requests sent)\n")
            return 2
        sent.append(client.set_parameters_atomically(changes))
        resend_at = min(deadline, now + RESEND_S)
        while time.monotonic() < resend_at and not any(f.done() for f in sent):
            executor.spin_once(timeout_sec=min(0.1, max(0.0, resend_at - time.monotonic())))
    reply = answered.result()
    if reply is None or not reply.result.successful:
        reason = reply.result.reason if reply is not None else "no reply"
        sys.stderr.write(f"refused: {reason}\n")
        return 1
    sys.stdout.write("ok: " + ", ".join(f"{p.name}={p.value}" for p in changes) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
