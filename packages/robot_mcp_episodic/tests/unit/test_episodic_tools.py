"""The tools' edges: bad inputs are clear tool errors, notes, status, forget with its audit."""

from __future__ import annotations

import time
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from mcp import Client

from robot_mcp_episodic.composition import EpisodicApp, build_app
from robot_mcp_episodic.config import EpisodicConfig
from robot_mcp_episodic.episode import ManualClock
from robot_mcp_episodic.timeparse import iso
from robot_mcp_kit.approvals import ApprovalVerifier, signed_approval
from robot_mcp_kit.caller import install_caller_context
from robot_stack_testing.kit.tool_calls import tool_answer

T = 1_790_000_000.0
APPROVAL_SECRET = "episodic-approval-secret-for-the-unit-tests"


@pytest.fixture
def app(tmp_path: Path) -> Iterator[EpisodicApp]:
    clock = ManualClock(T)
    built = build_app(
        EpisodicConfig(data_dir=tmp_path, record_raw=False), record_ros=False, clock=clock
    )
    install_caller_context(built.server, ApprovalVerifier("episodic", APPROVAL_SECRET))
    try:
        yield built
    finally:
        built.close()


async def call(app: EpisodicApp, tool: str, **args: Any) -> dict[str, Any]:
    async with Client(app.server) as client:
        answer: dict[str, Any] = await tool_answer(client, tool, args)
        return answer


def approval(args: dict[str, Any], by: str = "alice") -> dict[str, Any]:
    """The approval the brain signs for exactly this forget call (a fresh id each time)."""
    return signed_approval(
        APPROVAL_SECRET,
        server="episodic",
        tool="forget",
        arguments=args,
        approval_id=f"ap-{uuid.uuid4().hex[:12]}",
        by=by,
    )


async def forget_approved(app: EpisodicApp, by: str = "alice", **args: Any) -> dict[str, Any]:
    """forget as the brain sends it after an operator approved exactly this call."""
    async with Client(app.server) as client:
        answer: dict[str, Any] = await tool_answer(client, "forget", args, approval(args, by))
        return answer


async def test_the_server_lists_the_contract_tools(app: EpisodicApp) -> None:
    async with Client(app.server) as client:
        tools = {tool.name: tool for tool in (await client.list_tools()).tools}
    assert set(tools) == {
        "what_happened", "last_seen", "search_memory", "pose_at", "memory_status", "forget",
        "record_note", "known_labels",
    }  # fmt: skip
    assert tools["known_labels"].input_schema.get("properties", {}) == {}
    assert set(tools["what_happened"].input_schema["properties"]) == {
        "start", "end", "kinds", "place", "max_items",
    }  # fmt: skip
    assert set(tools["last_seen"].input_schema["properties"]) == {"query", "before", "place", "n"}
    assert set(tools["search_memory"].input_schema["properties"]) == {
        "query", "start", "end", "place", "k",
    }  # fmt: skip
    assert set(tools["pose_at"].input_schema["properties"]) == {"time"}
    assert set(tools["forget"].input_schema["properties"]) == {
        "start", "end", "label", "place", "dry_run",
    }  # fmt: skip
    assert set(tools["record_note"].input_schema["properties"]) == {"kind", "text", "mission_id"}


