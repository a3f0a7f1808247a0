"""The twist_mux lock entry deploy/ ships matches what the stack publishes and what robot-sim
honours (issue 27): one topic, priority 255, the documented timeout."""

from __future__ import annotations

from pathlib import Path

import yaml

from robot_mcp_manipulation.config import load_settings as manipulation_settings
from robot_mcp_navigation.config import load_settings as navigation_settings
from robot_ros_bridge.dead_man_lock import LOCK_PRIORITY, LOCK_TIMEOUT_S, LOCK_TOPIC
from robot_sim.config import load_settings as sim_settings

ROOT = Path(__file__).resolve().parents[2]


def test_the_shipped_twist_mux_lock_is_the_topic_navigation_publishes_at_priority_255() -> None:
    config = yaml.safe_load((ROOT / "deploy" / "twist_mux" / "supervisor_lock.yaml").read_text())
    (lock,) = config["twist_mux"]["ros__parameters"]["locks"].values()

    assert lock == {"topic": LOCK_TOPIC, "timeout": LOCK_TIMEOUT_S, "priority": LOCK_PRIORITY}
    assert lock["priority"] == 255
    assert navigation_settings({}).lock_topic == lock["topic"]
    sim = sim_settings({"SIM_SUPERVISOR_LOCK": "on"})
    assert sim.supervisor_lock_topics == (lock["topic"],)
    assert sim.supervisor_lock_timeout_s == lock["timeout"]


def test_the_local_stack_runs_robot_sim_with_the_lock_honoured() -> None:
    stack = yaml.safe_load((ROOT / "deploy" / "local-stack.yaml").read_text())
    sim = next(s for s in stack["services"] if s["name"] == "robot_sim")

    assert sim["env"]["SIM_SUPERVISOR_LOCK"] == "on"


def test_the_local_stack_holds_each_part_by_its_own_servers_lock() -> None:
    """Issue 39: robot-sim honours every motion server's lock it runs against — navigation's in
    front of the base, manipulation's in front of the arm — as the servers publish them."""
    stack = yaml.safe_load((ROOT / "deploy" / "local-stack.yaml").read_text())
    env = next(s for s in stack["services"] if s["name"] == "robot_sim")["env"]

    sim = sim_settings({k: str(v) for k, v in env.items() if k.startswith(("SIM_SUP", "SIM_ARM"))})
    assert sim.supervisor_lock_topics == (navigation_settings({}).lock_topic,)
    assert sim.arm_lock_topics == (manipulation_settings({}).lock_topic,)
    assert sim_settings({"SIM_SUPERVISOR_LOCK": "on"}).arm_lock_topics == sim.arm_lock_topics
