"""config/sim.yaml: loaded into a SimConfig; every bad value refused with the key, the value and what is expected."""

import copy
import dataclasses

import pytest
import yaml

from srs_ros.core.actuation.muscle_model import MUSCLE_OPTION_DEFAULTS
from srs_ros.core.errors import ConfigurationError
from srs_ros.core.robot import config_dir, default_robot
from srs_ros.sim.config import (
    changed_values,
    default_sim_config_path,
    load_sim_config,
    sim_config_from_dict,
    with_friction,
)


@pytest.fixture(scope="module")
def raw():
    return yaml.safe_load(default_sim_config_path().read_text())


def test_the_package_file_loads_with_units_and_shared_muscle_defaults():
    config = load_sim_config()
    robot = default_robot()
    assert config.body.segments_per_module >= 1 and config.body.skin_radius_m > robot.actuator_radius_m
    assert config.physics.steps_per_control * config.physics.time_step_s == pytest.approx(
        config.physics.control_period_s)
    # No muscle option in the file: the mock backend's shared defaults and the robot's deadzone/extension.
    assert config.muscles.pressure_time_constant_s == MUSCLE_OPTION_DEFAULTS["pressure_time_constant_s"]
    assert config.muscles.transport_delay_s == MUSCLE_OPTION_DEFAULTS["transport_delay_s"]
    assert config.muscles.deadzone_bar == robot.deadzone_bar
    assert config.muscles.max_extension_m == robot.max_extension_m
    assert config.contact.friction == "isotropic" and config.contact.self_contact is True


@pytest.mark.parametrize(("section", "key", "value", "expected"), [
    ("body", "segments_per_module", 0, "an integer in [1, 20] (segments)"),
    ("body", "segments_per_module", 2.5, "an integer in [1, 20] (segments)"),
    ("body", "skin_radius_m", -0.02, "a number in [0.002, 0.2] (m)"),
    ("servo", "bend_stiffness_nm_per_rad", "stiff", "a number in [0.0001, 10000] (N m/rad)"),
    ("servo", "skin_bend_stiffness_nm_per_rad", float("nan"), "a number in [0, 10000] (N m/rad)"),
    ("contact", "friction", "sticky", "one of ['isotropic', 'anisotropic']"),
    ("contact", "friction_coefficient", -0.1, "a number in [0, 10]"),
    ("contact", "self_contact", "yes", "true or false"),
    ("physics", "time_step_s", 0.5, "a number in [1e-05, 0.02] (s)"),
    ("physics", "control_period_s", 0.003, "a whole number (>= 1) of time_step_s = 0.002 s"),
    ("physics", "solver_iterations", True, "an integer in [1, 1000] (iterations)"),
    ("start", "yaw_rad", None, "a number in [-10, 10] (rad)"),
    ("camera", "tail_band_bgr", [300, 0, 0], "a list of 3 integers in [0, 255] (B, G, R)"),
    ("camera", "head_band_bgr", [0, 0], "a list of 3 integers in [0, 255] (B, G, R)"),
    ("muscles", "transport_delay_s", -1.0, "a number in [0, 2] (s)"),
    ("servo", "drive", "pistons", "one of ['joint_servos', 'muscle_tendons']"),
    ("servo", "twist_stiffness_nm_per_rad", -0.1, "a number in [0, 10000] (N m/rad)"),
    ("servo", "bend_moment_limit_nm", -0.2, "a number in [0, 100] (N m)"),
    ("contact", "roll_stiffness_nm_per_rad", -0.5, "a number in [0, 100] (N m/rad)"),
    ("contact", "floor_contact", "grid", "one of ['capsules', 'points']"),
    ("contact", "points_around", 2, "0 (one sphere on the axis) or 3 to 12 (spheres around the skin)"),
    ("body", "mass_per_module_kg", -1.0, "a number in [0, 100] (kg)"),
])
def test_a_bad_value_is_refused_naming_the_key_the_value_and_what_is_expected(raw, section, key, value, expected):
    data = copy.deepcopy(raw)
    data["sim"][section][key] = value
    with pytest.raises(ConfigurationError) as error:
        sim_config_from_dict(data, source="bad.yaml")
    text = str(error.value)
    assert text == f"bad.yaml: sim.{section}.{key} is {value!r}; expected {expected}.", text


