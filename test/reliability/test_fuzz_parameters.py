"""Every declared parameter of every node, set to hostile values over DDS while the node runs.

Hypothesis draws (parameter, value) pairs: the node's own parameters (listed from the node) and some
that do not exist, with values of every ROS parameter type and of none (wrong types, NaN, inf, huge,
negative, empty and odd strings, arrays, deletion, an unknown type tag). Each set must be answered:
refused with a reason, or taken (read back as set) and then survived by the node's work (hardware
node: configure, command, vent; trajectory_server: a fit; gait_player: the stream; camera_tracker:
everything is read-only). The node stays alive and answers; a taken value is put back afterwards.
A node started with a hostile parameter (out of range, of the wrong type) exits with status 2 and the reason.
"""

import copy
import math
import os
import time

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, example, given, settings
from hypothesis import strategies as st
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import ListParameters, SetParameters
from sensor_msgs.msg import JointState
from srs_testing import JOINT_NAMES, BackendRecord, recorded_rig, rolling_cycle, ros_args, trajectory
from trajectory_msgs.msg import JointTrajectory

from srs_ros.core.vision.camera_calibration import save_calibration
from srs_ros.ros.interfaces import SETPOINT_TOPIC, TRAJECTORY_TOPIC, latched_qos, setpoint_qos
from srs_ros.sim.scene import SyntheticCamera

SETTINGS = settings(max_examples=25, deadline=None, database=None, phases=[Phase.explicit, Phase.generate],
                    suppress_health_check=list(HealthCheck), report_multiple_bugs=False)
NAMES = JOINT_NAMES

STRINGS = st.one_of(st.sampled_from(["", " ", "/dev/zero", "/dev/null", "/nonexistent/file.yaml", "../../etc/passwd",
                                     "x" * 5000, "ñ\u202e", "0", "-1", "nan", "inspect", "serpentine", "mock", "can"]),
                    st.text(max_size=20))
DOUBLES = st.one_of(st.sampled_from([math.nan, math.inf, -math.inf, 1e308, -1e308, 0.0, -0.0, 5e-324, -1.0, 1e-300]),
                    st.floats())
INTEGERS = st.one_of(st.sampled_from([0, -1, 1, 2**63 - 1, -2**63, 2**31]), st.integers(-2**63, 2**63 - 1))


def value_of(kind: int, value) -> ParameterValue:
    """A ParameterValue message of type ``kind`` holding ``value`` (what ``ros2 param set`` sends)."""
    msg = ParameterValue(type=kind)
    field = {ParameterType.PARAMETER_BOOL: "bool_value", ParameterType.PARAMETER_INTEGER: "integer_value",
             ParameterType.PARAMETER_DOUBLE: "double_value", ParameterType.PARAMETER_STRING: "string_value",
             ParameterType.PARAMETER_BYTE_ARRAY: "byte_array_value",
             ParameterType.PARAMETER_BOOL_ARRAY: "bool_array_value",
             ParameterType.PARAMETER_INTEGER_ARRAY: "integer_array_value",
             ParameterType.PARAMETER_DOUBLE_ARRAY: "double_array_value",
             ParameterType.PARAMETER_STRING_ARRAY: "string_array_value"}.get(kind)
    if field is not None:
        setattr(msg, field, value)
    return msg


VALUES = {
    ParameterType.PARAMETER_BOOL: st.booleans(),
    ParameterType.PARAMETER_INTEGER: INTEGERS,
    ParameterType.PARAMETER_DOUBLE: DOUBLES,
    ParameterType.PARAMETER_STRING: STRINGS,
    ParameterType.PARAMETER_BYTE_ARRAY: st.lists(st.binary(min_size=1, max_size=1), max_size=4),
    ParameterType.PARAMETER_BOOL_ARRAY: st.lists(st.booleans(), max_size=4),
    ParameterType.PARAMETER_INTEGER_ARRAY: st.lists(INTEGERS, max_size=4),
    ParameterType.PARAMETER_DOUBLE_ARRAY: st.lists(DOUBLES, max_size=4),
    ParameterType.PARAMETER_STRING_ARRAY: st.lists(STRINGS, max_size=4),
    ParameterType.PARAMETER_NOT_SET: st.none(),
    99: st.none(),  # a type tag no ROS parameter has
}


