"""ros2 launch robot_mcp_perception vision.launch.py (system-ROS users).

Hydra config is selected with environment variables, exactly as for ``uv run vision_node``:
PERCEPTION_DEPLOYMENT (preset of config/deployment/) and PERCEPTION_CONFIG_OVERRIDES.
The node parameters of spec 000 §7 can be overridden here as launch arguments.
``camera_topic`` feeds the frame source through Hydra (``node.camera_topic``), the other
arguments are ROS parameters the node reads at start-up (tests/deploy/test_ros_packaging.py
checks both against the node).
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, SetEnvironmentVariable
from launch.substitutions import EnvironmentVariable, LaunchConfiguration
from launch_ros.actions import Node


def generate_launch_description() -> LaunchDescription:
    arguments = [
        DeclareLaunchArgument("camera_topic", default_value="/camera/image_raw"),
        DeclareLaunchArgument("topic_namespace", default_value="/vision"),
        DeclareLaunchArgument("processing_frequency", default_value="1.0"),
        DeclareLaunchArgument("max_in_flight", default_value="4"),
        DeclareLaunchArgument(
            "config_overrides",
            default_value=EnvironmentVariable("PERCEPTION_CONFIG_OVERRIDES", default_value=""),
            description="Hydra overrides, e.g. 'frame_source=ros segmenter=none'",
        ),
    ]
    return LaunchDescription(
        [
            *arguments,
            SetEnvironmentVariable(
                "PERCEPTION_CONFIG_OVERRIDES",
                [
                    LaunchConfiguration("config_overrides"),
                    " node.camera_topic=",
                    LaunchConfiguration("camera_topic"),
                ],
            ),
            Node(
                package="robot_mcp_perception",
                executable="vision_node",
                name="vision_node",
                output="screen",
                parameters=[
                    {
                        "camera_topic": LaunchConfiguration("camera_topic"),
                        "topic_namespace": LaunchConfiguration("topic_namespace"),
                        "processing_frequency": LaunchConfiguration("processing_frequency"),
                        "max_in_flight": LaunchConfiguration("max_in_flight"),
                    }
                ],
            ),
        ]
    )
