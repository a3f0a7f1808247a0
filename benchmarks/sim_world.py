"""robot-sim's world (issue 29): plan time on the office grid, the MuJoCo camera's render cost,
and the camera's frame rate and CPU — robot-sim alone, and while the whole local stack runs a
mission (the e2e load).

    uv run python benchmarks/sim_world.py [--seconds 20] [--skip-stack]

1. **plan**: GridPlanner (scikit-image MCP_Geometric on the costmap) between every pair of
   named places, 3 rounds: median / p95 / max ms, in this process.
2. **render**: MujocoRenderer (RGB + segmentation, 640×480, OSMesa) + annotation + the PNG/JSON
   save, from 30 random free poses: ms per frame, in this process.
3. **alone**: the ``robot-sim`` process with the robot driving all the time (goals between far
   places, time scale 1: every frame is a new view to render, annotate and save): camera frames
   received per second on ``/camera/image_raw`` and robot-sim's CPU (% of one core).
4. **stack**: the whole local stack (deploy/local-stack.yaml, every service a process) running
   the mailroom mission through the brain, while this process counts camera frames and
   robot-sim's CPU over the mission.
"published" counts ``/camera/camera_info`` (small, sent with every image under the same
stamp), "received" the images with those stamps (921 KB each, BEST_EFFORT) by a depth-1 reader
(the camera's QoS, as the vision node reads it) and a depth-10 one (what the transport
delivered); under the stack also the frames the vision node received (its ``/healthz``
``frame.seq``); "rendered" the new views robot-sim rendered (its DEBUG log).
3 and 4 run with the local stack's Fast DDS profile (``deploy/fastdds-local.xml``: the frames
over shared memory) and without it (Fast DDS's default 512 KB segment), one after the other on
the same machine load (``--fastdds-profile on|off|both``, default both).
JSON in benchmarks/results/sim_world.json. Bounded: about 6 minutes with the defaults.
"""

from __future__ import annotations

import argparse
import asyncio
import itertools
import json
import math
import os
import random
import statistics
import sys
import tempfile
import threading
import time
from datetime import datetime
from pathlib import Path
from typing import Any

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_DOMAIN_ID", str(random.SystemRandom().randint(101, 199)))

import urllib.error
import urllib.request

import yaml

from robot_mcp_navigation.motion.base import Pose
from robot_sim.camera import Camera
from robot_sim.config import default_world_path
from robot_sim.planner import GridPlanner
from robot_sim.render.renderer import MujocoRenderer
from robot_sim.store import SceneStore
from robot_sim.world import load_world

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _camera_counter import CameraCounter
from sim_camera_vision import cpu_s, percentile, stack_env, start, stop, wait_for

ROOT = Path(__file__).resolve().parents[1]
RESULTS = Path(__file__).resolve().parent / "results"
STACK_FILE = ROOT / "deploy" / "local-stack.yaml"


def stats(values: list[float]) -> dict[str, float]:
    return {
        "n": len(values),
        "median": round(statistics.median(values), 1),
        "p95": round(percentile(values, 95), 1),
        "max": round(max(values), 1),
    }


def plan_times() -> dict[str, Any]:
    world = load_world(default_world_path())
    planner = GridPlanner()
    costmap = planner.costmap(world.floor.with_doors_closed(world.closed_doors()))
    times = []
    for _ in range(3):
        for a, b in itertools.permutations(world.map.locations.values(), 2):
            started = time.perf_counter()
            planner.plan(costmap, (a.x, a.y), (b.x, b.y))
            times.append((time.perf_counter() - started) * 1000)
    started = time.perf_counter()
    planner.costmap(world.floor.grid)
    costmap_ms = (time.perf_counter() - started) * 1000
    grid = world.floor.grid
    return {
        "grid_cells": f"{grid.width}x{grid.height} at {grid.resolution} m",
        "plan_ms": stats(times),
        "costmap_build_ms": round(costmap_ms, 1),
    }


