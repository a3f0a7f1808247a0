"""Our audio_common_msgs definitions are byte-identical to audio_common's ROS 2 release named in
upstream/UPSTREAM.json, so a robot's audio capture node (audio_capture, or any node publishing
audio_common_msgs) talks to this stack; the generated types carry upstream's fields."""

from __future__ import annotations

import hashlib
import json
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest

PACKAGE = Path(__file__).resolve().parents[1]
UPSTREAM = PACKAGE / "upstream"


def manifest() -> dict[str, Any]:
    data: dict[str, Any] = json.loads((UPSTREAM / "UPSTREAM.json").read_text())
    return data


def git_blob_id(content: bytes) -> str:
    """What `git hash-object` prints: upstream's tree lists this id for the file."""
    return hashlib.sha1(b"blob %d\0" % len(content) + content, usedforsecurity=False).hexdigest()


def test_the_release_is_named_with_its_commit() -> None:
    data = manifest()
    assert data["repository"] == "https://github.com/ros-drivers/audio_common"
    assert data["branch"] == "ros2"
    assert len(data["commit"]) == 40
    int(data["commit"], 16)
    assert data["commit"] in (PACKAGE / "README.md").read_text()


@pytest.mark.parametrize("upstream_path", sorted(manifest()["files"]))
def test_every_definition_is_byte_identical_to_the_upstream_copy(upstream_path: str) -> None:
    entry = manifest()["files"][upstream_path]
    ours = (PACKAGE / entry["ours"]).read_bytes()
    assert ours == (UPSTREAM / entry["copy"]).read_bytes()
    assert git_blob_id(ours) == entry["git_blob"], "not the blob upstream's commit holds"


def test_every_built_definition_comes_from_upstream() -> None:
    tracked = {PACKAGE / entry["ours"] for entry in manifest()["files"].values()}
    assert set((PACKAGE / "msg").glob("*.msg")) == tracked
    cmake = (PACKAGE / "CMakeLists.txt").read_text()
    for path in tracked:
        assert f'"{path.relative_to(PACKAGE)}"' in cmake


def test_package_name_and_version_are_the_release() -> None:
    root = ET.parse(PACKAGE / "package.xml").getroot()  # noqa: S314 - our own file
    assert root.findtext("name") == "audio_common_msgs"
    assert root.findtext("version") == manifest()["release"]


def test_the_generated_messages_have_the_release_fields() -> None:
    from audio_common_msgs.msg import AudioData, AudioDataStamped, AudioInfo

    assert AudioData.get_fields_and_field_types() == {"data": "sequence<uint8>"}
    assert AudioDataStamped.get_fields_and_field_types() == {
        "header": "std_msgs/Header",
        "audio": "audio_common_msgs/AudioData",
    }
    assert set(AudioInfo.get_fields_and_field_types()) == {
        "channels",
        "sample_rate",
        "sample_format",
        "bitrate",
        "coding_format",
    }
    message = AudioDataStamped()
    message.audio.data = bytes(range(8))
    assert bytes(message.audio.data) == bytes(range(8))
