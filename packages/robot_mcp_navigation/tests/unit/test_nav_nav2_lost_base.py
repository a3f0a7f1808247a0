"""A lost base (issue 27 item 5): Nav2 stops answering mid-drive → BASE_UNAVAILABLE within the
feedback timeout, the pose is stale until one arrives, a base that comes back elsewhere is
reported as relocated (never a silent jump of the robot's marker)."""

import time
from collections.abc import AsyncIterator
from dataclasses import dataclass

import pytest

from robot_mcp_kit.task_events.fake import FakeEventSink
from robot_mcp_kit.tasks import TaskTable
from robot_mcp_navigation.map import parse_map
from robot_mcp_navigation.motion.base import Pose
from robot_mcp_navigation.motion.nav2.base import Nav2MotionBase
from robot_mcp_navigation.motion.nav2.fake import FakeNav2Action
from robot_mcp_navigation.motion.nav2.pose_watch import PoseContinuity
from robot_mcp_navigation.navigator import Navigator
from robot_stack_testing import async_wait_until

MAP = {
    "name": "test",
    "start": "dock",
    "speed_mps": 1.0,
    "locations": {"dock": {"x": 0, "y": 0}, "kitchen": {"x": 10, "y": 0}},
}


@dataclass
class Rig:
    action: FakeNav2Action
    events: FakeEventSink
    navigator: Navigator
    base: Nav2MotionBase


def make_rig(**options: float) -> Rig:
    action = FakeNav2Action()
    base = Nav2MotionBase(
        action,
        frame="map",
        speed_mps=1.0,
        initial_pose=Pose(0, 0),
        server_timeout_s=0.2,
        cancel_timeout_s=0.2,
        **options,
    )
    events = FakeEventSink()
    return Rig(action, events, Navigator(parse_map(MAP), base, events, TaskTable()), base)


@pytest.fixture
async def rig() -> AsyncIterator[Rig]:
    rig = make_rig(feedback_timeout_s=0.3)
    yield rig
    await rig.navigator.close()


async def test_a_base_that_stops_answering_mid_drive_ends_it_base_unavailable(rig: Rig) -> None:
    rig.action.publish_pose(Pose(0, 0))
    info = await rig.navigator.navigate_to("kitchen")
    rig.action.goals[-1].feedback(Pose(3, 0), distance_remaining_m=7.0)
    rig.action.vanish()  # kill -9 of the action server's process

    await async_wait_until(
        lambda: rig.navigator.get_task(info.task_id).state == "failed", 5, "the drive ended"
    )

    failed = rig.events.events[-1]
    assert failed.type == "task_failed"
    assert failed.payload["error_code"] == "BASE_UNAVAILABLE"
    assert "lost contact with the robot base" in failed.payload["message"]
    await async_wait_until(lambda: rig.action.goals[-1].cancel_requests == 1, 5, "a cancel")
    pose = rig.navigator.pose()
    assert pose["stale"] is True
    assert pose["moving"] is False
    assert "stopped answering" in pose["pose_note"]
    assert (pose["x"], pose["y"]) == (3.0, 0.0)  # where it was last seen


async def test_a_pose_sent_before_the_loss_but_delivered_after_it_is_still_a_lost_base(
    rig: Rig,
) -> None:
    rig.action.publish_pose(Pose(0, 0))
    await rig.navigator.navigate_to("kitchen")
    rig.action.goals[-1].feedback(Pose(3, 0), distance_remaining_m=7.0)
    rig.action.vanish()
    await async_wait_until(lambda: not rig.navigator.moving, 5, "the drive ended")

    rig.action.publish_pose(Pose(3, 0))  # queued on a starved host, handled after the timeout

    pose = rig.navigator.pose()
    assert pose["stale"] is True
    assert "stopped answering" in pose["pose_note"]


async def test_a_base_that_comes_back_elsewhere_is_reported_as_relocated(rig: Rig) -> None:
    rig.action.publish_pose(Pose(0, 0))
    await rig.navigator.navigate_to("kitchen")
    rig.action.goals[-1].feedback(Pose(6, 0), distance_remaining_m=4.0)
    rig.action.publish_pose(Pose(6, 0))
    rig.action.vanish()
    await async_wait_until(lambda: not rig.navigator.moving, 5, "the drive ended")
    assert rig.navigator.pose()["relocated"] is None

    rig.action.publish_pose(Pose(0, 0), at=time.monotonic() + 3.0)  # restarted at the dock

    pose = rig.navigator.pose()
    assert pose["stale"] is False
    assert pose["at_location"] == "dock"
    assert pose["relocated"]["from"] == {"x": 6.0, "y": 0.0}
    assert pose["relocated"]["distance_m"] == 6.0
    assert "came back 6.0 m from where it was last seen" in pose["pose_note"]


async def test_a_pose_gap_during_a_drive_is_no_relocation(rig: Rig) -> None:
    """A loaded host may deliver no pose for a while: the robot was moving, not teleported."""
    now = time.monotonic()
    rig.action.publish_pose(Pose(1, 0), at=now - 2.0)
    await rig.navigator.navigate_to("kitchen")
    rig.action.publish_pose(Pose(6, 0), at=now)  # 5 m after a 2 s gap, while driving

    assert rig.navigator.pose()["relocated"] is None
    assert rig.action.last_relocation() is not None  # the topic did jump; it is not said


async def test_with_no_pose_yet_the_pose_is_stale_and_says_so() -> None:
    rig = make_rig()
    pose = rig.navigator.pose()
    assert pose["stale"] is True
    assert pose["pose_age_s"] is None
    assert "map's start" in pose["pose_note"]


async def test_a_pose_older_than_the_configured_age_is_stale() -> None:
    rig = make_rig(pose_max_age_s=1.0)
    rig.action.publish_pose(Pose(1, 1), at=time.monotonic() - 5.0)
    pose = rig.navigator.pose()
    assert pose["stale"] is True
    assert pose["pose_age_s"] >= 5.0


def test_a_quiet_pose_topic_that_resumes_in_place_is_no_relocation() -> None:
    watch = PoseContinuity(gap_s=1.0, jump_m=0.5)
    watch.observe(Pose(1, 1), at=10.0)
    assert watch.observe(Pose(1.2, 1), at=60.0) is None  # AMCL is quiet while standing still
    assert watch.observe(Pose(5, 1), at=60.05) is None  # no silence: just driving
    moved = watch.observe(Pose(0, 0), at=62.0)
    assert moved is not None
    assert moved.silent_s == pytest.approx(1.95)


async def test_at_start_up_a_goal_an_earlier_life_left_at_the_base_is_cancelled() -> None:
    """A killed navigation server's goal is still Nav2's: once the next lease opens the lock
    the robot would drive on with no one supervising it."""
    rig = make_rig()
    stale = await rig.action.send_goal(Pose(10, 0), "map", lambda feedback: None, 1.0)

    await rig.base.cancel_stale_goals()  # what the app does before it serves

    assert rig.action.cancel_all_calls == 1
    assert (await stale.outcome()).status == "canceled"


async def test_start_up_without_a_nav2_up_cancels_nothing_and_goes_on() -> None:
    rig = make_rig()
    rig.action.available = False

    await rig.base.cancel_stale_goals()

    assert rig.action.cancel_all_calls == 1
