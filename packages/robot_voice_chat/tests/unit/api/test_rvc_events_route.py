"""POST /api/agent/events (spec §3): HMAC, 401 cases, schema_version, dedupe, orphans, limits."""

from __future__ import annotations

import asyncio
import json
import stat
import time
from collections.abc import AsyncIterator
from pathlib import Path

import httpx
import numpy as np
import pytest
import structlog
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pydantic import SecretStr, ValidationError

from robot_mcp_kit.models import TaskEvent
from robot_mcp_kit.signing import sign, signed_headers
from robot_stack_testing import async_wait_until
from robot_stack_testing.brain.harness import NAV_SECRET, PERCEPTION_SECRET, make_harness
from robot_voice_chat.api.app import create_app
from robot_voice_chat.api.container import Adapters, Container
from robot_voice_chat.composition import assemble
from robot_voice_chat.main import main
from robot_voice_chat.services.emitter.base import FakeEventEmitter
from robot_voice_chat.services.llm.fake import FakeLLM, reply
from robot_voice_chat.services.speech.audio import wav_bytes
from robot_voice_chat.services.speech.fake import FakeSpeechInput, FakeSpeechOutput
from robot_voice_chat.settings import AppConfig, McpServerConfig, McpToolsConfig

SECRET = NAV_SECRET


def app_config(tmp_path: Path, **api: object) -> AppConfig:
    return AppConfig.model_validate(
        {
            "llm": {"_target_": "fake"},
            "speech_output": {"_target_": "fake"},
            "speech_input": {"_target_": "fake"},
            "agent": {"trace_dir": str(tmp_path / "traces"), "memory_server": ""},
            "api": {"event_rate_limit": "10000/minute", **api},
        }
    )


def container_for(tmp_path: Path, planner: FakeLLM | None = None, **api: object) -> Container:
    h = make_harness(tmp_path, planner or FakeLLM([]))
    adapters = Adapters(
        llm=FakeLLM([]),
        planner=planner or FakeLLM([]),
        tools=h.tools,
        speech_output=FakeSpeechOutput(),
        speech_input=FakeSpeechInput(),
    )
    return assemble(app_config(tmp_path, **api), adapters, FakeEventEmitter())


@pytest.fixture
async def client(tmp_path: Path) -> AsyncIterator[httpx.AsyncClient]:
    app = create_app(container_for(tmp_path), manage_lifecycle=False)
    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
    ) as c:
        yield c


def body(**over: object) -> bytes:
    event = TaskEvent(
        task_id="nav-1",
        server="navigation",
        tool="navigate_to",
        type="progress",
        seq=0,
        ts=time.time(),
        payload={"eta_s": 3},
    ).model_dump(mode="json")
    return json.dumps({**event, **over}).encode()


async def post(c: httpx.AsyncClient, raw: bytes, headers: dict[str, str]) -> httpx.Response:
    return await c.post("/api/agent/events", content=raw, headers=headers)


async def test_validly_signed_event_is_accepted_and_unknown_task_is_an_orphan(
    client: httpx.AsyncClient,
) -> None:
    raw = body()
    r = await post(client, raw, signed_headers("navigation", SECRET, raw))
    assert r.status_code == 200
    assert r.json() == {"status": "orphan"}
    again = await post(client, raw, signed_headers("navigation", SECRET, raw))
    assert again.json() == {"status": "duplicate"}


@pytest.mark.parametrize("depth", [40, 1000, 5000, 30_000])
async def test_deeply_nested_json_in_a_signed_event_is_a_400_not_a_500(
    client: httpx.AsyncClient, depth: int
) -> None:
    nested = "[" * depth + "]" * depth
    raw = body()[:-1] + b', "payload": {"deep": ' + nested.encode() + b"}}"
    r = await post(client, raw, signed_headers("navigation", SECRET, raw))
    assert r.status_code == 400
    assert r.json() == {"status": "rejected", "reason": "json_too_deep"}


async def test_an_event_nested_within_the_limit_is_accepted(client: httpx.AsyncClient) -> None:
    raw = body()[:-1] + b', "payload": {"deep": ' + b"[" * 20 + b"]" * 20 + b"}}"
    r = await post(client, raw, signed_headers("navigation", SECRET, raw))
    assert r.json() == {"status": "orphan"}


