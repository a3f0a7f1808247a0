"""Changing the world at run time through the node's ROS parameters.

One ``string[]`` parameter per place, ``places.<place>.objects`` (catalogue labels), one
``bool`` per door, ``doors.<door>.closed``, and a ``bool`` parameter ``active`` (false: the
navigator rejects goals, like a Nav2 whose lifecycle is not active). The gripper's:
``gripper.held`` (the label it holds, "" for none; the gripper keeps it current), and the
injected faults ``gripper.fail_grasps`` (that many next grasps fail) and
``gripper.out_of_reach`` (labels the arm cannot reach). Any ROS tool sets them —
``ros2 param set /robot_sim places.kitchen.objects "['green bottle']"`` (someone took the mug),
``ros2 param set /robot_sim doors.mailroom_west_door.closed false`` — and the camera shows the
change from its next frame; the robot learns of a door when it sees it. A bad value is refused
with a reason naming it; nothing changes.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import structlog
from rcl_interfaces.msg import (
    ParameterDescriptor,
    SetParametersResult,
)
from rclpy.node import Node
from rclpy.parameter import Parameter

from robot_sim.gripper import Gripper
from robot_sim.world import World, WorldError

logger = structlog.get_logger(__name__)

ACTIVE = "active"
HELD = "gripper.held"
FAIL_GRASPS = "gripper.fail_grasps"
OUT_OF_REACH = "gripper.out_of_reach"


def objects_parameter(place: str) -> str:
    return f"places.{place}.objects"


def door_parameter(door: str) -> str:
    return f"doors.{door}.closed"


class WorldParameters:
    """Declares the parameters and applies every accepted change to ``world``."""

    def __init__(
        self,
        node: Node,
        world: World,
        on_active: Callable[[bool], None],
        gripper: Gripper | None = None,
    ) -> None:
        self._world = world
        self._on_active = on_active
        self._gripper = gripper
        self._places = {objects_parameter(place): place for place in world.places}
        catalogue = ", ".join(world.spec.objects)
        for name, place in self._places.items():
            node.declare_parameter(
                name,
                list(world.objects_at(place)),
                ParameterDescriptor(
                    description=f"What stands at {place} (labels of: {catalogue})",
                    dynamic_typing=True,
                ),
            )
        self._doors = {door_parameter(door): door for door in world.doors}
        closed = world.closed_doors()
        for name, door in self._doors.items():
            label = world.floor.plan.doors[door].label
            node.declare_parameter(
                name,
                door in closed,
                ParameterDescriptor(description=f"whether the {label} is closed"),
            )
        node.declare_parameter(
            ACTIVE, True, ParameterDescriptor(description="false: reject navigation goals")
        )
        if gripper is not None:
            self._declare_gripper(node)
        node.add_on_set_parameters_callback(self._on_set)

    def _declare_gripper(self, node: Node) -> None:
        node.declare_parameter(
            HELD,
            self._world.held() or "",
            ParameterDescriptor(description="What the gripper holds (a label; empty: nothing)"),
        )
        node.declare_parameter(
            FAIL_GRASPS,
            0,
            ParameterDescriptor(description="Injected fault: this many next grasps fail"),
        )
        node.declare_parameter(
            OUT_OF_REACH,
            [""],
            ParameterDescriptor(
                description="Injected fault: labels the arm cannot reach", dynamic_typing=True
            ),
        )

    def _gripper_change(self, parameter: Parameter[Any]) -> str | None:
        """Apply one gripper parameter; the reason when it is refused."""
        assert self._gripper is not None
        if parameter.name == HELD:
            if parameter.type_ != Parameter.Type.STRING:
                return f"{HELD} must be a string"
            try:
                self._world.set_held(str(parameter.value) or None)
            except WorldError as error:
                return str(error)
        elif parameter.name == FAIL_GRASPS:
            if parameter.type_ != Parameter.Type.INTEGER or int(parameter.value) < 0:
                return f"{FAIL_GRASPS} must be an integer >= 0"
            self._gripper.set_faults(fail_grasps=int(parameter.value))
        else:
            labels = _labels(parameter)
            if labels is None:
                return f"{OUT_OF_REACH} must be a list of strings"
            self._gripper.set_faults(out_of_reach=[label for label in labels if label])
        logger.info("gripper_changed", parameter=parameter.name, value=parameter.value)
        return None

    def _on_set(self, parameters: list[Parameter[Any]]) -> SetParametersResult:
        changes: list[tuple[str, list[str]]] = []
        doors: list[tuple[str, bool]] = []
        for parameter in parameters:
            if parameter.name == ACTIVE or parameter.name in self._doors:
                if parameter.type_ != Parameter.Type.BOOL:
                    return SetParametersResult(
                        successful=False, reason=f"{parameter.name} must be a bool"
                    )
                if parameter.name in self._doors:
                    doors.append((self._doors[parameter.name], bool(parameter.value)))
                continue
            if self._gripper is not None and parameter.name in (HELD, FAIL_GRASPS, OUT_OF_REACH):
                refused = self._gripper_change(parameter)
                if refused is not None:
                    return SetParametersResult(successful=False, reason=refused)
                continue
            place = self._places.get(parameter.name)
            if place is None:
                continue
            labels = _labels(parameter)
            if labels is None:
                return SetParametersResult(
                    successful=False, reason=f"{parameter.name} must be a list of strings"
                )
            changes.append((place, labels))
        try:
            for place, labels in changes:
                self._world.check(place, labels)
        except WorldError as error:
            logger.info("world_change_refused", reason=str(error))
            return SetParametersResult(successful=False, reason=str(error))
        for place, labels in changes:
            self._world.set_objects(place, labels)
            logger.info("world_changed", place=place, objects=labels)
        for door, closed in doors:
            self._world.set_door(door, closed)
            logger.info("door_changed", door=door, closed=closed)
        for parameter in parameters:
            if parameter.name == ACTIVE:
                self._on_active(bool(parameter.value))
                logger.info("navigator_active", active=bool(parameter.value))
        return SetParametersResult(successful=True)


def _labels(parameter: Parameter[Any]) -> list[str] | None:
    """The labels of a string-array value; an empty array may arrive typed as any array
    (rclpy infers ``BYTE_ARRAY`` for ``[]``)."""
    value = parameter.value
    if parameter.type_ == Parameter.Type.STRING_ARRAY:
        return [str(v) for v in value]
    empty_arrays = (
        Parameter.Type.BYTE_ARRAY,
        Parameter.Type.BOOL_ARRAY,
        Parameter.Type.INTEGER_ARRAY,
        Parameter.Type.DOUBLE_ARRAY,
    )
    if parameter.type_ in empty_arrays and len(value) == 0:
        return []
    return None