@pytest.mark.parametrize(
    ("tool", "args", "code", "words"),
    [
        ("what_happened", {"start": "yesterday-ish"}, "invalid_time", "start"),
        ("what_happened", {"start": "3pm +5x"}, "invalid_time", "offset"),
        ("what_happened", {"start": "-1m", "end": "-10m"}, "invalid_range", "before start"),
        ("what_happened", {"place": "garage"}, "unknown_place", "known places"),
        ("what_happened", {"kinds": ["dreams"]}, "invalid_argument", "unknown kinds"),
        ("last_seen", {"query": "mug", "before": "tomorrow"}, "invalid_time", "before"),
        ("last_seen", {"query": "mug", "place": "moon"}, "unknown_place", "moon"),
        ("last_seen", {"query": "the"}, "invalid_argument", "query"),
        ("search_memory", {"query": "mug", "start": "-1h", "end": "-2h"}, "invalid_range", "end"),
        ("search_memory", {"query": "   "}, "invalid_argument", "query"),
        ("pose_at", {"time": "half past"}, "invalid_time", "time"),
        ("pose_at", {"time": "2099-01-01T00:00:00Z"}, "invalid_time", "future"),
        ("forget", {"start": "-1h", "end": "-2h"}, "invalid_range", "end"),
        ("forget", {"start": "-1h", "end": "now", "place": "attic"}, "unknown_place", "attic"),
        ("record_note", {"kind": "gossip", "text": "x"}, "invalid_argument", "kind"),
        ("record_note", {"kind": "user", "text": "  "}, "invalid_argument", "empty"),
    ],
)
async def test_bad_inputs_are_clear_tool_errors(
    app: EpisodicApp, tool: str, args: dict[str, Any], code: str, words: str
) -> None:
    answer = await call(app, tool, **args)
    assert answer["_error"]["error"] == code
    assert words in answer["_error"]["detail"]


async def test_out_of_range_numbers_are_rejected_by_the_schema(app: EpisodicApp) -> None:
    answer = await call(app, "last_seen", query="mug", n=0)
    assert "_error" in answer


async def test_a_note_is_searchable_at_once_and_stamped_with_time_and_place(
    app: EpisodicApp,
) -> None:
    app.memory.indexer.on_pose(T - 1, 9.0, -3.0, 0.0)
    note = await call(
        app, "record_note", kind="user", text="The kettle is broken", mission_id="m-7"
    )
    assert note["id"].startswith("n-")
    assert (note["time"], note["place"], note["kind"]) == (iso(T), "kitchen", "user")

    found = await call(app, "search_memory", query="kettle")
    assert [r["id"] for r in found["results"]] == [note["id"]]
    assert found["results"][0]["mission_id"] == "m-7"


async def test_memory_status_reports_rows_sizes_retention_and_gaps(app: EpisodicApp) -> None:
    indexer = app.memory.indexer
    indexer.on_pose(T - 600, 0.0, 0.0, 0.0)
    indexer.on_pose(T - 10, 0.0, 0.0, 0.0)  # 590 s without a pose: a recording gap
    indexer.on_detections("detect", T - 5, [{"label": "mug", "score": 0.9}])

    status = await call(app, "memory_status")
    assert status["index"]["poses"]["rows"] == 2
    assert status["index"]["sightings"]["rows"] == 1
    assert status["recording_gaps"] == [{"from": iso(T - 600), "to": iso(T - 10), "seconds": 590}]
    assert status["retention"]["flush_s"] == 1.0
    assert status["retention"]["recordings_h"] == 72.0
    assert status["last_write"]["detections:detect"]["ago"] == "5 s ago"
    assert status["size_bytes"]["index"] > 0
    assert status["oldest_record"]["time"] == iso(T - 600)
    assert status["recordings"]["enabled"] is False


async def test_known_labels_are_every_label_seen_and_follow_forget(app: EpisodicApp) -> None:
    assert await call(app, "known_labels") == {"labels": [], "count": 0}
    indexer = app.memory.indexer
    indexer.on_detections("detect", T - 90, [{"label": "umbrella", "score": 0.9}])
    indexer.on_detections("detect", T - 80, [{"label": "mug", "score": 0.8}])
    indexer.on_detections("detect", T - 70, [{"label": "mug", "score": 0.8}])
    assert await call(app, "known_labels") == {"labels": ["mug", "umbrella"], "count": 2}

    await forget_approved(app, start="-5m", end="now", label="umbrella", dry_run=False)
    assert (await call(app, "known_labels"))["labels"] == ["mug"]


