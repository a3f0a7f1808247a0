"""GET /api/history: the History panel's sightings from the episodic memory server.

The unit tests run the route against a fake episodic server at the tool port (FakeToolBackend
handlers below) that rejects what the real server rejects — a contract test runs the same bad
arguments against the real ``robot_mcp_episodic`` server in memory — and one test reads the
real server's answers through the route."""

from __future__ import annotations

import json
import re
from collections.abc import AsyncIterator, Iterator
from contextlib import asynccontextmanager
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import httpx
import pytest
from mcp import Client

from robot_mcp_episodic.composition import EpisodicApp, build_app
from robot_mcp_episodic.config import EpisodicConfig
from robot_mcp_episodic.episode import ManualClock
from robot_mcp_kit.mcp_runtime import parse_tool_error
from robot_voice_chat.api.app import create_app
from robot_voice_chat.api.container import Adapters, Container
from robot_voice_chat.composition import assemble
from robot_voice_chat.services.emitter.base import FakeEventEmitter
from robot_voice_chat.services.llm.base import ToolDefinition
from robot_voice_chat.services.llm.fake import FakeLLM
from robot_voice_chat.services.speech.fake import FakeSpeechOutput
from robot_voice_chat.services.speech.none import NoSpeechInput
from robot_voice_chat.services.tools.base import (
    ConnectionState,
    ServerListener,
    ToolBackend,
    ToolOutcome,
)
from robot_voice_chat.services.tools.fake import FakeToolBackend
from robot_voice_chat.settings import AppConfig, McpServerConfig

NOW = datetime.now(UTC).timestamp()

# -- a fake episodic server (the real one: packages/robot_mcp_episodic) ------------------------
_UNITS = {"s": 1.0, "m": 60.0, "h": 3600.0, "d": 86400.0}
_RELATIVE = re.compile(
    r"^-\s*(\d+(?:\.\d+)?)\s*(s|secs?|seconds?|m|mins?|minutes?|h|hrs?|hours?|d|days?)$"
)
_CLOCK = re.compile(r"^(\d{1,2}):(\d{2})$")
_STOP_WORDS = {"a", "an", "the", "it", "this", "that", "of", "in", "on", "at", "to", "my"}
KINDS = ("sightings", "scene", "missions", "conversation", "places", "notes")


def _error(code: str, detail: str) -> ValueError:
    return ValueError(json.dumps({"error": code, "detail": detail}))


def _time(name: str, text: Any, now: float) -> float:
    stamp = _read_time(name, text, now)
    if not -62135596800.0 <= stamp <= 253402300799.0:  # years 1 to 9999, as the real server
        raise _error("invalid_time", f"{name}: the time {text!r} is out of range")
    return stamp


def _read_time(name: str, text: Any, now: float) -> float:
    value = str(text).strip().lower()
    if value in ("", "now"):
        return now
    if match := _RELATIVE.match(value):
        return now - float(match.group(1)) * _UNITS[match.group(2)[0]]
    if (match := _CLOCK.match(value)) and int(match.group(1)) < 24 and int(match.group(2)) < 60:
        day = datetime.fromtimestamp(now, UTC)
        at = day.replace(hour=int(match.group(1)), minute=int(match.group(2)), second=0)
        return at.timestamp() - (86400.0 if at.timestamp() > now else 0.0)
    try:
        parsed = datetime.fromisoformat(str(text).strip().replace("Z", "+00:00"))
    except ValueError:
        raise _error("invalid_time", f"{name}: cannot read the time {text!r}") from None
    return (parsed if parsed.tzinfo else parsed.replace(tzinfo=UTC)).timestamp()


def _iso(stamp: float) -> str:
    return datetime.fromtimestamp(stamp, UTC).isoformat(timespec="milliseconds")[:-6] + "Z"


def _when(stamp: float) -> dict[str, Any]:
    return {"time": _iso(stamp), "ago": f"{round(NOW - stamp)} s ago", "t": round(stamp, 3)}


