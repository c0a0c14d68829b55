"""The hardware node's settings without ROS: one table with the schema's refusals, and what a configure makes of it."""

import pytest

from srs_ros.core.actuation.settings import HARDWARE_SETTINGS, hardware_setup
from srs_ros.core.errors import ConfigurationError
from srs_ros.core.rig import load_rig, rig_path
from srs_ros.core.robot import config_dir, default_robot

DEFAULTS = HARDWARE_SETTINGS.read({}, "test")


def test_zero_and_empty_settings_take_the_rigs_values_and_the_robots_limit():
    setup = hardware_setup(DEFAULTS)
    rig = load_rig(None)  # the mock rig
    assert (setup.rig.name, setup.backend) == (rig.name, rig.backend)
    assert (setup.timing.command_rate_hz, setup.timing.setpoint_timeout_s) == (rig.command_rate_hz,
                                                                              rig.setpoint_timeout_s)
    assert setup.rig.robot.max_pressure_bar == default_robot().max_pressure_bar == 4.0
    assert setup.shaper.map.name == "paper" and not setup.shaper.compensation and setup.ramp_time_s == 1.0


def test_max_pressure_bar_only_lowers_the_robots_limit(tmp_path):
    assert hardware_setup({**DEFAULTS, "max_pressure_bar": 2.5}).rig.robot.max_pressure_bar == 2.5
    robot_file = tmp_path / "robot.yaml"
    text = (config_dir() / "robot.yaml").read_text()
    assert "max_pressure_bar: 4.0" in text
    robot_file.write_text(text.replace("max_pressure_bar: 4.0", "max_pressure_bar: 3.0"))
    lowered = hardware_setup({**DEFAULTS, "robot_description_file": str(robot_file), "max_pressure_bar": 4.0})
    assert lowered.rig.robot.max_pressure_bar == 3.0


def test_the_backend_setting_overrides_the_rigs_and_rates_override_the_rigs():
    setup = hardware_setup({**DEFAULTS, "rig_file": str(rig_path("sim")), "backend": "mock",
                            "command_rate_hz": 500.0, "setpoint_timeout_s": 0.1, "ramp_time_s": 0.0})
    assert (setup.rig.name, setup.backend) == ("sim", "mock")
    assert (setup.timing.command_rate_hz, setup.timing.setpoint_timeout_s, setup.ramp_time_s) == (500.0, 0.1, 0.0)


def test_a_rule_across_settings_is_refused_at_configure():
    with pytest.raises(ConfigurationError, match="command_rate_hz is 5 Hz"):
        hardware_setup({**DEFAULTS, "command_rate_hz": 5.0, "setpoint_timeout_s": 0.2})
    with pytest.raises(ConfigurationError, match="pressure_map is 'calibrated' but calibration_file is empty"):
        hardware_setup({**DEFAULTS, "pressure_map": "calibrated"})


@pytest.mark.parametrize(("key", "value", "expected"), [
    ("pressure_map", "linear", "pressure_map is 'linear'; expected one of ['paper', 'calibrated']"),
    ("setpoint_timeout_s", 6.0, "setpoint_timeout_s is 6.0; expected a number in [0, 5]"),
    ("max_pressure_bar", 4.5, "max_pressure_bar is 4.5; expected a number in [0.1, 4]"),
    ("autostart", "yes", "autostart is 'yes'; expected true or false"),
])
def test_a_bad_value_is_refused_in_the_one_format(key, value, expected):
    with pytest.raises(ConfigurationError) as refused:
        HARDWARE_SETTINGS.read({key: value}, "my_params.yaml")
    assert str(refused.value).startswith(f"my_params.yaml: hardware_node.{expected}")