@pytest.mark.parametrize(
    ("server", "secret", "skew", "reason"),
    [
        ("navigation", "wrong", 0, "bad_signature"),
        ("navigation", SECRET, 1000, "clock_skew"),
        ("elsewhere", SECRET, 0, "unknown_server"),
        ("memory", SECRET, 0, "no_event_secret"),
    ],
)
async def test_every_401_answers_alike_and_only_the_log_says_why(
    client: httpx.AsyncClient, server: str, secret: str, skew: int, reason: str
) -> None:
    raw = body(server=server)
    headers = signed_headers(server, secret, raw, now=time.time() - skew)
    with structlog.testing.capture_logs() as logs:
        r = await post(client, raw, headers)
    assert r.status_code == 401
    assert r.json() == {"status": "rejected", "reason": "unauthorized"}  # no name oracle
    rejected = [e for e in logs if e["event"] == "agent_event_rejected"]
    assert [(e["reason"], e["server"]) for e in rejected] == [(reason, server)]


async def test_missing_or_duplicated_headers_get_401(client: httpx.AsyncClient) -> None:
    raw = body()
    headers = signed_headers("navigation", SECRET, raw)
    del headers["X-RVC-Signature"]
    assert (await post(client, raw, headers)).status_code == 401
    dup = [*signed_headers("navigation", SECRET, raw).items(), ("X-RVC-Server", "navigation")]
    r = await client.post("/api/agent/events", content=raw, headers=dup)
    assert r.status_code == 401


async def test_newer_schema_version_is_400_and_oversized_body_is_413(
    client: httpx.AsyncClient,
) -> None:
    raw = body(schema_version=2)
    r = await post(client, raw, signed_headers("navigation", SECRET, raw))
    assert r.status_code == 400
    assert "schema_version" in r.json()["reason"]
    big = b"x" * 70000
    r = await post(client, big, signed_headers("navigation", SECRET, big))
    assert r.status_code == 413


async def test_event_for_a_live_task_reaches_the_executor(tmp_path: Path) -> None:
    planner = FakeLLM(
        [
            reply("", ("set_plan", {"steps": [{"id": "s1", "title": "Drive"}]})),
            reply("", ("navigation.navigate_to", {"step_id": "s1", "location": "kitchen"})),
            reply("", ("wait_for_events", {"reason": "x"})),
            reply("", ("finish_mission", {"outcome": "succeeded", "summary": "ok"})),
        ]
    )
    container = container_for(tmp_path, planner)
    app = create_app(container, manage_lifecycle=False)
    mission = await container.executor.start("go to the lab")

    await async_wait_until(lambda: container.executor.registry.get("nav-1") is not None, 5, "task")
    raw = body(type="task_done", seq=1, payload={"result": "arrived"})
    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
    ) as c:
        r = await post(c, raw, signed_headers("navigation", SECRET, raw))
        assert r.json() == {"status": "accepted"}
        await container.executor.wait_idle(5)
        assert mission.state == "succeeded"
        snap = (await c.get(f"/api/agent/missions/{mission.id}")).json()
        assert snap["steps"][0]["status"] == "succeeded"
        listing = (await c.get("/api/agent/missions")).json()
        assert listing["missions"][0]["id"] == mission.id
        assert (await c.get("/api/agent/missions/m-nope")).status_code == 404


async def test_rate_limit_per_server_answers_429(tmp_path: Path) -> None:
    app = create_app(container_for(tmp_path, event_rate_limit="2/minute"), manage_lifecycle=False)
    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
    ) as c:
        codes = []
        for seq in range(3):
            raw = body(seq=seq, event_id=f"e{seq}")
            codes.append(
                (await post(c, raw, signed_headers("navigation", SECRET, raw))).status_code
            )
    assert codes == [200, 200, 429]


async def test_teaching_toggle_round_trips(client: httpx.AsyncClient) -> None:
    assert (await client.get("/api/agent/teaching")).json() == {"enabled": False}
    assert (await client.post("/api/agent/teaching", json={"enabled": True})).json() == {
        "enabled": True
    }
    assert (await client.post("/api/agent/teaching", json={"enabled": "x"})).status_code == 422


header_values = st.one_of(
    st.none(), st.text(max_size=40), st.sampled_from(["navigation", "memory"])
)


