"""End to end: the real app on uvicorn, ReplayLLM (dev recordings), MCP servers as real OS
processes (sse + streamable-http) and events posted by a real robot_mcp_kit.EventPoster."""

from __future__ import annotations

import asyncio
import json
import secrets
import sys
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import httpx
import pytest
import uvicorn
import websockets

from robot_stack_testing import ProcessLauncher, async_wait_until, free_tcp_port
from robot_voice_chat.api.app import create_asgi_app
from robot_voice_chat.composition import bootstrap, compose_config

SERVERS = Path(__file__).with_name("rvc_fake_mcp_servers.py")
PLANNER_RECORDING = Path(__file__).with_name("rvc_replay_drive_to_mailroom.yaml")


class SocketClient:
    """Minimal Socket.IO v5 / Engine.IO v4 websocket client (events + acks)."""

    def __init__(self, ws: Any) -> None:
        self.ws = ws
        self.events: list[tuple[str, Any]] = []
        self._reader = asyncio.create_task(self._read())

    @classmethod
    async def connect(cls, port: int) -> SocketClient:
        ws = await websockets.connect(f"ws://127.0.0.1:{port}/socket.io/?EIO=4&transport=websocket")
        assert str(await ws.recv()).startswith("0")  # engine.io open
        await ws.send("40")
        early: list[str] = []
        while not (raw := str(await ws.recv())).startswith("40"):  # socket.io connected
            early.append(raw)
        client = cls(ws)
        for r in early:
            if r.startswith("42"):
                name, *data = json.loads(r[2:])
                client.events.append((name, data[0] if data else None))
        return client

    async def _read(self) -> None:
        async for raw in self.ws:
            if raw == "2":
                await self.ws.send("3")
            elif isinstance(raw, str) and raw.startswith("42"):
                name, *data = json.loads(raw[2:])
                self.events.append((name, data[0] if data else None))

    async def emit(self, name: str, data: Any) -> None:
        await self.ws.send("42" + json.dumps([name, data]))

    def of(self, name: str) -> list[Any]:
        return [d for n, d in self.events if n == name]

    async def close(self) -> None:
        self._reader.cancel()
        await self.ws.close()


@pytest.fixture
async def stack(
    launcher: ProcessLauncher, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> AsyncIterator[tuple[int, Any]]:
    app_port, nav_port, mem_port = free_tcp_port(), free_tcp_port(), free_tcp_port()
    secret = secrets.token_hex(32)
    monkeypatch.setenv("RVC_TRACE_DIR", str(tmp_path / "traces"))
    monkeypatch.setenv("NAV_EVENT_SECRET", secret)
    monkeypatch.setenv("RVC_NAVIGATION_URL", f"http://127.0.0.1:{nav_port}/sse")
    monkeypatch.setenv("RVC_MEMORY_URL", f"http://127.0.0.1:{mem_port}/mcp")
    monkeypatch.setenv("RVC_MEMORY_TRANSPORT", "streamable_http")
    monkeypatch.setenv("RVC_SKILL_CONTROL_URL", "http://127.0.0.1:9/sse")  # nothing there
    monkeypatch.setenv("RVC_PERCEPTION_URL", "http://127.0.0.1:9/sse")
    config = compose_config("test", [f"llm_planner.recording={PLANNER_RECORDING}"])
    container = bootstrap(config)
    server = uvicorn.Server(
        uvicorn.Config(
            create_asgi_app(container), host="127.0.0.1", port=app_port, log_level="warning"
        )
    )
    serving = asyncio.create_task(server.serve())
    await async_wait_until(lambda: server.started, 10, "app serving")
    # servers start after the app: the reconnect loop must adopt them
    launcher.start(
        "navigation",
        [
            sys.executable,
            str(SERVERS),
            "navigation",
            str(nav_port),
            f"http://127.0.0.1:{app_port}/api/agent/events",
            secret,
            str(tmp_path / "outbox"),
        ],
    )
    launcher.start("memory", [sys.executable, str(SERVERS), "memory", str(mem_port)])
    yield app_port, container
    server.should_exit = True
    await asyncio.wait_for(serving, 15)


async def test_mailroom_mission_runs_end_to_end_over_real_processes(
    stack: tuple[int, Any],
) -> None:
    port, container = stack
    async with httpx.AsyncClient(base_url=f"http://127.0.0.1:{port}") as http:

        async def all_connected() -> bool:
            states = (await http.get("/api/readyz")).json()["data"]["mcp_servers"]
            return bool(states["navigation"] == states["memory"] == "connected")

        await async_wait_until(all_connected, 90, "both MCP servers adopted", interval_s=0.2)
        sio = await SocketClient.connect(port)
        try:
            await sio.emit("send_message", {"text": "hello"})
            await async_wait_until(lambda: sio.of("chat_message")[1:], 10, "greeting")
            await sio.emit(
                "send_message", {"text": "drive to the mailroom and tell me when you arrive"}
            )
            await async_wait_until(lambda: sio.of("mission_finished"), 30, "mission finished")

            finished = sio.of("mission_finished")[0]
            assert finished["outcome"] == "succeeded", finished
            final_plan = sio.of("mission_plan")[-1]
            # skill_control is not running: the drive and the report succeeded, the prewarm
            # reaction's call failed and the planner was told so
            assert [s["status"] for s in final_plan["steps"]] == [
                "succeeded",
                "failed",
                "succeeded",
            ]
            assert final_plan["steps"][0]["task_id"].startswith("nav-")
            lines = [e["text"] for e in sio.of("mission_event")]
            assert any("trigger_fired: eta_below 10" in t for t in lines)
            assert any(t.startswith("[reaction] eta_below fired") for t in lines)
            assert any(
                t.startswith("[reaction] skill_control.instantiate_skill failed: error:")
                for t in lines
            )
            assert any("I have arrived" in s["text"] for s in sio.of("speak"))
            snap = (await http.get(f"/api/agent/missions/{finished['mission_id']}")).json()
            assert snap["state"] == "succeeded"
            trace = await container.trace.read(finished["mission_id"])
            reaction_calls = [r for r in trace if r["kind"] == "tool_result" and r.get("reaction")]
            assert [(r["tool"], r["is_error"]) for r in reaction_calls] == [
                ("skill_control.instantiate_skill", True)
            ]
            processes = next(r for r in trace if r["kind"] == "processes")
            assert processes["processes"][0]["id"] == "mailroom-run"  # retrieved from memory
        finally:
            await sio.close()
