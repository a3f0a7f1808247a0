"""EventPoster against a real signature-checking receiver on loopback."""

from __future__ import annotations

import asyncio
import json
import random
from collections import Counter
from pathlib import Path
from typing import Any

import httpx
import pytest

from robot_mcp_kit.dead_letters import main as dead_letters_cli
from robot_mcp_kit.models import TaskEvent
from robot_mcp_kit.outbox import OutboxFullError, OutboxLockedError
from robot_mcp_kit.poster import PosterClosedError
from robot_mcp_kit.signing import HEADER_SERVER
from robot_stack_testing import async_wait_until
from robot_stack_testing.kit.receiver import (
    ReceiverServer,
    RecordingReceiver,
    Reply,
    order_violations,
)

SECRET = "kit-test-secret-\u00e9"  # the fixtures' secret (conftest.py)

FAILURE = {"error_code": "DOOR_CLOSED", "message": "the door is closed", "recoverable": True}


async def wait_accepted(receiver: RecordingReceiver, ids: set[str], timeout_s: float = 20) -> None:
    await async_wait_until(
        lambda: ids <= receiver.accepted_ids(),
        timeout_s,
        f"{len(ids - receiver.accepted_ids())} of {len(ids)} events still undelivered",
    )


async def test_events_arrive_signed_in_order_with_server_header(
    make_poster: Any, receiver: RecordingReceiver, receiver_server: ReceiverServer
) -> None:
    await receiver_server.start()
    poster = make_poster()
    await poster.start()
    emitted = [await poster.emit("nav-1", "navigate_to", "progress", {"pct": p}) for p in range(5)]
    emitted.append(await poster.emit("nav-1", "navigate_to", "task_done", {"arrived": True}))

    await wait_accepted(receiver, {e.event_id for e in emitted})

    assert [d.event.seq for d in receiver.accepted()] == [0, 1, 2, 3, 4, 5]
    assert [d.event for d in receiver.accepted()] == emitted
    assert receiver.rejections == []
    assert all(d.event.server == "navigation" for d in receiver.accepted())
    assert await poster.wait_drained(5)
    assert poster.pending_count() == 0


async def test_events_queued_while_receiver_is_down_arrive_when_it_comes_up(
    make_poster: Any, receiver: RecordingReceiver, receiver_server: ReceiverServer
) -> None:
    poster = make_poster()
    await poster.start()
    emitted = [
        await poster.emit(f"t{i % 3}", "navigate_to", "progress", {"i": i}) for i in range(12)
    ]
    assert poster.pending_count() == 12
    assert receiver.attempts == 0

    await receiver_server.start()
    await wait_accepted(receiver, {e.event_id for e in emitted})

    assert order_violations(receiver.deliveries) == []
    for task in ("t0", "t1", "t2"):
        assert [d.event.seq for d in receiver.accepted() if d.event.task_id == task] == [
            0,
            1,
            2,
            3,
        ]


async def test_receiver_restarting_mid_stream_loses_nothing_and_keeps_task_order(
    make_poster: Any, receiver: RecordingReceiver, receiver_server: ReceiverServer
) -> None:
    await receiver_server.start()
    poster = make_poster()
    await poster.start()
    rng = random.Random(7)
    emitted: list[TaskEvent] = []
    for i in range(150):
        task = f"task-{rng.randrange(6)}"
        emitted.append(await poster.emit(task, "navigate_to", "progress", {"i": i}))
        if i in (40, 100):
            await receiver_server.stop()
        if i in (70, 130):
            await receiver_server.start()
        await asyncio.sleep(0.002)

    await wait_accepted(receiver, {e.event_id for e in emitted}, timeout_s=30)

    assert order_violations(receiver.deliveries) == []
    delivered = Counter(d.event.event_id for d in receiver.accepted())
    assert set(delivered) == {e.event_id for e in emitted}
    for task in {e.task_id for e in emitted}:
        seqs = sorted({d.event.seq for d in receiver.accepted() if d.event.task_id == task})
        assert seqs == list(range(len(seqs)))