def sighting(
    n: int, label: str, ago_s: float, place: str | None, pose: tuple[float, float] | None
) -> dict[str, Any]:
    return {
        "id": f"s-{n}",
        "label": label,
        "skill": "find_object",
        "first": NOW - ago_s,
        "last": NOW - ago_s + 4,
        "place": place,
        "pose": {"x": pose[0], "y": pose[1], "yaw": 0.5, "map": "office"} if pose else None,
        "score": 0.9,
        "count": 7,
        "skills": ["find_object"],
    }


class FakeEpisodic:
    """``episodic.what_happened`` and ``episodic.last_seen`` with the real answers' shapes."""

    def __init__(self, tools: FakeToolBackend, sightings: list[dict[str, Any]]) -> None:
        self.sightings = sightings
        tools.add("episodic.what_happened", self.what_happened)
        tools.add("episodic.last_seen", self.last_seen)

    def what_happened(self, args: dict[str, Any]) -> dict[str, Any]:
        begin = _time("start", args.get("start", "-10m"), NOW)
        finish = _time("end", args.get("end", "now"), NOW)
        if finish < begin:
            raise _error("invalid_range", f"end ({_iso(finish)}) is before start ({_iso(begin)})")
        unknown = [k for k in args.get("kinds") or () if k not in KINDS]
        if unknown:
            raise _error("invalid_argument", f"unknown kinds {unknown}")
        max_items = args.get("max_items", 50)
        if not 1 <= max_items <= 500:
            raise _error("tool_error", "max_items: Input should be between 1 and 500")
        found = sorted(
            (s for s in self.sightings if s["last"] >= begin and s["first"] <= finish),
            key=lambda s: s["first"],
        )
        items = [
            {
                **_when(s["first"]),
                "kind": "sighting",
                "id": s["id"],
                "label": s["label"],
                "skill": s["skill"],
                "place": s["place"],
                "until": _iso(s["last"]),
                "text": f"saw {s['label']}",
            }
            for s in found
        ]
        return {
            "start": _when(begin), "end": _when(finish), "place": None,
            "items": items[-max_items:], "count": min(len(items), max_items),
            "truncated": len(items) > max_items, "summary": f"{len(items)} events",
        }  # fmt: skip

    def last_seen(self, args: dict[str, Any]) -> dict[str, Any]:
        query = str(args.get("query", ""))
        words = [w for w in re.findall(r"\w+", query.lower()) if w not in _STOP_WORDS]
        if not words:
            raise _error("invalid_argument", "query must name what to look for")
        n = args.get("n", 3)
        if not 1 <= n <= 50:
            raise _error("tool_error", "n: Input should be between 1 and 50")
        found = sorted(
            (s for s in self.sightings if set(words) & set(s["label"].split())),
            key=lambda s: -s["last"],
        )[:n]
        results = [
            {
                "id": s["id"],
                "label": s["label"],
                "skill": s["skill"],
                "first_seen": _when(s["first"]),
                "last_seen": _when(s["last"]),
                "seen_for_s": s["last"] - s["first"],
                "seen_for": "4 s",
                "count": s["count"],
                "best_score": s["score"],
                "box": None,
                "place": s["place"],
                "robot_pose": s["pose"],
                "absent_since": None,
            }
            for s in found
        ]
        return {"query": query, "found": bool(results), "results": results, "answer": "…"}


SIGHTINGS = [
    sighting(1, "red mug", 900, "kitchen", (2.0, 3.0)),
    sighting(2, "yellow package", 120, "mailroom", (9.0, -3.0)),
    sighting(3, "red mug", 60, "kitchen", (2.5, 3.0)),
]


# -- the app under test ------------------------------------------------------------------------
def container_for(tmp_path: Path, tools: ToolBackend) -> Container:
    config = AppConfig.model_validate(
        {
            "llm": {"_target_": "fake"},
            "speech_output": {"_target_": "fake"},
            "speech_input": {"_target_": "fake"},
            "agent": {"trace_dir": str(tmp_path / "traces"), "memory_server": ""},
            "ui": {"static_dir": str(tmp_path / "no-build")},
        }
    )
    adapters = Adapters(
        llm=FakeLLM([]),
        planner=FakeLLM([]),
        tools=tools,
        speech_output=FakeSpeechOutput(),
        speech_input=NoSpeechInput(),
    )
    return assemble(config, adapters, FakeEventEmitter(), None)


