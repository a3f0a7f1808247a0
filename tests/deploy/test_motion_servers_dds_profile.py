"""The Fast DDS profile the motion servers' units run with (deploy/fastdds-motion-servers.xml):
it shortens a reliable writer's heartbeat to 100 ms and changes nothing else, and the Fast DDS
of the venv's ROS wheels loads it (a misspelt element makes it reject the whole file, loudly)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PROFILE = ROOT / "deploy" / "fastdds-motion-servers.xml"
NS = {"dds": "http://www.eprosima.com"}

# A reliable publisher, as the lock publisher is, in a process reading the profile.
PROBE = """
import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import Bool
rclpy.init()
node = rclpy.create_node("profile_probe")
reliable = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)
node.create_publisher(Bool, "/profile_probe", reliable)
node.destroy_node()
rclpy.shutdown()
print("probe done")
"""


def fast_dds_output_with(profile: Path) -> str:
    result = subprocess.run(
        [sys.executable, "-c", PROBE],
        env={**os.environ, "FASTDDS_DEFAULT_PROFILES_FILE": str(profile)},
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "probe done" in result.stdout
    return result.stdout + result.stderr


def test_the_profile_only_shortens_a_reliable_writers_heartbeat_to_100_ms() -> None:
    profiles = ET.parse(PROFILE).getroot().find("dds:profiles", NS)
    assert profiles is not None
    (writer,) = list(profiles)  # no participant, transport or discovery settings
    assert writer.tag == f"{{{NS['dds']}}}data_writer"
    assert writer.get("is_default_profile") == "true"
    period = writer.find("dds:times/dds:heartbeat_period", NS)
    assert period is not None
    assert (period.findtext("dds:sec", "", NS), period.findtext("dds:nanosec", "", NS)) == (
        "0",
        "100000000",
    )


def test_the_venvs_fast_dds_loads_the_profile_and_rejects_a_misspelt_one(tmp_path: Path) -> None:
    assert "XMLPARSER" not in fast_dds_output_with(PROFILE)

    # Fast DDS 2's spelling: Fast DDS 3 (the Kilted wheels) rejects the whole file, saying so.
    misspelt = tmp_path / "misspelt.xml"
    misspelt.write_text(PROFILE.read_text().replace("heartbeat_period", "heartbeatPeriod"))
    said = re.sub(r"\x1b\[[0-9;]*m", "", fast_dds_output_with(misspelt))  # no terminal colours
    assert "XMLPARSER Error" in said
    assert "heartbeatPeriod" in said
