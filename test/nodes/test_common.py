"""Parameters of every node: integers are accepted for double parameters (start-up and ``ros2 param set``)."""

import pytest
import rclpy
from rclpy.context import Context
from rclpy.exceptions import InvalidParameterTypeException
from rclpy.parameter import Parameter
from srs_testing import ros_args

from srs_ros.nodes.common import ParameterSpec, check_parameters, declare_parameters

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


def test_wrong_type_reason_says_to_write_a_double():
    assert "e.g. 500.0" in SPECS[0].check("fast")


@pytest.mark.ros
def test_gait_player_takes_integer_rate_from_the_command_line_and_param_set(launch_node, ros_client):
    proc = launch_node("gait_player", ros_args({"rate_hz": 500}))  # -p rate_hz:=500, an integer
    assert ros_client.get_parameters("gait_player", ["rate_hz"], timeout_s=20.0) == {"rate_hz": 500.0}
    result = ros_client.set_parameters("gait_player", {"rate_hz": 250})[0]  # ros2 param set ... rate_hz 250
    assert result.successful, result.reason
    value = ros_client.get_parameters("gait_player", ["rate_hz"])["rate_hz"]
    assert value == 250.0 and isinstance(value, float)
    assert proc.alive(), proc.output()