@pytest.fixture
def tools() -> FakeToolBackend:
    return FakeToolBackend()


@pytest.fixture
async def client(tmp_path: Path, tools: FakeToolBackend) -> AsyncIterator[httpx.AsyncClient]:
    app = create_app(container_for(tmp_path, tools))
    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
    ) as http:
        yield http


async def test_history_lists_sightings_newest_first_with_time_place_and_pose(
    client: httpx.AsyncClient, tools: FakeToolBackend
) -> None:
    FakeEpisodic(tools, SIGHTINGS)
    response = await client.get("/api/history")
    assert response.status_code == 200
    body = response.json()
    assert [row["id"] for row in body["sightings"]] == ["s-3", "s-2", "s-1"]
    assert body["count"] == 3
    assert body["truncated"] is False
    newest = body["sightings"][0]
    assert newest == {
        "id": "s-3",
        "label": "red mug",
        "skill": "find_object",
        "first_seen": _iso(NOW - 60),
        "last_seen": _iso(NOW - 56),
        "ago": "60 s ago",
        "t": round(NOW - 60, 3),
        "seen_for": "4 s",
        "place": "kitchen",
        "pose": {"x": 2.5, "y": 3.0, "yaw": 0.5, "map": "office"},
        "score": 0.9,
        "count": 7,
        "skills": ["find_object"],
    }
    assert body["sightings"][1]["pose"] == {"x": 9.0, "y": -3.0, "yaw": 0.5, "map": "office"}
    # one what_happened for the window, one last_seen per label (not per row)
    assert tools.called("episodic.what_happened") == [
        {"start": "-1h", "end": "now", "kinds": ["sightings"], "max_items": 50}
    ]
    assert sorted(a["query"] for a in tools.called("episodic.last_seen")) == [
        "red mug",
        "yellow package",
    ]


async def test_since_and_limit_choose_the_window_and_the_newest_rows(
    client: httpx.AsyncClient, tools: FakeToolBackend
) -> None:
    FakeEpisodic(tools, SIGHTINGS)
    body = (await client.get("/api/history", params={"since": "-5m", "limit": 1})).json()
    assert [row["id"] for row in body["sightings"]] == ["s-3"]
    assert body["truncated"] is True
    assert tools.called("episodic.what_happened")[0]["start"] == "-5m"

    since = _iso(NOW - 1000)
    body = (await client.get("/api/history", params={"since": since})).json()
    assert [row["id"] for row in body["sightings"]] == ["s-3", "s-2", "s-1"]
    assert tools.called("episodic.what_happened")[-1]["start"] == since


async def test_today_is_passed_as_midnight_for_the_memory_server_to_resolve(
    client: httpx.AsyncClient, tools: FakeToolBackend
) -> None:
    FakeEpisodic(tools, SIGHTINGS)
    response = await client.get("/api/history", params={"since": "00:00"})
    assert response.status_code == 200, response.text
    # the brain passes the clock time on as said: the server knows the site's zone
    assert tools.called("episodic.what_happened")[0]["start"] == "00:00"


async def test_nothing_recorded_is_an_empty_list(
    client: httpx.AsyncClient, tools: FakeToolBackend
) -> None:
    FakeEpisodic(tools, [])
    body = (await client.get("/api/history")).json()
    assert (body["sightings"], body["count"]) == ([], 0)
    assert tools.called("episodic.last_seen") == []