async def test_forget_previews_then_deletes_and_audits(app: EpisodicApp) -> None:
    indexer = app.memory.indexer
    indexer.on_pose(T - 100, 9.0, -3.0, 0.0)
    indexer.on_detections("detect", T - 90, [{"label": "toothbrush", "score": 0.9}])
    indexer.on_detections("detect", T - 90, [{"label": "mug", "score": 0.9}])
    indexer.note("scene", "A toothbrush on the kitchen counter", t=T - 89)
    indexer.note("scene", "The fridge hums", t=T - 88)

    preview = await call(app, "forget", start="-5m", end="now", label="toothbrush")
    assert preview["would_delete"] == {
        "sightings": 1, "notes": 1, "poses": 0, "visits": 0, "recorded_messages": 0,
    }  # fmt: skip
    assert (await call(app, "last_seen", query="toothbrush"))["found"] is True  # preview only

    done = await forget_approved(app, start="-5m", end="now", label="toothbrush", dry_run=False)
    assert done["deleted"]["sightings"] == 1
    assert (await call(app, "last_seen", query="toothbrush"))["found"] is False
    assert (await call(app, "search_memory", query="toothbrush"))["found"] is False
    assert (await call(app, "last_seen", query="mug"))["found"] is True
    status = await call(app, "memory_status")
    assert status["forget_audit"][0]["request"]["label"] == "toothbrush"
    assert status["forget_audit"][0]["result"]["sightings"] == 1
    assert status["forget_audit"][0]["request"]["approved_by"] == "alice"


async def test_forget_deletes_nothing_without_an_approval_of_that_exact_call(
    app: EpisodicApp,
) -> None:
    app.memory.indexer.on_detections("detect", T - 90, [{"label": "mug", "score": 0.9}])
    everything = {"start": "-36500d", "end": "now", "dry_run": False}
    refused = await call(app, "forget", **everything)
    assert refused["_error"]["error"] == "approval_required"
    async with Client(app.server) as client:  # an approval for another call does not count
        meta = approval({**everything, "label": "mug"})
        other = await tool_answer(client, "forget", everything, meta)
    assert other["_error"]["error"] == "approval_invalid"
    assert "(other_arguments)" in other["_error"]["detail"]
    assert (await call(app, "last_seen", query="mug"))["found"] is True
    assert (await call(app, "memory_status"))["forget_audit"] == []
    preview = await call(app, "forget", start="-5m", end="now")  # a preview needs no approval
    assert preview["would_delete"]["sightings"] == 1


def _tampered(meta: dict[str, Any], **changes: Any) -> dict[str, Any]:
    return {key: {**value, **changes} for key, value in meta.items()}


async def test_a_forged_replayed_or_expired_approval_deletes_nothing(app: EpisodicApp) -> None:
    """Issue 35: with the brain's principal, a made-up approval (approved_by "mallory")
    deleted 12 poses and 2,392 recorded messages."""
    indexer = app.memory.indexer
    indexer.on_pose(T - 100, 9.0, -3.0, 0.0)
    indexer.on_detections("detect", T - 90, [{"label": "mug", "score": 0.9}])
    everything = {"start": "-36500d", "end": "now", "dry_run": False}
    genuine = approval(everything)
    key = next(iter(genuine))
    stale = approval(everything)
    stale[key] = {**stale[key], "expires": int(time.time()) - 600}
    unsigned = {key: {"approval_id": "ap-123456789abc", "by": "mallory", "call": "0" * 64}}
    for meta, check in (
        (unsigned, "malformed"),  # issue 27's format: no signature
        (_tampered(genuine, by="mallory"), "bad_signature"),  # a made-up approver
        (stale, "bad_signature"),  # an expiry changed after signing
        (_tampered(genuine, server="memory"), "bad_signature"),
    ):
        async with Client(app.server) as client:
            refused = await tool_answer(client, "forget", everything, meta)
        assert refused["_error"]["error"] == "approval_invalid", meta
        assert f"({check})" in refused["_error"]["detail"]
    async with Client(app.server) as client:  # the genuine one works once
        done = await tool_answer(client, "forget", everything, genuine)
        again = await tool_answer(client, "forget", everything, genuine)
    assert done["deleted"]["sightings"] == 1
    assert again["_error"]["error"] == "approval_invalid"
    assert "(replayed)" in again["_error"]["detail"]
    audit = (await call(app, "memory_status"))["forget_audit"]
    assert [entry["request"]["approved_by"] for entry in audit] == ["alice"]