@settings(
    max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    raw=st.one_of(
        st.binary(max_size=300),
        st.builds(
            lambda d: json.dumps(d).encode(),
            st.dictionaries(
                st.text(max_size=12),
                st.one_of(
                    st.none(), st.integers(), st.text(max_size=8), st.floats(allow_nan=False)
                ),
                max_size=9,
            ),
        ),
        st.builds(
            lambda v, t: body(schema_version=v, type=t),
            st.one_of(st.integers(), st.text(max_size=4), st.none()),
            st.text(max_size=12),
        ),
    ),
    server=header_values,
    ts=st.one_of(st.none(), st.text(max_size=20), st.integers(-(10**12), 10**12).map(str)),
    sign_it=st.booleans(),
)
def test_ingress_never_answers_500_for_any_input(
    tmp_path: Path, raw: bytes, server: str | None, ts: str | None, sign_it: bool
) -> None:
    import asyncio

    async def run() -> int:
        app = create_app(container_for(tmp_path), manage_lifecycle=False)
        headers: dict[str, str] = {}
        if server is not None:
            headers["X-RVC-Server"] = server
        stamp = ts if ts is not None else str(int(time.time()))
        if ts is not None or sign_it:
            headers["X-RVC-Timestamp"] = stamp
        if sign_it:
            try:
                headers["X-RVC-Signature"] = sign(SECRET, stamp, raw)
            except ValueError:
                headers["X-RVC-Signature"] = "sha256=" + "0" * 64
        try:
            headers = {
                k: v.encode("utf-8", "replace").decode("latin-1", "replace")
                for k, v in headers.items()
            }
            async with httpx.AsyncClient(
                transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
            ) as c:
                r = await c.post("/api/agent/events", content=raw, headers=headers)
        except (httpx.LocalProtocolError, UnicodeEncodeError):
            return 400  # the client refused to send an illegal header; nothing reached us
        return r.status_code

    status = asyncio.run(run())
    assert status in (200, 400, 401, 413, 429)


async def test_chat_routes_answer_text_and_transcribed_audio(tmp_path: Path) -> None:
    container = container_for(tmp_path)
    container.pipeline._llm = FakeLLM([reply("Hi."), reply("The lab.")])
    app = create_app(container, manage_lifecycle=False)
    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
    ) as c:
        text = (await c.post("/api/chat", json={"text": "hi"})).json()
        assert text["reply"] == "Hi."
        assert text["route"] == "fast"
        tone = (np.sin(np.arange(8000) / 4) * 8000).astype(np.int16)  # a decodable WAV
        audio = await c.post(
            "/api/chat/audio", content=wav_bytes(tone), headers={"content-type": "audio/wav"}
        )
        assert audio.json()["transcript"] == "hello"
        assert audio.json()["reply"] == "The lab."
        wrong = await c.post(
            "/api/chat/audio", content=b"x", headers={"content-type": "text/plain"}
        )
        assert wrong.status_code == 415
        assert (await c.post("/api/chat", json={"text": ""})).status_code == 422
        assert (await c.post("/api/chat/stop")).json() == {"status": "stopped"}


async def test_unsigned_floods_are_limited_per_address_and_spend_no_servers_budget(
    tmp_path: Path,
) -> None:
    container = container_for(tmp_path, event_rate_limit="2/minute", unsigned_rate_limit="3/minute")
    app = create_app(container, manage_lifecycle=False)
    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
    ) as c:
        forged = []
        for seq in range(5):
            raw = body(seq=seq, event_id=f"forged{seq}")
            forged.append(
                (await post(c, raw, signed_headers("navigation", "guess", raw))).status_code
            )
        raw = body(event_id="real")
        real = await post(c, raw, signed_headers("navigation", SECRET, raw))
    assert forged == [401, 401, 401, 429, 429]
    assert real.status_code == 200  # the forged flood named navigation but did not use its quota


async def test_two_concurrent_copies_of_one_event_are_handled_once(tmp_path: Path) -> None:
    container = container_for(tmp_path)
    calls: list[str] = []
    both_arrived = asyncio.Event()

    async def slow_handler(event: TaskEvent) -> bool:
        calls.append(event.event_id)
        await asyncio.wait_for(both_arrived.wait(), 5)
        return True

    container.executor.on_task_event = slow_handler  # type: ignore[method-assign]
    app = create_app(container, manage_lifecycle=False)
    raw = body()
    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
    ) as c:
        first = asyncio.create_task(post(c, raw, signed_headers("navigation", SECRET, raw)))
        second = asyncio.create_task(post(c, raw, signed_headers("navigation", SECRET, raw)))
        await asyncio.wait({first, second}, return_when=asyncio.FIRST_COMPLETED)
        both_arrived.set()
        answers = sorted([(await first).json()["status"], (await second).json()["status"]])
    assert answers == ["accepted", "duplicate"]
    assert len(calls) == 1