@st.composite
def hostile_parameter(draw, types: dict[str, int]):
    """(name, ParameterValue): mostly the parameter's own type with hostile content, else any type."""
    name = draw(st.one_of(st.sampled_from(sorted(types)), st.sampled_from(["not_declared", "", "a..b", "/x"])))
    own = types.get(name, ParameterType.PARAMETER_DOUBLE)
    kind = own if draw(st.integers(0, 2)) else draw(st.sampled_from(sorted(VALUES)))
    return name, value_of(kind, draw(VALUES[kind]))


def same(a: ParameterValue, b: ParameterValue) -> bool:
    from rclpy.parameter import parameter_value_to_python

    x, y = parameter_value_to_python(a), parameter_value_to_python(b)
    if isinstance(x, float) and isinstance(y, float):
        return x == y or (math.isnan(x) and math.isnan(y))
    return list(x) == list(y) if isinstance(x, (list, tuple, np.ndarray)) else x == y


def over_dds(value: ParameterValue) -> ParameterValue:
    """``value`` as the node receives it: DDS carries strings as C strings, so each ends at its first NUL."""
    carried = copy.deepcopy(value)
    carried.string_value = carried.string_value.split("\x00")[0]
    carried.string_array_value = [text.split("\x00")[0] for text in carried.string_array_value]
    return carried


class ParameterFuzz:
    """Sets one parameter on a running node, checks the answer and the node, and puts taken values back."""

    def __init__(self, client, node: str, proc):
        self.client, self.node, self.proc = client, node, proc
        names = client.call(ListParameters, f"{node}/list_parameters").result.names
        from rcl_interfaces.srv import GetParameters

        values = client.call(GetParameters, f"{node}/get_parameters", GetParameters.Request(names=names)).values
        self.original = dict(zip(names, values))
        self.types = {name: value.type for name, value in self.original.items()}

    def set(self, name: str, value: ParameterValue):
        request = SetParameters.Request(parameters=[Parameter(name=name, value=value)])
        results = self.client.call(SetParameters, f"{self.node}/set_parameters", request).results
        assert len(results) == 1, results
        return results[0]

    def value(self, name: str) -> ParameterValue:
        """The parameter's value (type NOT_SET when the node does not have it)."""
        from rcl_interfaces.srv import GetParameters

        values = self.client.call(GetParameters, f"{self.node}/get_parameters",
                                  GetParameters.Request(names=[name])).values
        return values[0] if values else ParameterValue()

    def one(self, name: str, value: ParameterValue, exercise) -> None:
        result = self.set(name, value)
        if not result.successful:
            assert result.reason.strip(), f"{name}: refused without a reason"
        else:
            expected = over_dds(value)
            if self.types.get(name) == ParameterType.PARAMETER_STRING and value.type == ParameterType.PARAMETER_INTEGER:
                # an integer for a string parameter is taken as its text, as ros2cli's `-p source:=0` needs
                expected = value_of(ParameterType.PARAMETER_STRING, str(value.integer_value))
            assert same(self.value(name), expected), (name, value, self.value(name))
            exercise(name)
            restored = self.set(name, self.original[name])
            assert restored.successful, (name, restored.reason)
        assert self.proc.alive(), self.proc.output()[-3000:]
        assert "Traceback" not in self.proc.output(), self.proc.output()[-3000:]
        # still declared with its own type (a deletion is refused), and an unknown name is not created
        assert self.value(name).type == self.types.get(name, ParameterType.PARAMETER_NOT_SET), name


def run_fuzz(fuzz: ParameterFuzz, exercise, explicit=()) -> None:
    @SETTINGS
    @given(hostile_parameter(fuzz.types))
    def one_hostile_parameter(case):
        fuzz.one(*case, exercise)

    for case in explicit:
        one_hostile_parameter = example(case)(one_hostile_parameter)
    one_hostile_parameter()


# Values that must always be tried: deletion, an unknown type tag, NaN and infinity where a number is expected.
ALWAYS = [("rate_hz", value_of(ParameterType.PARAMETER_NOT_SET, None)), ("use_sim_time", value_of(99, None))]


