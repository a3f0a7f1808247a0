"""Process entry point: ``robot-sim`` (settings from the environment, see the README)."""

from __future__ import annotations

import os
import signal
import sys
from types import FrameType

import rclpy
import structlog
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor

from robot_ros_bridge.spinning import spin_until_shutdown
from robot_sim.camera import Camera
from robot_sim.config import ConfigError, SimSettings, load_settings
from robot_sim.costmap import RobotMap
from robot_sim.drive import DriveSim
from robot_sim.logging_setup import configure_logging
from robot_sim.render.renderer import MujocoRenderer
from robot_sim.stall_watch import StallWatch
from robot_sim.store import SceneStore
from robot_sim.world import WorldError, load_world

logger = structlog.get_logger(__name__)


def build(settings: SimSettings) -> tuple[DriveSim, Camera]:
    """The composition root: the world, what the robot knows of it, the drive and the camera
    (the first frame saved before the node is up, so the grounder's folder is never empty)."""
    world = load_world(settings.world_path, settings.map_path)
    robot_map = RobotMap(world.floor, world.closed_doors)
    drive = DriveSim(world.map, settings.time_scale, settings.failures_enabled, robot_map)
    store = SceneStore(settings.scenes_dir, settings.scenes_keep)
    removed = store.clear_stale()
    camera = Camera(world, store, MujocoRenderer(world), moving_scale=settings.moving_render_scale)
    camera.shot(drive.state(0.0).pose)
    logger.info("scenes_ready", removed_stale=removed, directory=str(settings.scenes_dir))
    return drive, camera


def _interrupt(signum: int, frame: FrameType | None) -> None:
    raise KeyboardInterrupt


def spin_on(executor: MultiThreadedExecutor) -> None:
    """Spin until shutdown (``robot_ros_bridge.spinning``): rmw failing to send a service reply
    to a client whose reply reader it has not matched yet raised out of spin() and took the
    whole simulated robot down in a CI run."""
    spin_until_shutdown(executor)


def main(args: list[str] | None = None) -> None:
    try:
        settings = load_settings(os.environ)
        configure_logging(settings.log_level)
        drive, camera = build(settings)
    except (ConfigError, WorldError, OSError) as exc:
        configure_logging()
        logger.error("startup_failed", detail=str(exc))
        sys.exit(2)
    from robot_sim.node import SimNode  # rclpy message imports only once the config is good

    signal.signal(signal.SIGTERM, _interrupt)
    rclpy.init(args=args)
    executor = MultiThreadedExecutor(num_threads=4)
    node: SimNode | None = None
    watch = StallWatch(settings.stall_dump_s) if settings.stall_dump_s else None
    try:
        node = SimNode(settings, drive, camera)
        if watch is not None:
            node.on_pose_tick = watch.beat
        executor.add_node(node)
        if settings.ready_file is not None:
            settings.ready_file.parent.mkdir(parents=True, exist_ok=True)
            settings.ready_file.write_text(str(os.getpid()))
        spin_on(executor)
    except (KeyboardInterrupt, ExternalShutdownException):
        logger.info("robot_sim_interrupted")
    finally:
        if watch is not None:
            watch.close()
        executor.shutdown(timeout_sec=2.0)  # no callback runs on the node once it is destroyed
        if node is not None:
            node.destroy_node()
        camera.renderer.close()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