async def test_a_failed_handling_releases_the_event_id_for_the_retry(tmp_path: Path) -> None:
    container = container_for(tmp_path)
    outcomes = iter([RuntimeError("boom"), True])

    async def flaky(event: TaskEvent) -> bool:
        outcome = next(outcomes)
        if isinstance(outcome, Exception):
            raise outcome
        return outcome

    container.executor.on_task_event = flaky  # type: ignore[method-assign]
    app = create_app(container, manage_lifecycle=False)
    raw = body()
    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
    ) as c:
        assert (await post(c, raw, signed_headers("navigation", SECRET, raw))).status_code == 503
        retry = await post(c, raw, signed_headers("navigation", SECRET, raw))
    assert retry.json() == {"status": "accepted"}


async def test_an_event_for_another_servers_task_is_refused(tmp_path: Path) -> None:
    planner = FakeLLM(
        [
            reply("", ("navigation.navigate_to", {"location": "kitchen"})),
            reply("", ("wait_for_events", {"reason": "x"})),
        ]
    )
    container = container_for(tmp_path, planner)
    app = create_app(container, manage_lifecycle=False)
    await container.executor.start("go to the lab")
    await async_wait_until(lambda: container.executor.registry.get("nav-1") is not None, 5, "task")
    raw = body(
        server="perception", type="task_failed", payload={"error_code": "X", "message": "forged"}
    )
    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
    ) as c:
        r = await post(c, raw, signed_headers("perception", PERCEPTION_SECRET, raw))
    assert r.status_code == 400
    assert r.json()["reason"] == "task_of_another_server"
    assert container.executor.registry.get("nav-1") is not None  # still live, untouched
    await container.executor.shutdown()


def test_event_secrets_shorter_than_32_bytes_are_refused_at_startup(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    with pytest.raises(ValidationError, match="at least 32 are required"):
        McpServerConfig(name="navigation", url="http://x", event_secret=SecretStr("short"))
    secretless = McpServerConfig(name="memory", url="http://x", event_secret=SecretStr(""))
    assert not secretless.can_post_events  # empty = cannot post, not an error
    monkeypatch.setenv("NAV_EVENT_SECRET", "nav-secret")
    assert main(["--port", "1"]) == 2


def test_readyz_lists_only_posting_servers_that_lack_a_secret() -> None:
    tools = McpToolsConfig(
        servers=[
            McpServerConfig(name="navigation", url="http://x", event_secret=SecretStr("")),
            McpServerConfig(name="perception", url="http://x", event_secret=SecretStr("p" * 32)),
            McpServerConfig(name="memory", url="http://x"),  # never posts events
        ]
    )
    assert tools.servers_without_event_secret() == ["navigation"]


async def one_life(tmp_path: Path, raw: bytes, **api: object) -> str:
    """POST ``raw`` to a freshly assembled brain (one process life) on the same data dir."""
    app = create_app(container_for(tmp_path, **api), manage_lifecycle=False)
    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
    ) as c:
        answer = await post(c, raw, signed_headers("navigation", SECRET, raw))
    status: str = answer.json()["status"]
    return status


async def test_an_event_seen_before_a_restart_is_still_a_duplicate_after_it(
    tmp_path: Path,
) -> None:
    """Issue 31: dedupe lived in memory only (``duplicate`` before a restart, accepted after)."""
    raw = body()
    assert await one_life(tmp_path, raw) == "orphan"
    assert await one_life(tmp_path, raw) == "duplicate"  # the next process life


async def test_the_seen_events_kept_on_disk_are_bounded_newest_first(tmp_path: Path) -> None:
    raws = [body(event_id=f"ev-{i}") for i in range(6)]
    for raw in raws:
        assert await one_life(tmp_path, raw, dedupe_size=4) == "orphan"
    assert await one_life(tmp_path, raws[-1], dedupe_size=4) == "duplicate"
    assert await one_life(tmp_path, raws[0], dedupe_size=4) == "orphan"  # forgotten: oldest
    stored = tmp_path / "rvc-data" / "seen_events.sqlite3"
    assert stat.S_IMODE(stored.stat().st_mode) == 0o600
