"""NAV_MOTION=nav2 in the composition root and the settings: the rclpy adapter is built (and
closed), a machine without rclpy/nav2_msgs gets exit 2 with one line, bad names are refused."""

import builtins
import sys
from typing import Any

import pytest

from robot_mcp_kit.task_events.fake import FakeEventSink
from robot_mcp_navigation import server
from robot_mcp_navigation.composition import build_app
from robot_mcp_navigation.config import ConfigError, load_settings
from robot_mcp_navigation.motion.nav2.base import Nav2MotionBase
from robot_mcp_navigation.motion.nav2.error_codes import CODES, FAILURES, named_failure


def test_nav2_settings_default_to_nav2s_names() -> None:
    settings = load_settings({"NAV_MOTION": "Nav2"})
    assert settings.motion == "nav2"
    assert settings.nav2_action == "/navigate_to_pose"
    assert settings.pose_topic == "/amcl_pose"
    assert load_settings({}).motion == "simulated"


@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("NAV_MOTION", "teleport"),
        ("NAV2_ACTION", "navigate_to_pose"),
        ("NAV2_ACTION", "/navigate to pose"),
        ("NAV_POSE_TOPIC", "/amcl_pose/"),
        ("NAV2_SERVER_TIMEOUT_S", "0"),
    ],
)
def test_bad_nav2_settings_are_refused_naming_the_variable(name: str, value: str) -> None:
    with pytest.raises(ConfigError, match=name):
        load_settings({name: value})


@pytest.mark.ros
async def test_nav2_mode_builds_the_rclpy_adapter_and_closes_it_on_shutdown() -> None:
    app = build_app(
        load_settings({"NAV_MOTION": "nav2", "NAV_POSE_TOPIC": "/robot/pose"}),
        events=FakeEventSink(),
    )
    assert isinstance(app.base, Nav2MotionBase)
    assert len(app.closers) == 1
    async with app.running():
        assert app.navigator.pose()["x"] == 0.0  # the map's start until a pose arrives
    ros = app.closers[0].__self__  # type: ignore[attr-defined]
    assert ros.bridge.closed
    assert ros.lock is not None  # required supervision: the dead-man lock is published


def test_nav2_mode_without_rclpy_exits_2_with_one_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    real_import = builtins.__import__

    def no_nav2_msgs(name: str, *args: Any, **kwargs: Any) -> Any:
        if name.startswith("nav2_msgs"):
            raise ImportError("No module named 'nav2_msgs'")
        return real_import(name, *args, **kwargs)

    monkeypatch.delitem(sys.modules, "robot_mcp_navigation.motion.nav2.rclpy_action", raising=False)
    monkeypatch.setattr(builtins, "__import__", no_nav2_msgs)
    monkeypatch.setenv("NAV_MOTION", "nav2")
    with pytest.raises(SystemExit) as caught:
        server.main()
    assert caught.value.code == 2
    out = capsys.readouterr()
    assert "NAV_MOTION=nav2 needs rclpy and nav2_msgs" in out.out + out.err
    assert "Traceback" not in out.out + out.err


def test_every_mapped_code_has_a_named_failure_and_the_rest_are_not_recoverable() -> None:
    assert set(CODES.values()) <= set(FAILURES)
    assert named_failure(9003).code == "NAVIGATION_TIMEOUT"  # NavigateToPose.Result.TIMEOUT
    assert named_failure(9001).recoverable is False  # FAILED_TO_LOAD_BEHAVIOR_TREE
    assert named_failure(65535).code == "NAV2_ERROR"
    assert named_failure(65535).recoverable is False
