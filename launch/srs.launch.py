"""Launch the SRS system as separate processes on a stock ROS 2 install (params from config/).

- ``ros2 launch srs_ros srs.launch.py``: mock rig, inward rolling at 4 bar, 1 Hz;
- ``ros2 launch srs_ros srs.launch.py rig_file:=/path/to/rigs/can.yaml gait:=serpentine``;
- ``ros2 launch srs_ros srs.launch.py camera:=true``: also the overhead camera tracker.
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


def generate_launch_description():
    config = os.path.join(get_package_share_directory("srs_ros"), "config")
    args = [
        DeclareLaunchArgument("gait", default_value="inward_rolling", description="gait to stream"),
        DeclareLaunchArgument("amplitude_bar", default_value="4.0", description="largest pressure (bar)"),
        DeclareLaunchArgument("frequency_hz", default_value="1.0", description="gait frequency (Hz)"),
        DeclareLaunchArgument("rig_file", default_value=os.path.join(config, "rigs", "mock.yaml"),
                              description="rig YAML (backend, channels, rates)"),
        DeclareLaunchArgument("autostart", default_value="true", description="configure, activate and play"),
        DeclareLaunchArgument("camera", default_value="false", description="start the camera tracker"),
    ]
    trajectory_server = Node(
        package="srs_ros", executable="trajectory_server", name="trajectory_server", output="screen",
        parameters=[os.path.join(config, "trajectory_server.yaml"), {
            "gait": LaunchConfiguration("gait"),
            "amplitude_bar": LaunchConfiguration("amplitude_bar"),
            "frequency_hz": LaunchConfiguration("frequency_hz"),
        }],
    )
    gait_player = Node(
        package="srs_ros", executable="gait_player", name="gait_player", output="screen",
        parameters=[os.path.join(config, "gait_player.yaml"), {"autostart": LaunchConfiguration("autostart")}],
    )
    hardware_node = Node(
        package="srs_ros", executable="hardware_node", name="hardware_node", output="screen",
        parameters=[os.path.join(config, "hardware_node.yaml"), {
            "rig_file": LaunchConfiguration("rig_file"),
            "autostart": LaunchConfiguration("autostart"),
        }],
    )
    camera_tracker = Node(
        package="srs_ros", executable="camera_tracker", name="camera_tracker", output="screen",
        parameters=[os.path.join(config, "camera_tracker.yaml")], condition=IfCondition(LaunchConfiguration("camera")),
    )
    return LaunchDescription(args + [trajectory_server, gait_player, hardware_node, camera_tracker])