@pytest.mark.parametrize(
    ("since", "words"),
    [
        ("yesterday-ish", "is not a time"),
        ("-1x", "is not a time"),
        ("1h", "is not a time"),
        ("24:00", "is not a time"),
        ("7:5", "is not a time"),
        ("12:60", "is not a time"),
        (" ", "since must be"),
        ("-" + "1" * 60 + "s", "since must be"),
        ("2099-01-01T00:00:00Z", "in the future"),
    ],
)
async def test_a_bad_since_is_a_422_that_says_which_forms_work(
    client: httpx.AsyncClient, tools: FakeToolBackend, since: str, words: str
) -> None:
    FakeEpisodic(tools, SIGHTINGS)
    response = await client.get("/api/history", params={"since": since})
    assert response.status_code == 422
    body = response.json()
    assert body["error"] == "invalid_query"
    assert words in body["detail"]
    assert tools.calls == []  # refused before the memory server is asked


@pytest.mark.parametrize(
    "since",
    ["1969-12-31T23:59:59Z", "1900-01-01T00:00:00+02:00", "0001-01-01T00:00:00", "-99999d"],
)
async def test_a_since_before_1970_is_a_422_as_the_readme_says(
    client: httpx.AsyncClient, tools: FakeToolBackend, since: str
) -> None:
    """README: "/api/history?since= further back than 1970 is a 422 (invalid_query)" — for
    every form, not only the relative one (issue 35: an ISO time before 1970 was sent on)."""
    FakeEpisodic(tools, SIGHTINGS)
    response = await client.get("/api/history", params={"since": since})
    assert response.status_code == 422
    assert response.json()["error"] == "invalid_query"
    assert "before 1970" in response.json()["detail"]
    assert tools.calls == []  # refused before the memory server is asked


async def test_the_first_second_of_1970_is_a_time_the_server_is_asked_for(
    client: httpx.AsyncClient, tools: FakeToolBackend
) -> None:
    FakeEpisodic(tools, SIGHTINGS)
    response = await client.get("/api/history", params={"since": "1970-01-01T00:00:00Z"})
    assert response.status_code == 200, response.text
    assert tools.calls[0][1]["start"] == "1970-01-01T00:00:00Z"


@pytest.mark.parametrize("limit", [0, -3, 101])
async def test_a_limit_outside_its_bounds_is_a_422(
    client: httpx.AsyncClient, tools: FakeToolBackend, limit: int
) -> None:
    FakeEpisodic(tools, SIGHTINGS)
    response = await client.get("/api/history", params={"limit": limit})
    assert response.status_code == 422
    assert response.json() == {
        "error": "invalid_query",
        "detail": "limit must be between 1 and 100",
    }
    assert tools.calls == []


async def test_a_time_the_memory_server_rejects_is_a_422_with_its_reason(
    client: httpx.AsyncClient, tools: FakeToolBackend
) -> None:
    tools.add(
        "episodic.what_happened",
        lambda _args: ToolOutcome(
            text=json.dumps({"error": "invalid_range", "detail": "end is before start"}),
            is_error=True,
        ),
    )
    response = await client.get("/api/history", params={"since": "-1d"})
    assert response.status_code == 422
    assert response.json() == {"error": "invalid_query", "detail": "end is before start"}


async def test_without_the_episodic_server_the_history_is_a_503(
    client: httpx.AsyncClient, tools: FakeToolBackend
) -> None:
    response = await client.get("/api/history")
    assert response.status_code == 503
    assert response.json() == {
        "error": "episodic_unavailable",
        "detail": "The episodic memory server is not connected, so the robot's history "
        "cannot be shown.",
    }


async def test_a_disconnected_episodic_server_is_a_503_and_is_not_called(
    client: httpx.AsyncClient, tools: FakeToolBackend
) -> None:
    FakeEpisodic(tools, SIGHTINGS)
    await tools.disconnected("episodic")
    response = await client.get("/api/history")
    assert response.status_code == 503
    assert response.json()["error"] == "episodic_unavailable"
    assert tools.calls == []


async def test_a_server_lost_during_the_call_is_a_503(
    client: httpx.AsyncClient, tools: FakeToolBackend
) -> None:
    async def lost(_args: dict[str, Any]) -> ToolOutcome:
        await tools.disconnected("episodic")
        return ToolOutcome(text="error: server 'episodic' is not connected", is_error=True)

    tools.add("episodic.what_happened", lost)
    assert (await client.get("/api/history")).status_code == 503