async def test_server_errors_and_429_are_retried_with_the_same_event_id(
    make_poster: Any, receiver: RecordingReceiver, receiver_server: ReceiverServer
) -> None:
    answers = iter([Reply(503), Reply(500), Reply(429, {"Retry-After": "1"})])
    receiver.responder = lambda event: next(answers, None)
    await receiver_server.start()
    poster = make_poster()
    await poster.start()

    event = await poster.emit("nav-9", "navigate_to", "task_done", {"ok": True})
    await wait_accepted(receiver, {event.event_id})

    assert [d.status for d in receiver.deliveries] == [503, 500, 429, 200]
    assert {d.event.event_id for d in receiver.deliveries} == {event.event_id}
    assert len({d.body for d in receiver.deliveries}) == 1
    assert receiver.deliveries[3].received_at - receiver.deliveries[2].received_at >= 0.9
    assert poster.stats()["retries"] == 3


async def test_a_malformed_event_goes_to_the_dead_letters_and_the_task_moves_on(
    make_poster: Any, receiver: RecordingReceiver, receiver_server: ReceiverServer
) -> None:
    receiver.responder = lambda event: Reply(422) if event.payload.get("bad") else None
    await receiver_server.start()
    poster = make_poster()
    await poster.start()

    bad = await poster.emit("nav-2", "navigate_to", "progress", {"bad": True})
    good = await poster.emit("nav-2", "navigate_to", "task_done", {"bad": False})
    await wait_accepted(receiver, {good.event_id})

    assert [(d.event.event_id, d.status) for d in receiver.deliveries] == [
        (bad.event_id, 422),
        (good.event_id, 200),
    ]
    assert poster.stats()["rejected"] == 1
    assert await poster.wait_drained(5)
    letters = await poster.dead_letters()
    assert [(d.event_id, d.status) for d in letters] == [(bad.event_id, 422)]
    assert TaskEvent.model_validate_json(letters[0].body) == bad
    assert poster.health()["dead_letters"] == 1