def render_times(count: int = 30) -> dict[str, Any]:
    world = load_world(default_world_path())
    free = world.floor.grid.free
    rng = random.Random(7)
    renderer = MujocoRenderer(world)
    camera = Camera(world, SceneStore(Path(tempfile.mkdtemp(prefix="sim_world_render_"))), renderer)
    camera.shot(Pose(0.0, 0.0))  # build the model and the GL context once
    render_ms, shot_ms = [], []
    try:
        while len(shot_ms) < count:
            x, y = rng.uniform(-2, 21), rng.uniform(-6, 13)
            row, col = world.floor.grid.cell_of(x, y)
            if not (world.floor.grid.inside(row, col) and free[row, col]):
                continue
            pose = Pose(x, y, rng.uniform(-math.pi, math.pi))
            started = time.perf_counter()
            renderer.render(pose)
            render_ms.append((time.perf_counter() - started) * 1000)
            started = time.perf_counter()
            camera.shot(pose)  # render again + annotate + save PNG and JSON
            shot_ms.append((time.perf_counter() - started) * 1000)
    finally:
        renderer.close()
    return {"render_rgb_and_segmentation_ms": stats(render_ms), "frame_total_ms": stats(shot_ms)}


def rendered_frames(log: Path, start: float, end: float) -> list[float]:
    """Durations of the frames robot-sim rendered (its ``camera_rendered`` log) in a window
    of wall-clock time."""
    durations = []
    for line in log.read_text(errors="replace").splitlines():
        if '"camera_rendered"' not in line:
            continue
        record = json.loads(line)
        stamp = datetime.fromisoformat(record["timestamp"]).timestamp()
        if start <= stamp <= end:
            durations.append(float(record["duration_ms"]))
    return durations


def alone(seconds: float, profile: bool) -> dict[str, Any]:
    work = Path(tempfile.mkdtemp(prefix="sim_world_alone_"))
    ready = work / "sim.pid"
    log = work / "robot_sim.log"
    sim = start(
        [sys.executable, "-m", "robot_sim"],
        {
            **(stack_env(work) if profile else {}),
            "SIM_SCENES_DIR": str(work / "scenes"),
            "SIM_READY_FILE": str(ready),
            "SIM_TIME_SCALE": "1",
            "LOG_LEVEL": "DEBUG",  # camera_rendered: every new frame, with its duration
        },
        log,
    )
    counter = CameraCounter()
    try:
        wait_for(lambda: ready.is_file(), 60, "robot-sim")
        world = load_world(default_world_path())
        driver = threading.Thread(
            target=counter.keep_driving, args=(world, time.monotonic() + seconds + 5), daemon=True
        )
        driver.start()
        time.sleep(3.0)  # under way
        cpu0, t0 = cpu_s(sim.pid), time.monotonic()
        time.sleep(seconds)
        t1 = time.monotonic()
        cpu = (cpu_s(sim.pid) - cpu0) / (t1 - t0) * 100
        wall0, wall1 = time.time() - (time.monotonic() - t0), time.time() - (time.monotonic() - t1)
        time.sleep(1.0)  # the last frames of the window arrive
        frames = counter.window(t0, t1)
        driver.join(timeout=15)
    finally:
        counter.close()
        stop(sim)
    rendered = rendered_frames(log, wall0, wall1)
    return {
        **frames,
        "camera_fps_rendered": round(len(rendered) / (t1 - t0), 2),
        "frame_ms_in_robot_sim": stats(rendered) if rendered else None,
        "robot_sim_cpu_percent": round(cpu, 1),
        "seconds": round(t1 - t0, 1),
        "robot": "driving all the time (time scale 1)",
    }


def stack_file(profile: bool) -> Path:
    """The shipped stack file, or a copy without its common ``env:`` (no Fast DDS profile)."""
    if profile:
        return STACK_FILE
    document = yaml.safe_load(STACK_FILE.read_text())
    document.pop("env", None)
    copy = Path(tempfile.mkdtemp(prefix="sim_world_stack_file_")) / "local-stack.yaml"
    copy.write_text(yaml.safe_dump(document, sort_keys=False))
    return copy


