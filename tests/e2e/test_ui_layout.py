"""The operator UI's layout in a real browser (Debian's chromium, launched by path): the whole
map panel — the office down to the kitchen's label — is in view above the status bar at
1280×800 and, below the chat, at 768 px wide (issue 39: the status bar cut it off, the
kitchen's label hidden). No stack: the page is the built UI and the brain's API answers with
fixtures (the office's places, robot-sim's own floor map rendered by navigation's renderer,
every server connected); nothing binds a port. Screenshots land in build/ui-screenshots/.
"""

from __future__ import annotations

import json
import mimetypes
import shutil
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

import cv2
import numpy as np
import pytest
import yaml
from playwright.sync_api import Browser, Page, Route, sync_playwright

from robot_mcp_navigation.mapview.base import GridSnapshot
from robot_mcp_navigation.mapview.render import floor_view

pytestmark = [pytest.mark.slow, pytest.mark.timeout(120)]

ROOT = Path(__file__).resolve().parents[2]
STATIC = ROOT / "packages" / "robot_voice_chat" / "src" / "robot_voice_chat" / "static"
SHOTS = ROOT / "build" / "ui-screenshots"
CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
ORIGIN = "http://brain.test"
FLOOR_DIR = ROOT / "packages" / "robot_sim" / "config" / "floor"
PLACES = ROOT / "packages" / "robot_mcp_navigation" / "config" / "maps" / "office.yaml"
LABELS = {
    "desk_alice": "Alice's desk",
    "desk_bob": "Bob's desk",
    "meeting_room": "Meeting room",
    "corridor_b": "East corridor",
    "reception": "Reception desk",
}


def _floor() -> dict[str, Any]:
    """robot-sim's map_server map as navigation serves it to the UI (trinary, 0.65/0.196)."""
    meta = yaml.safe_load((FLOOR_DIR / "office.yaml").read_text())
    image = cv2.imread(str(FLOOR_DIR / meta["image"]), cv2.IMREAD_GRAYSCALE)
    occupancy = (255 - image.astype(np.float64)) / 255.0
    cells = np.where(occupancy > 0.65, 100, np.where(occupancy < 0.196, 0, -1)).astype(np.int8)
    cells = cells[::-1]  # an OccupancyGrid's first row is the map's lowest y
    height, width = cells.shape
    origin = (float(meta["origin"][0]), float(meta["origin"][1]))
    grid = GridSnapshot("map", meta["resolution"], origin, width, height, cells.tobytes(), 0.0)
    return floor_view(grid, None)


def _api() -> dict[str, Any]:
    places = yaml.safe_load(PLACES.read_text())["locations"]
    servers = ("navigation", "perception", "skill_control", "memory", "episodic", "manipulation")
    understanding = "rules + embedded matcher"
    return {
        "/api/ui/config": {
            "deployment": "dev", "llm": "rules", "planner": "rules", "speech_input": False,
            "speech_input_reason": "no microphone", "speech_output_browser": False,
            "camera": True,
        },
        "/api/auth/me": {"user": "operator"},
        "/api/readyz": {
            "status": "ready",
            "data": {
                "mcp_servers": dict.fromkeys(servers, "connected"), "llm": "rules",
                "planner": "rules", "planner_understanding": understanding,
                "llm_understanding": understanding, "planner_state": "ok", "deployment": "dev",
            },
        },
        "/api/safety": {"latched": False, "since": None, "by": None, "reason": None},
        "/api/agent/missions": {"missions": [], "active": None},
        "/api/agent/approvals": [],
        "/api/agent/teaching": {"enabled": False},
        "/api/robot/held": {"known": True, "holding": False, "label": None},
        "/api/chat/history": {"lines": []},
        "/api/history": {
            "since": None, "now": None, "count": 0, "truncated": False, "sightings": [],
        },
        "/api/camera/detections": {
            "ts": time.time(), "mode": "warm", "scene": "An office desk.", "scene_age_s": 2,
            "detections": [
                {"label": label, "score": 0.9, "skill": "describe_scene", "age_s": 1,
                 "stale": False}
                for label in ("laptop", "red mug", "chair")
            ],
        },
        "/api/map/locations": {
            "map": "office",
            "locations": [
                {"name": name, "label": LABELS.get(name, name.capitalize()),
                 "description": place.get("description", ""), "x": place["x"], "y": place["y"]}
                for name, place in places.items()
            ],
        },
        "/api/map/pose": {
            "x": 8.5, "y": 8.0, "theta": 0.0, "at_location": "desk_bob", "moving": False,
            "destination": None, "stale": False,
        },
        "/api/map/floor": _floor(),
        "/api/map/plan": {"frame": "map", "points": [], "destination": None},
    }  # fmt: skip


@pytest.fixture(scope="module")
def api() -> dict[str, Any]:
    assert (STATIC / "index.html").is_file(), "the UI is not built: run make setup"
    return _api()


@pytest.fixture(scope="module")
def browser() -> Iterator[Browser]:
    with sync_playwright() as playwright:
        launched = playwright.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        yield launched
        launched.close()


def _serve(api: dict[str, Any]) -> Any:
    ok, frame = cv2.imencode(".jpg", np.full((480, 640, 3), 120, np.uint8))
    assert ok

    def handle(route: Route) -> None:
        path = urlsplit(route.request.url).path
        if path.startswith("/socket.io"):
            route.abort()
        elif path == "/api/camera/frame":
            route.fulfill(status=200, body=frame.tobytes(), content_type="image/jpeg")
        elif path in api:
            route.fulfill(status=200, body=json.dumps(api[path]), content_type="application/json")
        elif path.startswith("/api/"):
            route.fulfill(status=404, body='{"detail": "no such fixture"}')
        else:
            file = STATIC / (path.lstrip("/") or "index.html")
            file = file if file.is_file() else STATIC / "index.html"
            kind = mimetypes.guess_type(file.name)[0] or "application/octet-stream"
            route.fulfill(status=200, body=file.read_bytes(), content_type=kind)

    return handle


def _open(browser: Browser, api: dict[str, Any], width: int, height: int) -> Page:
    page = browser.new_page(viewport={"width": width, "height": height})
    page.route("**/*", _serve(api))
    page.goto(f"{ORIGIN}/")
    page.get_by_test_id("floor-plan").wait_for(state="attached", timeout=20_000)
    page.get_by_role("group", name="Floor map").get_by_text("Kitchen", exact=True).first.wait_for(
        timeout=10_000
    )
    return page


def _box(page: Page, selector: Any) -> dict[str, float]:
    box = selector.bounding_box()
    assert box is not None
    return {"top": box["y"], "bottom": box["y"] + box["height"]}


@pytest.mark.parametrize(("width", "height"), [(1280, 800), (768, 1024)])
def test_the_whole_map_is_in_view_above_the_status_bar(
    browser: Browser, api: dict[str, Any], width: int, height: int
) -> None:
    page = _open(browser, api, width, height)
    try:
        SHOTS.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(SHOTS / f"layout-{width}x{height}.png"))
        status = _box(page, page.locator("footer"))
        panel = _box(page, page.get_by_role("region", name="Map"))
        kitchen = _box(
            page,
            page.get_by_role("group", name="Floor map").get_by_text("Kitchen", exact=True).first,
        )
        assert panel["top"] >= 0
        assert panel["bottom"] <= status["top"], (panel, status)  # not scrolled: in view
        assert kitchen["bottom"] <= status["top"], (kitchen, status)
    finally:
        page.close()