def test_hardware_node_parameters(launch_node, ros_client, tmp_path):
    rig, record_path = recorded_rig(tmp_path)
    proc = launch_node("hardware_node", ros_args({"rig_file": str(rig)}))
    client = ros_client
    client.spin_until(lambda: client.lifecycle_state("/hardware_node") == "unconfigured", 20.0, "hardware_node up")
    publisher = client.node.create_publisher(JointState, SETPOINT_TOPIC, setpoint_qos())
    record = BackendRecord(record_path)
    good = JointState(name=NAMES, position=[0.02] * 9)

    def exercise(name: str) -> None:
        """Configure with the new value: it either works (and commands safely) or is refused with the reason."""
        failures = proc.output().count("configure failed")
        if client.change_state("/hardware_node", "configure"):
            assert client.change_state("/hardware_node", "activate")
            end = time.monotonic() + 0.3
            while time.monotonic() < end:
                publisher.publish(good)
                client.spin_for(0.01)
            assert client.change_state("/hardware_node", "deactivate")
            assert client.change_state("/hardware_node", "cleanup")
        else:
            client.spin_until(lambda: proc.output().count("configure failed") > failures, 5.0, "the reason")
            assert client.lifecycle_state("/hardware_node") == "unconfigured"
        assert client.trigger("/hardware_node/emergency_stop").success  # the e-stop always answers
        assert client.trigger("/hardware_node/reset").success
        written = record.update().pressures_bar
        assert np.all(np.isfinite(written)) and np.all((written >= 0.0) & (written <= 4.0))

    fuzz = ParameterFuzz(client, "/hardware_node", proc)
    fifo = tmp_path / "rig.fifo"
    os.mkfifo(fifo)
    run_fuzz(fuzz, exercise, ALWAYS[1:] + [
        ("setpoint_timeout_s", value_of(ParameterType.PARAMETER_DOUBLE, math.nan)),
        ("command_rate_hz", value_of(ParameterType.PARAMETER_DOUBLE, math.inf)),
        ("rig_file", value_of(ParameterType.PARAMETER_STRING, str(fifo))),
        ("rig_file", value_of(ParameterType.PARAMETER_INTEGER, -2)),  # taken as the text '-2': configure refuses it
        ("backend", value_of(ParameterType.PARAMETER_STRING, "can")),
        ("calibration_file", value_of(ParameterType.PARAMETER_STRING, "\u00d9^\x00b")),  # DDS ends it at the NUL
        ("ramp_time_s", value_of(ParameterType.PARAMETER_DOUBLE, 0.0)),  # taken: configures and commands
    ])
    assert len(record) > 0  # the recorded rig was configured and written at least once


def test_trajectory_server_parameters(launch_node, ros_client):
    proc = launch_node("trajectory_server", ros_args({"samples": 16}))
    client = ros_client
    client.spin_until(client.client(_trigger(), "/trajectory_server/regenerate").service_is_ready, 20.0, "server up")

    def exercise(name: str) -> None:
        response = client.trigger("/trajectory_server/regenerate", timeout_s=60.0)
        assert response.message.strip()

    run_fuzz(ParameterFuzz(client, "/trajectory_server", proc), exercise, ALWAYS[1:] + [
        ("frequency_hz", value_of(ParameterType.PARAMETER_DOUBLE, 1e-300)),
        ("amplitude_bar", value_of(ParameterType.PARAMETER_DOUBLE, -0.0)),
        ("gait", value_of(ParameterType.PARAMETER_STRING, "")),
    ])


def test_gait_player_parameters(launch_node, ros_client):
    proc = launch_node("gait_player", ros_args({"autostart": True, "rate_hz": 100.0, "ramp_time_s": 0.1}))
    client = ros_client
    trajectories = client.node.create_publisher(JointTrajectory, TRAJECTORY_TOPIC, latched_qos())
    setpoints = client.subscribe(JointState, SETPOINT_TOPIC, setpoint_qos(depth=1000))
    trajectories.publish(trajectory(rolling_cycle(32), 1.0))
    client.spin_until(lambda: len(setpoints) > 20, 20.0, "the stream")

    def exercise(name: str) -> None:
        start = len(setpoints)
        client.spin_for(0.15)
        sent = np.array([m.position for m in setpoints[start:]]).reshape(-1, 9)
        assert np.all(np.isfinite(sent)) and (sent.size == 0 or (sent.min() >= 0.0 and sent.max() <= 0.065))

    run_fuzz(ParameterFuzz(client, "/gait_player", proc), exercise, ALWAYS + [
        ("rate_hz", value_of(ParameterType.PARAMETER_DOUBLE, 1e-9)),
        ("amplitude_scale", value_of(ParameterType.PARAMETER_DOUBLE, math.nan)),
    ])
    start = len(setpoints)
    client.spin_until(lambda: len(setpoints) > start + 20, 30.0, "the stream after the fuzzing")


