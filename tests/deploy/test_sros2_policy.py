"""deploy/sros2: the SROS2 policy of the robot stack (issue 35 item 3, RUNBOOK "ROS trust
boundary") is valid for sros2 and grants what the RUNBOOK says: only navigation publishes the
base's lock, only manipulation the arm's, only the robot's base /amcl_pose, and the
cloud-facing vision node reads the camera and publishes /vision/** only.

What runs here is what `ros2 security create_permission` does to the policy, with sros2's own
files (tests/deploy/data/sros2, copied from ros2/sros2 0.13.0, Apache-2.0): the policy is
validated against policy.xsd, turned into DDS permissions by permissions.xsl (with the
ros_discovery_info rule sros2 adds for Fast DDS) and those are validated against
permissions.xsd. The grants are then read the way a DDS Security access-control plugin reads
them: a grant's rules in order, the first whose topic expression matches (fnmatch) decides,
else its default. Not run here: signing and enforcing — the PyPI ROS wheels' Fast DDS is
built without DDS Security; a robot's system ROS has it (RUNBOOK)."""

from __future__ import annotations

import fnmatch
import os
import shutil
import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
POLICY = ROOT / "deploy/sros2/policy.xml"
DROP_INS = ROOT / "deploy/sros2/systemd"
SROS2 = Path(__file__).resolve().parent / "data/sros2"
LOCK = "rt/robot/supervisor_lock"
ARM_LOCK = "rt/robot/supervisor_lock/manipulation"
SEND_GOAL = "rq/navigate_to_pose/_action/send_goalRequest"


def tool(name: str) -> str:
    found = shutil.which(name)
    assert found, f"{name} is not installed: make setup installs it (libxml2-utils, xsltproc)"
    return found


def run(argv: list[str]) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "XML_CATALOG_FILES": str(SROS2 / "catalog.xml")}
    return subprocess.run(argv, capture_output=True, text=True, env=env, timeout=60, check=False)


def schema_check(document: Path, schema: Path) -> subprocess.CompletedProcess[str]:
    return run([tool("xmllint"), "--nonet", "--noout", "--schema", str(schema), str(document)])


def validate(document: Path, schema: Path) -> None:
    done = schema_check(document, schema)
    assert done.returncode == 0, done.stderr