def vision_frames(url: str) -> int:
    """Frames the vision node has received so far (``/healthz`` ``frame.seq``; its body comes
    with HTTP 503 too, when the node calls itself degraded)."""
    try:
        with urllib.request.urlopen(url, timeout=5.0) as response:
            body = response.read()
    except urllib.error.HTTPError as error:
        body = error.read()
    return int(json.loads(body)["frame"]["seq"] or 0)


def under_stack(profile: bool) -> dict[str, Any]:
    from robot_stack_testing.mission_driver import (
        MAILROOM_REQUEST,
        MissionDriver,
        mailroom_stack,
        seed_memory,
    )
    from robot_stack_testing.stack import free_port_overrides

    path = stack_file(profile)
    overrides = {**free_port_overrides(path), "nav_time_scale": "2"}
    var = Path(tempfile.mkdtemp(prefix="sim_world_stack_"))
    counter = CameraCounter()
    try:
        with mailroom_stack(ROOT, var, overrides, stack_file=path) as stack:
            sim_pid = stack.services["robot_sim"].popen.pid
            processes = len(stack.services)
            healthz = stack.url("vision", "/healthz")

            async def mission() -> Any:
                await seed_memory(stack)
                async with MissionDriver(stack.brain_url) as user:
                    await user.wait_servers_connected(60.0)
                    cpu0, seq0, t0 = cpu_s(sim_pid), vision_frames(healthz), time.monotonic()
                    record = await user.run_mission(MAILROOM_REQUEST, timeout_s=180.0)
                    t1 = time.monotonic()
                    return record, cpu0, seq0, t0, t1

            record, cpu0, seq0, t0, t1 = asyncio.run(mission())
            cpu = (cpu_s(sim_pid) - cpu0) / (t1 - t0) * 100
            seen = vision_frames(healthz) - seq0
            time.sleep(1.0)  # the last frames of the window arrive
            frames = counter.window(t0, t1)
    finally:
        counter.close()
    return {
        **frames,
        "frames_received_vision_node": seen,
        "camera_fps_received_vision_node": round(seen / (t1 - t0), 2),
        "robot_sim_cpu_percent": round(cpu, 1),
        "mission_seconds": round(t1 - t0, 1),
        "mission_outcome": record.outcome,
        "load": f"the whole local stack ({processes} processes) running the mailroom mission, "
        "time scale 2",
    }


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--skip-stack", action="store_true")
    parser.add_argument("--skip-render", action="store_true", help="no plan/render figures")
    parser.add_argument("--fastdds-profile", choices=["on", "off", "both"], default="both")
    args = parser.parse_args()
    profiles = {"on": [True], "off": [False], "both": [False, True]}[args.fastdds_profile]
    result: dict[str, Any] = {
        "machine": f"{os.cpu_count()} cores",
        "loadavg_at_start": Path("/proc/loadavg").read_text().split()[:3],
    }
    if not args.skip_render:
        result["plan"] = plan_times()
        result["render"] = render_times()
    for profile in profiles:
        key = "with_profile" if profile else "without_profile"
        result.setdefault("alone", {})[key] = alone(args.seconds, profile)
        print(key, "alone", json.dumps(result["alone"][key]), flush=True)
    if not args.skip_stack:
        for profile in profiles:
            key = "with_profile" if profile else "without_profile"
            result.setdefault("stack", {})[key] = under_stack(profile)
            print(key, "stack", json.dumps(result["stack"][key]), flush=True)
    result["loadavg_at_end"] = Path("/proc/loadavg").read_text().split()[:3]
    RESULTS.mkdir(exist_ok=True)
    out = RESULTS / "sim_world.json"
    out.write_text(json.dumps(result, indent=2))
    print(json.dumps(result, indent=2))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