def test_camera_tracker_parameters(launch_node, ros_client, tmp_path):
    calibration = save_calibration(SyntheticCamera(width_px=320, height_px=240).calibration(), tmp_path / "cal.yaml")
    proc = launch_node("camera_tracker", ros_args({"calibration_file": str(calibration)}))
    client = ros_client
    client.spin_until(lambda: client.node.count_publishers("/robot_pose") > 0, 20.0, "camera_tracker up")
    run_fuzz(ParameterFuzz(client, "/camera_tracker", proc), lambda name: None, ALWAYS[1:])


def test_navigator_parameters(launch_node, ros_client):
    """The navigator alone (no gait nodes: its gait calls fail and say so): after each set, a goal is taken."""
    from geometry_msgs.msg import PoseStamped
    from std_msgs.msg import String

    from srs_ros.ros.interfaces import GOAL_POSE_TOPIC, NAVIGATION_PROGRESS_TOPIC, POSE_TOPIC, progress_fields

    proc = launch_node("navigator", ros_args({"calibration_preset": "sim_bands"}))
    client = ros_client
    progress = client.subscribe(String, NAVIGATION_PROGRESS_TOPIC, latched_qos())
    goals = client.node.create_publisher(PoseStamped, GOAL_POSE_TOPIC, 10)
    poses = client.node.create_publisher(PoseStamped, POSE_TOPIC, 10)
    client.spin_until(lambda: progress and goals.get_subscription_count(), 20.0, "the navigator up")

    def exercise(name: str) -> None:
        pose, goal = PoseStamped(), PoseStamped()
        pose.header.frame_id = goal.header.frame_id = "floor"
        pose.header.stamp = client.node.get_clock().now().to_msg()
        pose.pose.orientation.w = goal.pose.orientation.w = 1.0
        goal.pose.position.x = 0.3
        poses.publish(pose)
        goals.publish(goal)
        start = len(progress)
        client.spin_until(lambda: len(progress) > start + 2, 10.0, "progress after the goal")
        fields = progress_fields(progress[-1])
        assert fields["state"] in ("driving", "stopping", "pose_lost", "failed") or fields["refused"], fields
        client.trigger("/navigator/cancel")

    run_fuzz(ParameterFuzz(client, "/navigator", proc), exercise, ALWAYS[1:] + [
        ("goal_tolerance_m", value_of(ParameterType.PARAMETER_DOUBLE, math.nan)),
        ("turn_levels_rad", value_of(ParameterType.PARAMETER_DOUBLE_ARRAY, [0.5, -0.5])),
        ("view_margin_m", value_of(ParameterType.PARAMETER_DOUBLE, 1.9)),
    ])


def _trigger():
    from std_srvs.srv import Trigger

    return Trigger


# -- start-up: a node launched with a hostile parameter says why not and exits with status 2 ------------------
# Each value is out of its declared range or of the wrong type (docs/safety.md: a start-up value the node
# cannot take stops it with the reason; it never runs on a value it would refuse at run time).
@pytest.mark.parametrize(("script", "name", "value", "reason"), [
    ("gait_player", "rate_hz", ".nan", "rate_hz out of range"),
    ("gait_player", "robot_description_file", "/dev/zero", "/dev/zero: not a regular file"),
    ("hardware_node", "max_pressure_bar", ".inf", "max_pressure_bar out of range Min: 0.1, Max: 4.0"),
    ("trajectory_server", "samples", "9223372036854775808", "expecting type 'INTEGER'"),
    ("camera_tracker", "velocity_window_s", "[.nan, 1]", "the ROS arguments cannot be parsed"),
    ("navigator", "goal_tolerance_m", ".nan", "goal_tolerance_m out of range"),
    ("navigator", "turn_levels_rad", "[0.5, -0.5]", "increasing values"),
])
def test_a_node_started_with_a_hostile_parameter_exits_2_with_the_reason(launch_node, script, name, value, reason):
    proc = launch_node(script, ["--ros-args", "-p", f"{name}:={value}"])
    assert proc.process.wait(60.0) == 2, (value, proc.output()[-3000:])
    output = proc.output()
    assert "cannot start" in output and reason in output, (value, output[-3000:])
    assert name in output or value in output, (value, output[-3000:])  # says which parameter or file
    assert "Traceback" not in output, (value, output[-3000:])
