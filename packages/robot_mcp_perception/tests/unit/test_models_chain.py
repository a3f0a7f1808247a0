"""The grounder chain: the fallback answers on each named outage of the primary, marked; the
primary is left alone on a back-off and used again once it answers; the budget counts only
cloud requests; a bad answer is not an outage."""

from __future__ import annotations

import numpy as np
import pytest

from robot_mcp_perception.cost import RefusingMeter
from robot_mcp_perception.models import answers
from robot_mcp_perception.models.base import (
    GroundedTarget,
    GroundingResult,
    ModelError,
)
from robot_mcp_perception.models.chain import FallbackGrounder
from robot_mcp_perception.models.fakes import FakeGrounder
from robot_mcp_perception.models.metering import metered
from robot_mcp_perception.prompt_builder import BadModelAnswerError

IMAGE = np.zeros((40, 60, 3), np.uint8)
CLOUD = GroundingResult("cloud", targets=[GroundedTarget("mug", (1, 1, 9, 9), [(5, 5)])])
LOCAL = GroundingResult("local", targets=[GroundedTarget("mug", (2, 2, 8, 8), [(5, 5)])])


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


class CountingMeter:
    def __init__(self) -> None:
        self.charges = 0

    def charge(self) -> bool:
        self.charges += 1
        return True


def chain(primary: FakeGrounder, clock: Clock | None = None) -> FallbackGrounder:
    primary.name = "gemini_er"
    fallback = FakeGrounder(LOCAL, cost_class="local")
    fallback.name = "owlv2"
    return FallbackGrounder(primary, fallback, 10.0, 40.0, clock=clock or Clock())


@pytest.mark.parametrize("kind", ["network", "server_error", "quota", "timeout", "auth", "budget"])
async def test_each_named_outage_of_the_primary_is_answered_by_the_fallback_and_marked(
    kind: str,
) -> None:
    grounders = chain(FakeGrounder(error=ModelError("down", kind)))
    with answers.recording() as notes:
        result = await grounders.ground(IMAGE, "the mug")

    assert result is LOCAL
    assert answers.marks(notes) == {
        "grounder": "owlv2",
        "grounder_fallback": True,
        "fallback_reason": kind,
    }


async def test_the_primary_answering_is_marked_as_the_primary() -> None:
    grounders = chain(FakeGrounder(CLOUD))
    with answers.recording() as notes:
        assert await grounders.ground(IMAGE, "the mug") is CLOUD
    assert answers.marks(notes) == {"grounder": "gemini_er", "grounder_fallback": False}


async def test_after_an_outage_the_primary_rests_on_a_back_off_then_is_used_again() -> None:
    clock = Clock()
    primary = FakeGrounder([ModelError("503", "server_error"), CLOUD])
    grounders = chain(primary, clock)

    assert await grounders.ground(IMAGE, "a") is LOCAL
    clock.now += 5.0  # inside the 10 s back-off: the primary is not asked
    with answers.recording() as notes:
        assert await grounders.ground(IMAGE, "b") is LOCAL
    assert answers.marks(notes)["fallback_reason"] == "backoff"
    assert primary.ground_calls == 1

    clock.now += 6.0  # back-off over: the primary is tried again and answers
    with answers.recording() as notes:
        assert await grounders.ground(IMAGE, "c") is CLOUD
    assert answers.marks(notes)["grounder_fallback"] is False
    assert grounders.last_outage is None


async def test_the_back_off_doubles_per_outage_up_to_its_ceiling() -> None:
    clock = Clock()
    primary = FakeGrounder(error=ModelError("down", "network"))
    grounders = chain(primary, clock)
    waits = []
    for _ in range(4):
        await grounders.ground(IMAGE, "q")
        waits.append(grounders._retry_at - clock.now)
        clock.now = grounders._retry_at
    assert waits == [10.0, 20.0, 40.0, 40.0]


async def test_only_the_cloud_requests_are_charged_and_a_spent_budget_sends_none() -> None:
    primary = FakeGrounder(CLOUD)
    grounders = chain(primary)
    meter = CountingMeter()
    with metered(meter):
        await grounders.ground(IMAGE, "q")
    assert meter.charges == 1  # the primary's request

    with metered(RefusingMeter()), answers.recording() as notes:
        assert await grounders.ground(IMAGE, "q") is LOCAL
    assert primary.ground_calls == 1  # nothing was sent to the cloud
    assert answers.marks(notes)["fallback_reason"] == "budget"
    assert grounders.last_outage is None  # the node's own budget: no back-off

    primary.error = ModelError("down", "network")
    with metered(meter):
        await grounders.ground(IMAGE, "q")  # the primary was tried: charged; local: not
    assert meter.charges == 2


async def test_a_bad_answer_is_not_an_outage_and_reaches_the_node() -> None:
    grounders = chain(FakeGrounder(error=BadModelAnswerError("no JSON")))
    with pytest.raises(BadModelAnswerError):
        await grounders.ground(IMAGE, "q")


async def test_pointing_falls_back_like_grounding() -> None:
    grounders = chain(FakeGrounder(error=ModelError("quota", "quota")))
    assert await grounders.point(IMAGE, "every object") == LOCAL.targets


def test_the_chain_reports_ready_through_its_fallback_and_sums_the_worst_case() -> None:
    grounders = chain(FakeGrounder(CLOUD))
    assert grounders.readiness() is None
    assert grounders.worst_case_s is None
    assert grounders.cost_class == "cloud"
    assert grounders.name == "gemini_er"
    with pytest.raises(ValueError, match="retry_after_s"):
        FallbackGrounder(grounders.primary, grounders.fallback, 0.0)
