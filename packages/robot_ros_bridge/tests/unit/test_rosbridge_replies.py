import pytest

from robot_ros_bridge import RemoteError
from robot_ros_bridge.vision_tasks import decode_reply, service_names


def test_service_names_live_under_the_vision_node_name() -> None:
    assert service_names("vision_node") == {
        "create": "/vision_node/create_vision_task",
        "manage": "/vision_node/manage_vision_task",
        "list": "/vision_node/list_vision_tasks",
    }
    assert service_names("/robot/vision/")["list"] == "/robot/vision/list_vision_tasks"


def test_a_successful_reply_decodes_to_its_json_object() -> None:
    assert decode_reply(True, '{"name": "a", "topics": {}}', "s") == {"name": "a", "topics": {}}
    assert decode_reply(True, "", "s") == {}


def test_a_failed_reply_carries_the_nodes_error_code_and_detail() -> None:
    with pytest.raises(RemoteError) as info:
        decode_reply(False, '{"error": "duplicate_name", "detail": "exists"}', "s")
    assert (info.value.code, info.value.detail) == ("duplicate_name", "exists")


def test_a_failed_reply_without_json_still_becomes_a_clean_error() -> None:
    with pytest.raises(RemoteError) as info:
        decode_reply(False, "boom", "s")
    assert info.value.code == "vision_task_failed"
    assert info.value.detail == "boom"


def test_a_successful_reply_that_is_not_a_json_object_is_a_bad_reply() -> None:
    with pytest.raises(RemoteError) as info:
        decode_reply(True, "[1, 2]", "/x/list_vision_tasks")
    assert info.value.code == "bad_reply"
    with pytest.raises(RemoteError):
        decode_reply(True, "not json", "s")