@pytest.mark.parametrize(
    ("outcome", "detail"),
    [
        (
            ToolOutcome(
                text=json.dumps({"error": "store_unavailable", "detail": "database is locked"}),
                is_error=True,
            ),
            "what_happened: database is locked",
        ),
        (
            ToolOutcome(text="error: episodic.what_happened timed out after 3 s", is_error=True),
            "what_happened: error: episodic.what_happened timed out after 3 s",
        ),
        (ToolOutcome(text="not json"), "what_happened answered no JSON"),
        (ToolOutcome(text="[1, 2]"), "what_happened answered list"),
    ],
)
async def test_an_episodic_failure_is_a_502_with_its_message(
    client: httpx.AsyncClient, tools: FakeToolBackend, outcome: ToolOutcome, detail: str
) -> None:
    tools.add("episodic.what_happened", lambda _args: outcome)
    response = await client.get("/api/history")
    assert response.status_code == 502
    assert response.json() == {"error": "episodic_error", "detail": detail}


async def test_a_last_seen_failure_is_a_502_too(
    client: httpx.AsyncClient, tools: FakeToolBackend
) -> None:
    FakeEpisodic(tools, SIGHTINGS)
    tools.add(
        "episodic.last_seen",
        lambda _args: ToolOutcome(
            text=json.dumps({"error": "internal_error", "detail": "last_seen failed"}),
            is_error=True,
        ),
    )
    response = await client.get("/api/history")
    assert response.status_code == 502
    assert response.json()["detail"] == "last_seen: last_seen failed"


async def test_a_label_the_server_cannot_search_keeps_its_row_without_a_pose(
    client: httpx.AsyncClient, tools: FakeToolBackend
) -> None:
    FakeEpisodic(tools, [*SIGHTINGS, sighting(4, "it", 30, None, (1.0, 1.0))])
    body = (await client.get("/api/history")).json()
    assert body["sightings"][0]["label"] == "it"
    assert body["sightings"][0]["pose"] is None
    assert body["sightings"][0]["last_seen"] == _iso(NOW - 26)  # what_happened's "until"
    assert body["sightings"][1]["pose"] is not None


# -- the fake fails like the real server ---------------------------------------------------------
@pytest.fixture
def real_episodic(tmp_path: Path) -> Iterator[EpisodicApp]:
    built = build_app(
        EpisodicConfig(data_dir=tmp_path / "episodic", record_raw=False),
        record_ros=False,
        clock=ManualClock(NOW),
    )
    try:
        yield built
    finally:
        built.close()


CONTRACT_CASES = [
    ("what_happened", {"start": "yesterday-ish"}),
    ("what_happened", {"start": "-1x"}),
    ("what_happened", {"start": "2099-01-01T00:00:00Z"}),
    ("what_happened", {"start": "-1m", "end": "-10m"}),
    ("what_happened", {"start": "-1h", "kinds": ["dreams"]}),
    ("what_happened", {"start": "-1h", "max_items": 0}),
    ("what_happened", {"start": "-1h", "max_items": 501}),
    ("what_happened", {"start": "-99999999999d"}),  # before year 1: invalid_time (issue 31)
    ("what_happened", {"start": "-1h", "end": "-99999999999999999999s"}),
    ("last_seen", {"query": "the"}),
    ("last_seen", {"query": "   "}),
    ("last_seen", {"query": "mug", "n": 0}),
    ("last_seen", {"query": "mug", "n": 51}),
    # and what both accept
    ("what_happened", {"start": "-1h", "end": "now", "kinds": ["sightings"], "max_items": 50}),
    ("what_happened", {"start": "-30s"}),
    ("what_happened", {"start": "-2 hours"}),
    ("what_happened", {"start": "2026-01-01T00:00:00Z"}),
    ("what_happened", {"start": "2026-01-01T00:00:00"}),
    ("what_happened", {"start": "00:00"}),
    ("last_seen", {"query": "red mug", "n": 50}),
]