async def test_an_expired_approval_deletes_nothing(app: EpisodicApp) -> None:
    app.memory.indexer.on_detections("detect", T - 90, [{"label": "mug", "score": 0.9}])
    everything = {"start": "-36500d", "end": "now", "dry_run": False}
    install_caller_context(
        app.server,
        ApprovalVerifier("episodic", APPROVAL_SECRET, clock=lambda: time.time() + 200),
    )
    async with Client(app.server) as client:
        refused = await tool_answer(client, "forget", everything, approval(everything))
    assert refused["_error"]["error"] == "approval_invalid"
    assert "(expired)" in refused["_error"]["detail"]
    assert (await call(app, "last_seen", query="mug"))["found"] is True
    assert (await call(app, "memory_status"))["forget_audit"] == []


async def test_forget_a_whole_window_removes_every_kind(app: EpisodicApp) -> None:
    indexer = app.memory.indexer
    indexer.on_pose(T - 100, 9.0, -3.0, 0.0)
    indexer.on_detections("detect", T - 90, [{"label": "mug", "score": 0.9}])
    indexer.note("user", "a secret", t=T - 80)
    done = await forget_approved(app, start="-5m", end="now", dry_run=False)
    assert done["deleted"] == {
        "sightings": 1, "notes": 1, "poses": 1, "visits": 1, "recorded_messages": 0,
    }  # fmt: skip
    happened = await call(app, "what_happened", start="-5m")
    assert happened["items"] == []


async def test_forget_removes_the_label_from_index_and_recordings(tmp_path: Path) -> None:
    from rclpy.serialization import serialize_message
    from ros2_vision_interfaces.msg import VisionDetection, VisionDetectionArray
    from rosbags.highlevel import AnyReader

    clock = ManualClock(T)
    app = build_app(EpisodicConfig(data_dir=tmp_path), record_ros=False, clock=clock)
    install_caller_context(app.server, ApprovalVerifier("episodic", APPROVAL_SECRET))
    try:
        assert app.memory.bags is not None
        for i in range(6):
            labels = ["toothbrush", "mug"] if i < 3 else ["mug"]
            msg = VisionDetectionArray()
            for label in labels:
                det = VisionDetection()
                det.label = label
                msg.detections.append(det)
            stamp = T - 60 + i
            app.memory.indexer.on_detections("detect", stamp, [{"label": x} for x in labels])
            app.memory.bags.write("/vision/detect/detections_meta",
                                  "ros2_vision_interfaces/msg/VisionDetectionArray",
                                  serialize_message(msg), int(stamp * 1e9))  # fmt: skip
        preview = await call(app, "forget", start="-5m", end="now", label="toothbrush")
        assert preview["would_delete"]["recorded_messages"] == 3
        done = await forget_approved(app, start="-5m", end="now", label="toothbrush", dry_run=False)
        assert done["deleted"]["recorded_messages"] == 3
        status = await call(app, "memory_status")
        assert status["recordings"]["messages"] == 3
    finally:
        app.close()
    labels_left = []
    for bag in sorted((tmp_path / "bags").iterdir()):
        with AnyReader([bag]) as reader:
            for connection, _, raw in reader.messages():
                message = reader.deserialize(raw, connection.msgtype)
                labels_left += [d.label for d in message.detections]
    assert labels_left == ["mug", "mug", "mug"]
