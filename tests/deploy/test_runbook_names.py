"""The RUNBOOK and the env examples name every credential install.sh writes (issue 35: the
RUNBOOK's list of <NAME>_MCP_TOKEN variables left out MANIPULATION), and the docs state the ROS
trust boundary in the same words everywhere an integrator reads."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
RUNBOOK = ROOT / "deploy/RUNBOOK.md"
TRUST_BOUNDARY = (
    "every process that can join the robot's ros domain can drive the base, open a lock and "
    "fake a pose"
)


def mcp_server_names() -> list[str]:
    """The NAMEs of install.sh's MCP_SERVERS entries ("<env file>:<NAME>")."""
    text = (ROOT / "deploy/install.sh").read_text()
    block = re.search(r"^MCP_SERVERS=\((.*?)^\)", text, re.S | re.M)
    assert block, "install.sh has no MCP_SERVERS=( … ) list"
    names = re.findall(r'"[a-z-]+:([A-Z_]+)"', block[1])
    assert len(names) >= 6, names
    return names


def test_install_sh_lists_the_manipulation_server_among_its_mcp_servers() -> None:
    assert "MANIPULATION" in mcp_server_names()


@pytest.mark.parametrize(
    "document",
    [
        "deploy/RUNBOOK.md",
        ".env.example",
        "packages/robot_voice_chat/README.md",
        "packages/robot_voice_chat/config/tools/mcp.yaml",
        "deploy/local-stack.yaml",
    ],
)
def test_every_brain_credential_install_sh_writes_is_named(document: str) -> None:
    text = (ROOT / document).read_text()
    missing = [f"{n}_MCP_TOKEN" for n in mcp_server_names() if f"{n}_MCP_TOKEN" not in text]
    assert not missing, f"{document} does not name {missing}"


def test_the_runbook_names_the_operator_credentials_and_the_vision_nodes() -> None:
    text = RUNBOOK.read_text()
    assert "<NAME>_MCP_OPERATOR_TOKEN" in text
    assert "MANIPULATION_MCP_OPERATOR_TOKEN" in text
    for name in ("ARTIFACTS_AUTH_TOKEN", "VISION_ARTIFACTS_TOKEN"):
        assert name in text, name
        assert name in (ROOT / "deploy/install.sh").read_text(), name


@pytest.mark.parametrize(
    "document",
    [
        "README.md",
        "deploy/RUNBOOK.md",
        "packages/robot_mcp_navigation/README.md",
        "packages/robot_mcp_manipulation/README.md",
    ],
)
def test_the_ros_trust_boundary_is_stated_with_what_closes_it(document: str) -> None:
    text = " ".join((ROOT / document).read_text().split()).lower().replace("*", "")
    assert TRUST_BOUNDARY in text, document
    for closes in ("sros2", "ros_automatic_discovery_range", "firewall"):
        assert closes in text, f"{document}: {closes}"


def test_the_runbook_enables_sros2_with_a_keystore_enclaves_and_enforce() -> None:
    text = RUNBOOK.read_text()
    for needed in (
        "ros2 security create_keystore",
        "deploy/sros2/policy.xml",
        "ROS_SECURITY_KEYSTORE",
        "ROS_SECURITY_ENABLE",
        "ROS_SECURITY_STRATEGY=Enforce",
        "ROS_SECURITY_ENCLAVE",
        "/robot_stack/vision",
    ):
        assert needed in text, needed
