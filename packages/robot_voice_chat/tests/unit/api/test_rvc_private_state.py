"""The brain's state is private to its user: traces, the mission archive and the revocation
list are created 0600 in 0700 directories; every route has the app-wide rate limit."""

from __future__ import annotations

import stat
from pathlib import Path

import httpx
import pytest

from robot_voice_chat.agent.archive import SqliteMissionArchive
from robot_voice_chat.agent.trace import TraceRecorder
from robot_voice_chat.api.app import create_app
from robot_voice_chat.composition import bootstrap, compose_config


def mode(path: Path) -> int:
    return stat.S_IMODE(path.stat().st_mode)


async def test_traces_are_written_0600_in_a_0700_directory(tmp_path: Path) -> None:
    trace = TraceRecorder(tmp_path / "data" / "missions")
    trace.record("m-1", "instruction", text="fetch the package from the mailroom")
    await trace.flush()
    assert mode(tmp_path / "data") == 0o700
    assert mode(tmp_path / "data" / "missions") == 0o700
    assert mode(tmp_path / "data" / "missions" / "m-1.jsonl") == 0o600
    assert (await trace.read("m-1"))[0]["text"] == "fetch the package from the mailroom"


async def test_the_mission_archive_and_its_journal_are_0600(tmp_path: Path) -> None:
    archive = SqliteMissionArchive(tmp_path / "data" / "missions.sqlite3")
    assert await archive.events("m-1") == []
    assert mode(tmp_path / "data") == 0o700
    files = list((tmp_path / "data").glob("missions.sqlite3*"))
    assert files
    assert {p.name: mode(p) for p in files} == {p.name: 0o600 for p in files}


async def test_the_default_rate_limit_applies_to_every_route_but_the_signed_ingress(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("RVC_TRACE_DIR", str(tmp_path / "traces"))
    config = compose_config("dev", ["api.default_rate_limit=3/minute"])
    app = create_app(bootstrap(config), manage_lifecycle=False)
    transport = httpx.ASGITransport(app)
    async with httpx.AsyncClient(transport=transport, base_url="http://127.0.0.1") as http:
        statuses = [(await http.get("/api/agent/missions")).status_code for _ in range(4)]
        assert statuses == [200, 200, 200, 429]
        # the ingress answers with its own limits (here: 401 for an unsigned post, not 429)
        ingress = [(await http.post("/api/agent/events")).status_code for _ in range(4)]
        assert ingress == [401] * 4
