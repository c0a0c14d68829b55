"""Launch the SRS system as separate processes on a stock ROS 2 install (params from config/).

- ``ros2 launch srs_ros srs.launch.py``: the simulated robot (``sim_world``, MuJoCo) on the sim rig, watched
  by ``camera_tracker`` on its overhead camera, inward rolling at 4 bar, 1 Hz;
- ``ros2 launch srs_ros srs.launch.py rig_file:=/path/to/rigs/can.yaml sim:=false camera_preset:=''
  gait:=serpentine amplitude_bar:=3``: a real rig (then arm it: ``ros2 service call /hardware_node/arm
  std_srvs/srv/Trigger``) with a real camera tracking ArUco markers (``camera:=false`` for none);
- ``ros2 launch srs_ros srs.launch.py namespace:=snake1 use_sim_time:=true``: every node under
  ``/snake1`` (topics ``/snake1/joint_setpoints`` ..., services ``/snake1/hardware_node/...``), on
  ``/clock`` time;
- ``ros2 launch srs_ros srs.launch.py navigate:=true``: closed loop, the ``navigator`` drives the gait to the
  goals sent on ``goal_pose`` (RViz's "2D Goal Pose", frame ``floor``) or ``goal_path``, by the camera's pose;
  the gait player then waits for it instead of starting on its own (docs/navigation.md).

``hardware_node`` is started with launch_ros's ``LifecycleNode`` action, so launch can drive its
transitions (``ChangeState`` events); with ``autostart:=true`` it configures and activates itself.
Numbers are handed to the nodes as doubles whether written ``3`` or ``3.0``; a number that is not one
(``amplitude_bar:=abc``) stops the launch before any node starts, with an error naming the argument, its
value and what it takes; a switch takes ``true`` or ``false`` only. ``ros2 launch srs_ros srs.launch.py
--show-args`` lists the arguments. Their defaults (gait, amplitude, frequency, rig, camera preset) are read from the
parameter specs of srs_ros (:mod:`srs_ros.core.gait.request`, :data:`srs_ros.core.rig.SYSTEM_RIG` and
:data:`~srs_ros.core.rig.SIM_COLOR_PRESET`), as ``srs_bringup``'s are, so neither restates a value.
"""

import math
import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import LifecycleNode, Node
from launch_ros.parameter_descriptions import ParameterValue

from srs_ros.core import rig
from srs_ros.core.gait.library import list_gaits
from srs_ros.core.gait.request import FREQUENCY_FIELD, gait_field
from srs_ros.core.robot import amplitude_field, default_robot

#: The numeric launch arguments: (unit, an example value).
NUMBERS = {"amplitude_bar": ("bar", "3"), "frequency_hz": ("Hz", "1")}


def _check_numbers(context) -> None:
    """Refuse a numeric launch argument that is not a finite number, naming it, its value and what it takes.

    Without it launch_ros fails later with only ``could not convert string to float: 'abc'``. The
    switches (``sim``, ``camera``, ``autostart``, ``use_sim_time``) are checked by their ``choices``
    (launch names the argument, the value and the valid options); the ranges by the nodes.
    """
    for name, (unit, example) in NUMBERS.items():
        text = LaunchConfiguration(name).perform(context)
        try:
            finite = math.isfinite(float(text))
        except ValueError:
            finite = False
        if not finite:
            raise RuntimeError(f"launch argument {name}:={text!r} is not valid: expected a finite number of {unit} "
                               f"(e.g. {name}:={example} or {name}:={example}.0)")


def _typed(name: str, value_type: type) -> ParameterValue:
    """The launch argument ``name`` as a typed parameter value (``3`` becomes 3.0 for a float)."""
    return ParameterValue(LaunchConfiguration(name), value_type=value_type)


def _gait_player(context, config: str, namespace, common: dict) -> list:
    """gait_player; with ``navigate:=true`` it never starts on its own (the navigator starts and stops it)."""
    autostart = (LaunchConfiguration("autostart").perform(context) == "true"
                 and LaunchConfiguration("navigate").perform(context) != "true")
    return [Node(package="srs_ros", executable="gait_player", name="gait_player", namespace=namespace,
                 output="screen", parameters=[os.path.join(config, "gait_player.yaml"), common,
                                              {"autostart": autostart}])]