@pytest.mark.parametrize(("tool", "args"), CONTRACT_CASES)
async def test_the_fake_rejects_what_the_real_episodic_server_rejects(
    real_episodic: EpisodicApp, tool: str, args: dict[str, Any]
) -> None:
    async with Client(real_episodic.server) as real:
        answer = await real.call_tool(tool, args)
    real_text = answer.content[0].text  # type: ignore[union-attr]
    fake_tools = FakeToolBackend()
    FakeEpisodic(fake_tools, SIGHTINGS)
    fake = await fake_tools.call_tool(f"episodic.{tool}", args)
    assert fake.is_error == answer.is_error, (real_text, fake.text)
    if answer.is_error:
        real_error, fake_error = parse_tool_error(real_text), parse_tool_error(fake.text)
        assert real_error is not None
        assert fake_error is not None
        assert fake_error["error"] == real_error["error"], (real_text, fake.text)


# -- the route on the real server's answers ----------------------------------------------------
class InMemoryEpisodic(ToolBackend):
    """The tool port in front of the real episodic MCP server (in memory, no sockets)."""

    def __init__(self, client: Client) -> None:
        self.client = client

    def list_tools(self) -> list[ToolDefinition]:
        return []

    async def call_tool(
        self, name: str, arguments: dict[str, object], timeout_s: float | None = None
    ) -> ToolOutcome:
        result = await self.client.call_tool(name.removeprefix("episodic."), dict(arguments))
        return ToolOutcome(text=result.content[0].text, is_error=result.is_error)  # type: ignore[union-attr]

    def servers(self) -> dict[str, McpServerConfig]:
        return {"episodic": McpServerConfig(name="episodic", url="http://127.0.0.1:1/sse")}

    def server_states(self) -> dict[str, ConnectionState]:
        return {"episodic": "connected"}

    def add_connect_listener(self, listener: ServerListener) -> None:
        pass

    def add_disconnect_listener(self, listener: ServerListener) -> None:
        pass


@asynccontextmanager
async def history_api(tmp_path: Path, episodic: EpisodicApp) -> AsyncIterator[httpx.AsyncClient]:
    """The brain's HTTP API over a real episodic server (in-memory MCP)."""
    async with Client(episodic.server) as mcp_client:
        app = create_app(container_for(tmp_path, InMemoryEpisodic(mcp_client)))
        async with httpx.AsyncClient(
            transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
        ) as http:
            yield http


async def test_the_route_reads_what_the_real_episodic_server_recorded(
    tmp_path: Path, real_episodic: EpisodicApp
) -> None:
    indexer = real_episodic.memory.indexer
    indexer.on_pose(NOW - 300, 9.0, -3.0, 1.0)  # in the mailroom of the default map
    indexer.on_detections("find_object", NOW - 290, [{"label": "yellow package", "score": 0.8}])
    indexer.on_detections("find_object", NOW - 288, [{"label": "yellow package", "score": 0.9}])
    async with history_api(tmp_path, real_episodic) as http:
        response = await http.get("/api/history", params={"since": "-10m"})
        bad = await http.get("/api/history", params={"since": "-10 fortnights"})
    assert response.status_code == 200, response.text
    [row] = response.json()["sightings"]
    assert row["label"] == "yellow package"
    assert row["skill"] == "find_object"
    assert row["first_seen"] == _iso(NOW - 290)
    assert row["last_seen"] == _iso(NOW - 288)
    assert row["ago"] == "4 min ago"
    assert (row["pose"]["x"], row["pose"]["y"]) == (9.0, -3.0)
    assert row["score"] == 0.9
    assert row["count"] == 2
    assert bad.status_code == 422


