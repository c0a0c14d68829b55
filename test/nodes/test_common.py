"""Parameters of every node: integers are accepted for double parameters (start-up and ``ros2 param set``)."""

import math
import re

import pytest
import rclpy
from rcl_interfaces.msg import ParameterType
from rcl_interfaces.srv import DescribeParameters, GetParameters, ListParameters, SetParameters
from rclpy.context import Context
from rclpy.exceptions import InvalidParameterTypeException
from rclpy.parameter import Parameter
from srs_testing import ros_args

from srs_ros.core.errors import ConfigurationError
from srs_ros.ros.parameters import ParameterSpec, check_parameters, declare_parameters, startup_value

SPECS = (ParameterSpec("rate_hz", 200.0, "rate, Hz", 1.0, 1000.0), ParameterSpec("cycles", 0, "cycles", 0, 10))


@pytest.fixture
def node(ros_domain):
    context = Context()
    rclpy.init(context=context, domain_id=ros_domain)
    created = []

    def _node(**overrides):
        made = rclpy.create_node("params_under_test", context=context,
                                 parameter_overrides=[Parameter(k, value=v) for k, v in overrides.items()])
        created.append(made)
        return made

    yield _node
    for made in created:
        made.destroy_node()
    rclpy.shutdown(context=context)


def test_integer_start_up_value_of_a_double_parameter_is_taken_as_a_double(node):
    made = node(rate_hz=500, cycles=3)
    declare_parameters(made, SPECS)
    assert made.get_parameter("rate_hz").type_ == Parameter.Type.DOUBLE
    assert made.get_parameter("rate_hz").value == 500.0
    assert made.get_parameter("cycles").type_ == Parameter.Type.INTEGER  # integers stay integers


def test_integer_set_at_run_time_is_stored_as_a_double_and_still_range_checked(node):
    made = node()
    specs = declare_parameters(made, SPECS)
    made.add_on_set_parameters_callback(lambda params: check_parameters(specs, params))
    assert made.set_parameters([Parameter("rate_hz", value=250)])[0].successful
    assert made.get_parameter("rate_hz").type_ == Parameter.Type.DOUBLE and made.get_parameter("rate_hz").value == 250.0
    too_fast = made.set_parameters([Parameter("rate_hz", value=5000)])[0]
    assert not too_fast.successful and made.get_parameter("rate_hz").value == 250.0
    text = made.set_parameters([Parameter("rate_hz", value="fast")])[0]
    assert not text.successful and "DOUBLE" in text.reason
    # A double for an integer parameter is not silently truncated.
    assert not made.set_parameters([Parameter("cycles", value=2.5)])[0].successful


def test_without_the_conversion_rclpy_refuses_the_integer(node):
    """The behaviour the conversion fixes (guards against the test passing for the wrong reason)."""
    made = node(rate_hz=500)
    with pytest.raises(InvalidParameterTypeException):
        made.declare_parameter("rate_hz", 200.0)


def test_a_second_declare_parameters_call_on_a_node_is_refused(node):
    """Each call adds a pre-set callback, and rclpy concatenates their outputs: one call per node only."""
    made = node()
    declare_parameters(made, SPECS[:1])
    with pytest.raises(RuntimeError, match="declare_parameters called twice on node 'params_under_test'"):
        declare_parameters(made, SPECS[1:])
    assert not made.has_parameter("cycles")


def test_without_the_one_call_rule_an_integer_set_would_arrive_twice_and_be_refused(node):
    """The rclpy behaviour the rule guards against (the test passing for the right reason)."""
    made = node()
    declare_parameters(made, SPECS[:1])
    del made._srs_declared_parameters  # bypass the guard, as a second call did before it
    declare_parameters(made, (ParameterSpec("gain", 1.0, "gain", 0.0, 10.0),))
    assert not made.set_parameters([Parameter("rate_hz", value=250)])[0].successful


def test_a_start_up_value_is_read_before_declaring(node):
    robot_file = ParameterSpec("robot_description_file", "", "robot YAML", read_only=True)
    assert startup_value(node(), robot_file) == ""
    assert startup_value(node(robot_description_file="/tmp/robot.yaml"), robot_file) == "/tmp/robot.yaml"
    assert startup_value(node(rate_hz=500), SPECS[0]) == 500.0
    assert startup_value(node(robot_description_file=3), robot_file) == "3"  # as declare_parameters will take it
    with pytest.raises(ConfigurationError, match="invalid start-up parameter: robot_description_file is 2.5; "
                                                 "expected a string; robot YAML."):
        startup_value(node(robot_description_file=2.5), robot_file)


def test_an_integer_for_a_string_parameter_is_its_text_at_start_up_and_at_run_time(node):
    """ros2cli and rcl type `-p source:=0` (a camera index) as an INTEGER: camera_tracker refused what its docs say."""
    source = ParameterSpec("source", "", "a video file or a camera index (e.g. '0')")
    made = node(source=0)
    declare_parameters(made, (source,))
    assert made.get_parameter("source").type_ == Parameter.Type.STRING and made.get_parameter("source").value == "0"
    assert made.set_parameters([Parameter("source", value=2)])[0].successful
    assert made.get_parameter("source").value == "2"


