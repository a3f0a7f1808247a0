"""The robot says once per outage that it sees with the on-board detector."""

from __future__ import annotations

import json

from robot_voice_chat.agent.perception_notice import FALLBACK_SENTENCE, FallbackNotice


def _result(fallback: bool) -> str:
    return json.dumps({"skill": "find", "grounder": "x", "grounder_fallback": fallback})


def test_the_fallback_is_told_once_per_outage_and_again_after_the_cloud_came_back() -> None:
    notice = FallbackNotice()
    assert notice.sentence_for("perception.wait_for_result", _result(True)) == FALLBACK_SENTENCE
    assert notice.sentence_for("perception.get_latest", _result(True)) is None
    assert notice.sentence_for("perception.get_latest", _result(False)) is None
    assert notice.sentence_for("perception.get_latest", _result(True)) == FALLBACK_SENTENCE


def test_results_without_the_marker_or_from_other_servers_say_nothing() -> None:
    notice = FallbackNotice()
    assert notice.sentence_for("navigation.get_pose", _result(True)) is None
    assert notice.sentence_for("perception.list_buffers", '{"buffers": []}') is None
    assert notice.sentence_for("perception.list_buffers", "not json") is None
    nested = json.dumps({"detections": [{"extra": {"grounder_fallback": True}}]})
    assert notice.sentence_for("perception.what_do_you_see", nested) == FALLBACK_SENTENCE