async def test_one_thing_seen_by_a_detector_and_the_scene_describer_is_one_row(
    tmp_path: Path, real_episodic: EpisodicApp
) -> None:
    indexer = real_episodic.memory.indexer
    indexer.on_pose(NOW - 300, 9.0, -3.0, 1.0)  # in the mailroom of the default map
    indexer.on_output("scene", "scene_objects", NOW - 291, ["yellow package", "cardboard box"])
    indexer.on_detections("find_object", NOW - 290, [{"label": "yellow package", "score": 0.9}])
    indexer.on_output("scene", "scene_objects", NOW - 289, ["yellow package", "cardboard box"])
    indexer.on_output("scene", "scene_objects", NOW - 200, ["cardboard box"])  # it was taken
    indexer.on_output("scene", "scene_objects", NOW - 100, ["yellow package", "cardboard box"])
    async with history_api(tmp_path, real_episodic) as http:
        response = await http.get("/api/history", params={"since": "-10m"})
    assert response.status_code == 200, response.text
    rows = response.json()["sightings"]
    packages = [r for r in rows if r["label"] == "yellow package"]
    assert [(r["first_seen"], r["skills"]) for r in packages] == [
        (_iso(NOW - 100), ["scene"]),  # back later: a sighting of its own
        (_iso(NOW - 290), ["find_object", "scene"]),  # the detector's row, with its score
    ]
    assert packages[1]["score"] == 0.9
    boxes = [(r["first_seen"], r["last_seen"]) for r in rows if r["label"] == "cardboard box"]
    assert boxes == [  # only the describer saw it: three lists far apart, three sightings
        (_iso(NOW - 100), _iso(NOW - 100)),
        (_iso(NOW - 200), _iso(NOW - 200)),
        (_iso(NOW - 291), _iso(NOW - 289)),
    ]


async def test_since_midnight_lists_only_what_the_real_server_saw_today(tmp_path: Path) -> None:
    noon = datetime(2026, 11, 24, 15, 0, tzinfo=UTC).timestamp()  # 15:00 in the site's zone
    built = build_app(
        EpisodicConfig(data_dir=tmp_path / "episodic", record_raw=False, timezone="UTC"),
        record_ros=False,
        clock=ManualClock(noon),
    )
    try:
        indexer = built.memory.indexer
        indexer.on_pose(noon - 16 * 3600, 2.0, 3.0, 0.0)  # yesterday 23:00
        indexer.on_detections("find_object", noon - 16 * 3600, [{"label": "red mug", "score": 0.8}])
        indexer.on_pose(noon - 3 * 3600, 9.0, -3.0, 1.0)  # today 12:00
        indexer.on_detections(
            "find_object", noon - 3 * 3600, [{"label": "yellow package", "score": 0.9}]
        )
        async with history_api(tmp_path, built) as http:
            today = (await http.get("/api/history", params={"since": "00:00"})).json()
            day = (await http.get("/api/history", params={"since": "-24h"})).json()
    finally:
        built.close()
    assert today["since"] == "2026-11-24T00:00:00.000Z"
    assert [row["label"] for row in today["sightings"]] == ["yellow package"]
    assert [row["label"] for row in day["sightings"]] == ["yellow package", "red mug"]


@pytest.mark.parametrize("since", ["-99999999999d", "-1e400s", "-99999999999999999999999h"])
async def test_a_since_too_far_back_is_a_422_not_a_502(
    client: httpx.AsyncClient, tools: FakeToolBackend, since: str
) -> None:
    """Issue 31: ``since=-99999999999d`` → the episodic server raised ValueError → 502."""
    FakeEpisodic(tools, SIGHTINGS)
    response = await client.get("/api/history", params={"since": since})
    assert response.status_code == 422, response.text
    assert response.json()["error"] == "invalid_query"


async def test_the_real_server_answers_a_time_out_of_range_as_invalid_time(
    tmp_path: Path, real_episodic: EpisodicApp
) -> None:
    async with Client(real_episodic.server) as real:
        answer = await real.call_tool("what_happened", {"start": "-99999999999d"})
    assert answer.is_error
    error = parse_tool_error(answer.content[0].text)  # type: ignore[union-attr]
    assert error is not None
    assert error["error"] == "invalid_time"