@pytest.mark.parametrize(("change", "message"), [
    (lambda d: d["sim"]["body"].update(segments=5), "sim.body.segments is not a known key; expected one of "
                                                    r"\[marker_offset_m, mass_per_module_kg, segments_per_module, "
                                                    r"skin_radius_m\]"),
    (lambda d: d["sim"]["servo"].pop("axial_stiffness_n_per_m"), "sim.servo.axial_stiffness_n_per_m is missing"),
    (lambda d: d["sim"].pop("contact"), "sim.contact is missing"),
    (lambda d: d["sim"].update(extras={}), "sim.extras is not a known key"),
    (lambda d: d.pop("sim"), "bad.yaml: sim is missing"),
])
def test_structure_errors_say_what_is_missing_or_unknown(raw, change, message):
    data = copy.deepcopy(raw)
    change(data)
    with pytest.raises(ConfigurationError, match=message):
        sim_config_from_dict(data, source="bad.yaml")


def test_a_missing_file_is_a_configuration_error(tmp_path):
    with pytest.raises(ConfigurationError, match="no such file"):
        load_sim_config(tmp_path / "nope.yaml")


@pytest.mark.parametrize(("text", "mode", "along_across"), [
    ("isotropic", "isotropic", None),
    ("anisotropic", "anisotropic", None),
    ("0.5", "isotropic", (0.5, 0.5)),
    ("0.2, 0.9", "anisotropic", (0.2, 0.9)),
])
def test_friction_option(text, mode, along_across):
    base = load_sim_config()
    contact = with_friction(base, text).contact
    assert contact.friction == mode
    expected = along_across or ((base.contact.friction_along_body, base.contact.friction_across_body)
                                if mode == "anisotropic" else (base.contact.friction_coefficient,) * 2)
    assert contact.along_across == pytest.approx(expected)


@pytest.mark.parametrize("text", ["slippery", "1,2,3", "-0.5", "0.3,abc"])
def test_a_bad_friction_option_is_refused(text):
    with pytest.raises(ConfigurationError, match="friction"):
        with_friction(load_sim_config(), text)


def test_replace_validates_the_new_value():
    config = load_sim_config()
    assert config.replace("start", yaw_rad=1.0).start.yaw_rad == 1.0
    assert config.start.yaw_rad == 0.0  # the original is untouched
    with pytest.raises(ConfigurationError, match=r"sim.body.skin_radius_m is 5.0; expected a number in \[0.002, 0.2\]"):
        config.replace("body", skin_radius_m=5.0)


def test_the_shipped_calibration_to_the_paper_loads_and_differs_from_the_defaults_in_fitted_values_only():
    calibrated = load_sim_config(config_dir() / "sim_calibrated_paper.yaml")
    default = load_sim_config()
    assert calibrated.contact.friction_coefficient != default.contact.friction_coefficient
    assert calibrated.muscles != default.muscles and calibrated.body != default.body
    assert dataclasses.replace(calibrated.contact, friction_coefficient=0.0) == dataclasses.replace(
        default.contact, friction_coefficient=0.0)  # no roll damping: the default fit leaves it out
    assert calibrated.servo == default.servo and calibrated.physics == default.physics


def test_the_held_spin_file_differs_from_the_defaults_in_the_five_values_its_header_gives_only():
    """config/sim_held_spin.yaml (docs/simulation.md): the moment limit, the sleeve-only skin, the tubes' hold on the
    spin and 0.2 s lines. benchmarks/model_study.py reads its variant moment_limit_soft_tubes_line_lag from it."""
    changed = changed_values(load_sim_config(config_dir() / "sim_held_spin.yaml"), load_sim_config())
    assert changed == {"servo.bend_moment_limit_nm": 0.2, "servo.skin_bend_stiffness_nm_per_rad": 0.25,
                       "contact.roll_stiffness_nm_per_rad": 0.2, "contact.roll_damping_nms_per_rad": 0.002,
                       "muscles.pressure_time_constant_s": 0.2}
