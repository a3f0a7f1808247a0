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
"published" counts ``/camera/camera_info`` (small, sent with every image), "received" the
images (921 KB each, BEST_EFFORT: under load the transport drops some), "rendered" the new
views robot-sim rendered (its DEBUG log).
JSON in benchmarks/results/sim_world.json. Bounded: about 3 minutes with the defaults.
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

import rclpy
from nav2_msgs.action import NavigateToPose
from rclpy.action.client import ActionClient
from rclpy.context import Context
from rclpy.executors import MultiThreadedExecutor
from sensor_msgs.msg import CameraInfo, Image

from robot_mcp_navigation.motion.base import Pose
from robot_sim.camera import Camera
from robot_sim.config import default_world_path
from robot_sim.node import CAMERA_QOS
from robot_sim.planner import GridPlanner
from robot_sim.render.renderer import MujocoRenderer
from robot_sim.store import SceneStore
from robot_sim.world import load_world

sys.path.insert(0, str(Path(__file__).resolve().parent))
from sim_camera_vision import cpu_s, percentile, start, stop, wait_for

ROOT = Path(__file__).resolve().parents[1]
RESULTS = Path(__file__).resolve().parent / "results"
FAR = ["meeting_room", "kitchen", "mailroom", "dock"]


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


class CameraCounter:
    """Counts /camera/image_raw frames and keeps the robot driving between far places."""

    def __init__(self) -> None:
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node("sim_world_bench", context=self.context)
        self.executor = MultiThreadedExecutor(num_threads=2, context=self.context)
        self.executor.add_node(self.node)
        self.frames: list[float] = []
        self.infos: list[float] = []
        self.node.create_subscription(Image, "/camera/image_raw", self._on_image, CAMERA_QOS)
        # CameraInfo goes with every image and is small: its rate is the rate published
        self.node.create_subscription(
            CameraInfo,
            "/camera/camera_info",
            lambda m: self.infos.append(time.monotonic()),
            CAMERA_QOS,  # best effort, as the sim publishes it
        )
        self.navigate = ActionClient(self.node, NavigateToPose, "/navigate_to_pose")
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()
        self.driving = False

    def _on_image(self, msg: Image) -> None:
        self.frames.append(time.monotonic())

    def fps(self, t0: float, t1: float) -> float:
        return sum(1 for t in self.frames if t0 <= t <= t1) / (t1 - t0)

    def published_fps(self, t0: float, t1: float) -> float:
        return sum(1 for t in self.infos if t0 <= t <= t1) / (t1 - t0)

    def keep_driving(self, world: Any, until: float) -> None:
        """Goals between far places until ``until`` (the robot is always moving)."""
        if not self.navigate.wait_for_server(timeout_sec=30.0):
            raise TimeoutError("no NavigateToPose server")
        for name in itertools.cycle(FAR):
            if time.monotonic() > until:
                return
            place = world.map.locations[name]
            goal = NavigateToPose.Goal()
            goal.pose.header.frame_id = "map"
            goal.pose.pose.position.x, goal.pose.pose.position.y = place.x, place.y
            goal.pose.pose.orientation.z = math.sin(place.theta / 2)
            goal.pose.pose.orientation.w = math.cos(place.theta / 2)
            sent = self.navigate.send_goal_async(goal)
            wait_for(sent.done, 10.0, "goal response")
            result = sent.result().get_result_async()
            wait_for(lambda r=result: r.done() or time.monotonic() > until, 120.0, "arrival")
            if not result.done():
                sent.result().cancel_goal_async()
                return

    def close(self) -> None:
        self.executor.shutdown(timeout_sec=2.0)
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


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


def alone(seconds: float) -> dict[str, Any]:
    work = Path(tempfile.mkdtemp(prefix="sim_world_alone_"))
    ready = work / "sim.pid"
    log = work / "robot_sim.log"
    sim = start(
        [sys.executable, "-m", "robot_sim"],
        {
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
        fps = counter.fps(t0, t1)
        wall0, wall1 = time.time() - (time.monotonic() - t0), time.time() - (time.monotonic() - t1)
        driver.join(timeout=15)
    finally:
        counter.close()
        stop(sim)
    rendered = rendered_frames(log, wall0, wall1)
    return {
        "camera_fps_published": round(counter.published_fps(t0, t1), 2),
        "camera_fps_rendered": round(len(rendered) / (t1 - t0), 2),
        "frame_ms_in_robot_sim": stats(rendered) if rendered else None,
        "camera_fps_received": round(fps, 2),
        "robot_sim_cpu_percent": round(cpu, 1),
        "seconds": round(t1 - t0, 1),
        "robot": "driving all the time (time scale 1)",
    }


def under_stack() -> dict[str, Any]:
    from robot_stack_testing.mission_driver import (
        MAILROOM_REQUEST,
        MissionDriver,
        mailroom_stack,
        seed_memory,
    )
    from robot_stack_testing.stack import free_port_overrides

    stack_file = ROOT / "deploy" / "local-stack.yaml"
    overrides = {**free_port_overrides(stack_file), "nav_time_scale": "2"}
    var = Path(tempfile.mkdtemp(prefix="sim_world_stack_"))
    counter = CameraCounter()
    try:
        with mailroom_stack(ROOT, var, overrides) as stack:
            sim_pid = stack.services["robot_sim"].popen.pid

            async def mission() -> Any:
                await seed_memory(stack)
                async with MissionDriver(stack.brain_url) as user:
                    await user.wait_servers_connected(60.0)
                    cpu0, t0 = cpu_s(sim_pid), time.monotonic()
                    record = await user.run_mission(MAILROOM_REQUEST, timeout_s=180.0)
                    t1 = time.monotonic()
                    return record, cpu0, t0, t1

            record, cpu0, t0, t1 = asyncio.run(mission())
            cpu = (cpu_s(sim_pid) - cpu0) / (t1 - t0) * 100
            fps = counter.fps(t0, t1)
            published = counter.published_fps(t0, t1)
    finally:
        counter.close()
    return {
        "camera_fps_published": round(published, 2),
        "camera_fps_received": round(fps, 2),
        "robot_sim_cpu_percent": round(cpu, 1),
        "mission_seconds": round(t1 - t0, 1),
        "mission_outcome": record.outcome,
        "load": "the whole local stack (8 processes) running the mailroom mission, time scale 2",
    }


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--skip-stack", action="store_true")
    args = parser.parse_args()
    load_at_start = Path("/proc/loadavg").read_text().split()[:3]
    result: dict[str, Any] = {
        "machine": f"{os.cpu_count()} cores",
        "loadavg_at_start": load_at_start,
    }
    result["plan"] = plan_times()
    result["render"] = render_times()
    result["alone"] = alone(args.seconds)
    if not args.skip_stack:
        result["stack"] = under_stack()
    result["loadavg_at_end"] = Path("/proc/loadavg").read_text().split()[:3]
    RESULTS.mkdir(exist_ok=True)
    out = RESULTS / "sim_world.json"
    out.write_text(json.dumps(result, indent=2))
    print(json.dumps(result, indent=2))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