async def test_a_400_is_dead_lettered_kept_across_restarts_and_listed_by_the_cli(
    make_poster: Any,
    receiver: RecordingReceiver,
    receiver_server: ReceiverServer,
    outbox_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    receiver.responder = lambda event: Reply(400)
    await receiver_server.start()
    poster = make_poster()
    await poster.start()
    bad = await poster.emit("nav-9", "navigate_to", "task_done", {"x": 1})
    assert await poster.wait_drained(10)
    await poster.close()
    capsys.readouterr()  # drop the poster's own log lines

    assert dead_letters_cli([str(outbox_path)]) == 0
    listed = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [(d["event_id"], d["status"], d["type"]) for d in listed] == [
        (bad.event_id, 400, "task_done")
    ]
    again = make_poster()
    await again.start()
    assert again.health()["dead_letters"] == 1
    assert again.pending_count() == 0


async def test_a_wrong_secret_keeps_the_event_retries_it_and_shows_in_health(
    make_poster: Any, receiver: RecordingReceiver, receiver_server: ReceiverServer
) -> None:
    receiver.secrets["navigation"] = "another-secret"
    await receiver_server.start()
    poster = make_poster()
    await poster.start()

    event = await poster.emit("nav-3", "navigate_to", "task_done", {})
    # wait on the poster's own count: the receiver records a refusal before the poster has
    # read the 401 answer
    await async_wait_until(lambda: poster.health()["refused"] >= 3, 10.0, "three refused attempts")

    assert len(receiver.rejections) >= 3
    assert set(receiver.rejections) == {"bad_signature"}
    assert poster.pending_count() == 1  # kept in the outbox, not dropped
    health = poster.health()
    assert health["status"] == "refused"
    assert health["last_refusal"]["status"] == 401
    assert health["refused"] >= 3

    receiver.secrets["navigation"] = SECRET  # the operator fixes the secret
    await wait_accepted(receiver, {event.event_id})
    # the receiver records the delivery before the poster has read the 200 answer
    assert await poster.wait_drained(5)
    assert poster.health()["status"] == "ok"


@pytest.mark.parametrize("status", [401, 403, 404])
async def test_refusals_of_the_receiver_keep_the_event(
    make_poster: Any, receiver: RecordingReceiver, receiver_server: ReceiverServer, status: int
) -> None:
    refuse = {"on": True}
    receiver.responder = lambda event: Reply(status) if refuse["on"] else None
    await receiver_server.start()
    poster = make_poster()
    await poster.start()

    event = await poster.emit("nav-4", "navigate_to", "watch_event", {})
    await async_wait_until(lambda: len(receiver.deliveries) >= 2, 10.0, "two refused attempts")
    assert poster.pending_count() == 1
    assert poster.health()["last_refusal"]["status"] == status
    refuse["on"] = False
    await wait_accepted(receiver, {event.event_id})
    assert await poster.dead_letters() == []


async def test_a_failing_head_blocks_only_its_own_task(
    make_poster: Any, receiver: RecordingReceiver, receiver_server: ReceiverServer
) -> None:
    blocked = {"on": True}
    receiver.responder = lambda event: (
        Reply(503) if event.task_id == "stuck" and blocked["on"] else None
    )
    await receiver_server.start()
    poster = make_poster()
    await poster.start()

    stuck = [await poster.emit("stuck", "navigate_to", "progress", {"i": i}) for i in range(3)]
    free = [await poster.emit("free", "navigate_to", "progress", {"i": i}) for i in range(3)]
    await wait_accepted(receiver, {e.event_id for e in free})

    assert not any(d.event.task_id == "stuck" and d.status == 200 for d in receiver.deliveries)
    assert {d.event.event_id for d in receiver.deliveries if d.event.task_id == "stuck"} == {
        stuck[0].event_id
    }
    blocked["on"] = False
    await wait_accepted(receiver, {e.event_id for e in stuck})
    assert order_violations(receiver.deliveries) == []


async def test_a_second_poster_on_the_same_outbox_delivers_and_continues_seq(
    make_poster: Any, receiver: RecordingReceiver, receiver_server: ReceiverServer
) -> None:
    first = make_poster()
    await first.start()
    before = [await first.emit("nav-4", "navigate_to", "progress", {"i": i}) for i in range(4)]
    await first.close(flush_timeout_s=0.2)  # receiver down: everything stays in the outbox

    await receiver_server.start()
    second = make_poster()
    await second.start()
    assert second.pending_count() == 4
    after = await second.emit("nav-4", "navigate_to", "task_done", {"arrived": True})

    await wait_accepted(receiver, {e.event_id for e in [*before, after]})
    assert after.seq == 4
    assert [d.event.seq for d in receiver.accepted()] == [0, 1, 2, 3, 4]


async def test_close_flushes_pending_events_when_the_receiver_is_up(
    make_poster: Any,
    receiver: RecordingReceiver,
    receiver_server: ReceiverServer,
    outbox_path: Path,
) -> None:
    await receiver_server.start()
    poster = make_poster()
    await poster.start()
    emitted = [await poster.emit("nav-5", "navigate_to", "progress", {"i": i}) for i in range(20)]

    await poster.close(flush_timeout_s=10)

    assert receiver.accepted_ids() >= {e.event_id for e in emitted}
    assert poster.pending_count() == 0
    with pytest.raises(PosterClosedError):
        await poster.emit("nav-5", "navigate_to", "progress", {})
    reopened = make_poster()
    await reopened.start()
    assert reopened.pending_count() == 0


async def test_only_one_live_poster_may_hold_an_outbox(make_poster: Any) -> None:
    first = make_poster()
    await first.start()
    second = make_poster()
    with pytest.raises(OutboxLockedError):
        await second.start()


async def test_outbox_pressure_drops_oldest_progress_then_triggers_never_terminal_events(
    make_poster: Any, receiver: RecordingReceiver, receiver_server: ReceiverServer
) -> None:
    # Slow retries: after its first failed attempt each lane's head waits >= 2 s, so the test
    # can wait until no post is under way (an event in flight is never dropped for room).
    poster = make_poster(max_outbox=4, backoff_initial_s=4.0, backoff_max_s=4.0)

    async def quiet(attempts: int) -> None:
        def settled() -> bool:
            stats = poster.stats()
            return stats["retries"] >= attempts and stats["in_flight"] == 0

        await async_wait_until(settled, 10.0, f"{attempts} first attempts over, none in flight")

    await poster.start()
    p0 = await poster.emit("a", "navigate_to", "progress", {"i": 0})
    t0 = await poster.emit("a", "navigate_to", "trigger_fired", {"trigger": "eta_below"})
    p1 = await poster.emit("b", "navigate_to", "progress", {"i": 1})
    d0 = await poster.emit("a", "navigate_to", "task_done", {})
    await quiet(2)  # lane heads p0, p1
    w0 = await poster.emit("w", "watch", "watch_event", {"x": 1})  # drops p0
    await quiet(4)  # + t0 (now head of a), w0
    f0 = await poster.emit("b", "navigate_to", "task_failed", FAILURE)  # drops p1
    await quiet(5)  # + f0
    d1 = await poster.emit("c", "navigate_to", "task_done", {})  # drops t0
    with pytest.raises(OutboxFullError):
        await poster.emit("c", "navigate_to", "task_done", {})
    assert poster.pending_count() == 4
    assert poster.stats()["dropped"] == 3

    await receiver_server.start()
    await wait_accepted(receiver, {d0.event_id, w0.event_id, f0.event_id, d1.event_id})
    assert receiver.accepted_ids().isdisjoint({p0.event_id, t0.event_id, p1.event_id})


async def test_emit_refuses_bad_events_without_touching_the_outbox(make_poster: Any) -> None:
    poster = make_poster()
    with pytest.raises(PosterClosedError):
        await poster.emit("x", "tool", "progress", {})
    await poster.start()
    with pytest.raises(ValueError, match="error_code"):
        await poster.emit("x", "tool", "task_failed", {"message": "no code"})
    with pytest.raises(ValueError, match="type"):
        await poster.emit("x", "tool", "finished", {})
    assert poster.pending_count() == 0
    event = await poster.emit("x", "tool", "progress", {})
    assert event.seq == 0


async def test_requests_carry_the_three_rvc_headers(
    make_poster: Any, receiver: RecordingReceiver, receiver_server: ReceiverServer
) -> None:
    seen: list[str] = []
    inner = receiver.__call__

    async def spy(scope: Any, receive: Any, send: Any) -> None:
        seen.extend(k.decode().lower() for k, _ in scope.get("headers", []))
        await inner(scope, receive, send)

    receiver_server.app = spy
    await receiver_server.start()
    poster = make_poster()
    await poster.start()
    event = await poster.emit("nav-6", "navigate_to", "progress", {})
    await wait_accepted(receiver, {event.event_id})
    assert {HEADER_SERVER.lower(), "x-rvc-timestamp", "x-rvc-signature"} <= set(seen)


async def test_a_supplied_http_client_is_used_and_left_open(
    make_poster: Any, receiver: RecordingReceiver, receiver_server: ReceiverServer
) -> None:
    await receiver_server.start()
    async with httpx.AsyncClient() as client:
        poster = make_poster(client=client)
        await poster.start()
        event = await poster.emit("nav-7", "navigate_to", "task_done", {})
        await wait_accepted(receiver, {event.event_id})
        await poster.close()
        assert not client.is_closed


async def test_an_emit_whose_caller_is_cancelled_is_still_delivered(
    make_poster: Any, receiver: RecordingReceiver, receiver_server: ReceiverServer
) -> None:
    await receiver_server.start()
    poster = make_poster()
    await poster.start()
    task = asyncio.create_task(poster.emit("nav-8", "navigate_to", "task_done", {"n": 1}))
    await asyncio.sleep(0)  # the emit is now storing
    task.cancel()
    with pytest.raises(asyncio.CancelledError):
        await task
    await async_wait_until(lambda: len(receiver.accepted()) == 1, 10, "the cancelled emit")
    assert receiver.accepted()[0].event.payload == {"n": 1}