@pytest.mark.parametrize(("spec", "value", "expected"), [
    (ParameterSpec("camera_encoding", "bgr8", "encoding", choices=("bgr8", "mono8")), "foo",
     "camera_encoding is 'foo'; expected one of"),
    (ParameterSpec("gain", 1.0, "gain", 0.0, 10.0, above_minimum=True), 0.0, "gain is 0.0; expected"),
    (ParameterSpec("levels", [0.0, 1.0], "levels", length=2), [1.0], "levels is [1.0]; expected"),
])
def test_a_start_up_value_is_checked_as_a_set_would_be_and_the_node_does_not_start(node, spec, value, expected):
    """rclpy's descriptor checks a start-up value's type and range only: sim_world with camera_encoding:=foo started
    and died at its first frame with a traceback; navigator took a misspelt calibration_preset silently."""
    with pytest.raises(ConfigurationError, match=re.escape(f"invalid start-up parameter: {expected}")):
        declare_parameters(node(**{spec.name: value}), (spec,))


def test_wrong_type_reason_says_to_write_a_double():
    assert SPECS[0].check("fast") == "rate_hz is 'fast'; expected a number in [1, 1000], e.g. 200.0; rate, Hz."


#: Every node process, with what keeps it light (no start-up fit, no camera) and an integer start-up value
#: for a double parameter (``-p rate_hz:=500``).
NODES = {
    "trajectory_server": ({"generate_on_start": False, "amplitude_bar": 3}, "amplitude_bar"),
    "gait_player": ({"rate_hz": 500}, "rate_hz"),
    "hardware_node": ({"state_publish_rate_hz": 25}, "state_publish_rate_hz"),
    "camera_tracker": ({"image_timeout_s": 2}, "image_timeout_s"),
    "sim_world": ({"camera_rate_hz": 0.0, "pose_rate_hz": 25}, "pose_rate_hz"),
    "navigator": ({"calibration_preset": "sim_bands", "pose_timeout_s": 2}, "pose_timeout_s"),
}


def writable_doubles(client, node: str) -> dict[str, int]:
    """Every double parameter of ``node`` that is not read-only, with an integer inside its range to send."""
    names = client.call(ListParameters, f"{node}/list_parameters").result.names
    described = client.call(DescribeParameters, f"{node}/describe_parameters",
                            DescribeParameters.Request(names=names)).descriptors
    current = client.get_parameters(node, list(names))
    chosen = {}
    for descriptor in described:
        if descriptor.type != ParameterType.PARAMETER_DOUBLE or descriptor.read_only:
            continue
        limits = descriptor.floating_point_range[0] if descriptor.floating_point_range else None
        low, high = (math.ceil(limits.from_value), math.floor(limits.to_value)) if limits else (-5, 5)
        assert low <= high, f"{node} {descriptor.name}: no integer in [{limits.from_value}, {limits.to_value}]"
        middle = (limits.from_value + limits.to_value) / 2 if limits else 0.0
        candidates = sorted(range(low, high + 1), key=lambda v: (v == current[descriptor.name], abs(v - middle)))
        chosen[descriptor.name] = candidates[0]
    return chosen


@pytest.mark.ros
@pytest.mark.slow(seconds=5)
def test_every_writable_double_of_every_node_takes_an_integer_as_ros2_param_set_sends_it(launch_node, ros_client):
    procs = {node: launch_node(node, ros_args(params)) for node, (params, _) in NODES.items()}  # all at once
    ros_client.discover([(srv_type, f"{node}/{name}") for node in NODES for srv_type, name in (
        (ListParameters, "list_parameters"), (DescribeParameters, "describe_parameters"),
        (GetParameters, "get_parameters"), (SetParameters, "set_parameters"))], timeout_s=60.0)
    taken = {}
    for node, proc in procs.items():
        params, start_up_integer = NODES[node]
        value = ros_client.get_parameters(node, [start_up_integer])[start_up_integer]
        assert isinstance(value, float) and value == params[start_up_integer], (node, start_up_integer, value)
        chosen = writable_doubles(ros_client, node)
        for name, value in chosen.items():  # one request per parameter, as `ros2 param set` sends it
            result = ros_client.set_parameters(node, {name: value})[0]
            assert result.successful, f"ros2 param set /{node} {name} {value}: {result.reason}"
        values = ros_client.get_parameters(node, list(chosen))
        for name, value in chosen.items():
            assert isinstance(values[name], float) and values[name] == value, (node, name, values[name])
        taken[node] = set(chosen)
        assert proc.alive(), proc.output()
    assert {"amplitude_bar", "frequency_hz", "serpentine.poor_fit_mm"} <= taken["trajectory_server"]
    assert {"rate_hz", "amplitude_scale"} <= taken["gait_player"]
    assert {"setpoint_timeout_s", "ramp_time_s"} <= taken["hardware_node"]
    assert {"goal_tolerance_m", "pose_timeout_s"} <= taken["navigator"]


@pytest.mark.parametrize("names", [("trajectory_server", "gait-player"), ("1ts", "gait_player")])
def test_a_gait_node_name_that_is_no_name_is_a_start_up_error_that_names_the_parameters(node, names):
    """navigator -p gait_player:=gait-player ended in rclpy's traceback, exit 1 (a helper's review)."""
    from srs_ros.ros.gait_driver import GaitDriver
    from srs_ros.ros.process import STARTUP_ERRORS

    with pytest.raises(ConfigurationError, match=re.escape(f"trajectory_server {names[0]!r} or gait_player "
                                                           f"{names[1]!r} is not a node name: ")) as raised:
        GaitDriver(node(), *names)
    assert isinstance(raised.value, STARTUP_ERRORS)