@pytest.fixture(scope="module")
def permissions(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("sros2") / "permissions.xml"
    done = run(
        [
            tool("xsltproc"),
            "--nonet",
            "--stringparam",
            "allow_ros_discovery_topic",
            "1",
            "-o",
            str(out),
            str(SROS2 / "permissions.xsl"),
            str(POLICY),
        ]
    )
    assert done.returncode == 0, done.stderr
    return out


Grants = dict[str, ET.Element]


@pytest.fixture(scope="module")
def grants(permissions: Path) -> Grants:
    root = ET.parse(permissions).getroot()
    return {grant.attrib["name"]: grant for grant in root.iter("grant")}


def allowed(grant: ET.Element, action: str, topic: str) -> bool:
    """DDS Security's access-control decision for ``action`` (publish / subscribe) on the DDS
    topic ``topic``: the first rule of the grant that names a matching expression decides."""
    for rule in grant:
        if rule.tag not in ("allow_rule", "deny_rule"):
            continue
        expressions = [t.text or "" for t in rule.findall(f"{action}/topics/topic")]
        if any(fnmatch.fnmatchcase(topic, expression) for expression in expressions):
            return rule.tag == "allow_rule"
    return (grant.findtext("default") or "DENY") == "ALLOW"


def who(grants: Grants, action: str, topic: str) -> set[str]:
    return {name for name, grant in grants.items() if allowed(grant, action, topic)}


def test_the_policy_is_valid_for_sros2_and_becomes_valid_dds_permissions(
    permissions: Path,
) -> None:
    validate(POLICY, SROS2 / "policy.xsd")
    validate(permissions, SROS2 / "permissions.xsd")


def test_a_policy_sros2_would_refuse_is_refused_here(tmp_path: Path) -> None:
    broken = tmp_path / "policy.xml"
    broken.write_text(POLICY.read_text().replace('publish="ALLOW"', 'publish="YES"', 1))
    assert schema_check(broken, SROS2 / "policy.xsd").returncode != 0


def test_only_navigation_publishes_the_bases_lock_and_only_manipulation_the_arms(
    grants: Grants,
) -> None:
    assert who(grants, "publish", LOCK) == {"/robot_stack/navigation"}
    assert who(grants, "publish", ARM_LOCK) == {"/robot_stack/manipulation"}
    assert "/robot/base" in who(grants, "subscribe", LOCK)  # twist_mux reads it
    assert "/robot/arm" in who(grants, "subscribe", ARM_LOCK)


def test_only_the_base_publishes_the_pose_and_the_map(grants: Grants) -> None:
    assert who(grants, "publish", "rt/amcl_pose") == {"/robot/base"}
    assert who(grants, "publish", "rt/map") == {"/robot/base"}
    assert who(grants, "subscribe", "rt/amcl_pose") == {
        "/robot/base",
        "/robot_stack/navigation",
        "/robot_stack/episodic",
    }


def test_only_navigation_and_the_base_itself_send_a_drive_goal(grants: Grants) -> None:
    assert who(grants, "publish", SEND_GOAL) == {"/robot_stack/navigation", "/robot/base"}
    assert who(grants, "publish", "rq/manipulation/pick/_action/send_goalRequest") == {
        "/robot_stack/manipulation"
    }


def test_the_cloud_facing_vision_node_reads_the_camera_and_publishes_only_vision_results(
    grants: Grants,
) -> None:
    vision = grants["/robot_stack/vision"]
    assert allowed(vision, "subscribe", "rt/camera/image_raw")
    assert allowed(vision, "publish", "rt/vision/find_object/detections")
    for topic in (LOCK, ARM_LOCK, "rt/amcl_pose", "rt/map", "rt/cmd_vel", "rt/camera/image_raw"):
        assert not allowed(vision, "publish", topic), topic
    for topic in (SEND_GOAL, "rq/manipulation/pick/_action/send_goalRequest"):
        assert not allowed(vision, "publish", topic), topic
    assert not allowed(vision, "subscribe", "rt/amcl_pose")
    # the base's ALLOW * comes after its DENY of /vision/*: nobody else fakes a detection
    assert who(grants, "publish", "rt/vision/find_object/detections") == {"/robot_stack/vision"}


def test_every_ros_unit_has_a_drop_in_that_enforces_its_own_enclave(grants: Grants) -> None:
    ros_units = sorted(
        path.stem
        for path in (ROOT / "deploy").glob("*.service")
        if "EnvironmentFile=/etc/robot-stack/ros.env" in path.read_text()
    )
    assert ros_units == sorted(p.name.removesuffix(".service.d") for p in DROP_INS.iterdir())
    enclaves = set()
    for unit in ros_units:
        lines = (DROP_INS / f"{unit}.service.d" / "sros2.conf").read_text().splitlines()
        assert "[Service]" in lines, unit
        env = dict(
            line.removeprefix("Environment=").split("=", 1)
            for line in lines
            if line.startswith("Environment=")
        )
        assert env["ROS_SECURITY_ENABLE"] == "true", unit
        assert env["ROS_SECURITY_STRATEGY"] == "Enforce", unit
        assert env["ROS_SECURITY_KEYSTORE"] == "/etc/robot-stack-sros2", unit
        assert env["ROS_SECURITY_ENCLAVE"] in grants, unit
        enclaves.add(env["ROS_SECURITY_ENCLAVE"])
    assert len(enclaves) == len(ros_units)  # one enclave per unit
    assert {"/robot_stack/vision", "/robot_stack/navigation"} <= enclaves


def test_the_cloud_facing_vision_unit_is_confined_beyond_the_others() -> None:
    lines = (ROOT / "deploy/robot-mcp-perception.service").read_text().splitlines()
    for setting in (
        "ProtectProc=invisible",
        "SystemCallFilter=~@privileged",
        "UMask=0077",
        "StateDirectoryMode=0700",
        "CapabilityBoundingSet=",
        "DevicePolicy=closed",
    ):
        assert setting in lines, setting