def generate_launch_description():
    config = os.path.join(get_package_share_directory("srs_ros"), "config")
    gait, amplitude = gait_field(list_gaits()), amplitude_field(default_robot())
    args = [
        DeclareLaunchArgument("gait", default_value=gait.default, description=f"gait to stream, {gait.expected} "
                              "(with navigate:=true the navigator chooses)"),
        DeclareLaunchArgument("amplitude_bar", default_value=str(amplitude.default),
                              description=f"largest pressure of the cycle, {amplitude.expected} (3 or 3.0); with "
                                          "navigate:=true the navigator's cruise amplitude (0.5-4 bar)"),
        DeclareLaunchArgument("frequency_hz", default_value=str(FREQUENCY_FIELD.default),
                              description=f"gait frequency, {FREQUENCY_FIELD.expected} (1 or 1.0); with "
                                          "navigate:=true the navigator chooses (its cruise_frequency_hz)"),
        DeclareLaunchArgument("rig_file", default_value=os.path.join(config, "rigs", f"{rig.SYSTEM_RIG}.yaml"),
                              description="rig YAML (backend, channels, rates); rigs/sim.yaml = the simulated robot"),
        DeclareLaunchArgument("sim", default_value="true", choices=["true", "false"],
                              description="start sim_world, the simulated robot (for rigs/sim.yaml)"),
        DeclareLaunchArgument("autostart", default_value="true", choices=["true", "false"],
                              description="configure and activate the hardware node, play the gait"),
        DeclareLaunchArgument("camera", default_value="true", choices=["true", "false"],
                              description="start the camera tracker (on image_raw)"),
        DeclareLaunchArgument("camera_preset", default_value=rig.SIM_COLOR_PRESET, choices=list(rig.COLOR_PRESETS),
                              description=f"camera_tracker color_preset: {rig.SIM_COLOR_PRESET} for sim_world's "
                                          "camera, '' for config/camera_tracker.yaml (ArUco markers of a real robot)"),
        DeclareLaunchArgument("namespace", default_value="", description="ROS namespace of every node"),
        DeclareLaunchArgument("use_sim_time", default_value="false", choices=["true", "false"],
                              description="use /clock (simulation) time"),
        DeclareLaunchArgument("navigate", default_value="false", choices=["true", "false"],
                              description="start the navigator (goals on goal_pose / goal_path, pose from the camera); "
                                          "the gait then plays only when the navigator starts it"),
    ]
    namespace = LaunchConfiguration("namespace")
    common = {"use_sim_time": _typed("use_sim_time", bool)}
    autostart = {"autostart": _typed("autostart", bool)}
    trajectory_server = Node(
        package="srs_ros", executable="trajectory_server", name="trajectory_server", namespace=namespace,
        output="screen",
        parameters=[os.path.join(config, "trajectory_server.yaml"), common, {
            "gait": LaunchConfiguration("gait"),
            "amplitude_bar": _typed("amplitude_bar", float),
            "frequency_hz": _typed("frequency_hz", float),
        }],
    )
    gait_player = OpaqueFunction(function=_gait_player, args=[config, namespace, common])
    hardware_node = LifecycleNode(
        package="srs_ros", executable="hardware_node", name="hardware_node", namespace=namespace, output="screen",
        parameters=[os.path.join(config, "hardware_node.yaml"), common, autostart,
                    {"rig_file": LaunchConfiguration("rig_file")}],
    )
    camera_tracker = Node(
        package="srs_ros", executable="camera_tracker", name="camera_tracker", namespace=namespace, output="screen",
        parameters=[os.path.join(config, "camera_tracker.yaml"), common,
                    {"color_preset": _typed("camera_preset", str)}],
        condition=IfCondition(LaunchConfiguration("camera")),
    )
    navigator = Node(
        package="srs_ros", executable="navigator", name="navigator", namespace=namespace, output="screen",
        parameters=[os.path.join(config, "navigator.yaml"), common,  # amplitude_bar:=3: it was 4 bar (a review)
                    {"calibration_preset": _typed("camera_preset", str),
                     "amplitude_bar": _typed("amplitude_bar", float)}],
        condition=IfCondition(LaunchConfiguration("navigate")),
    )
    sim_world = Node(
        package="srs_ros", executable="sim_world", name="sim_world", namespace=namespace, output="screen",
        parameters=[common], condition=IfCondition(LaunchConfiguration("sim")),
    )
    check = OpaqueFunction(function=_check_numbers)  # after the arguments, before any node starts
    return LaunchDescription(args + [check, sim_world, trajectory_server, gait_player, hardware_node, camera_tracker,
                                     navigator])
