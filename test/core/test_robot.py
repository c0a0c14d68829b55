"""The robot description: the shipped file matches docs/conventions.md; bad files name the key."""

import math

import pytest
import yaml

from srs_ros.core.errors import ConfigurationError
from srs_ros.core.robot import config_dir, default_robot, load_robot, robot_from_dict


def _data():
    return yaml.safe_load((config_dir() / "robot.yaml").read_text())


def test_shipped_description_matches_conventions():
    robot = default_robot()
    assert robot.module_count == 3 and robot.actuators_per_module == 3 and robot.joint_count == 9
    assert robot.unactuated_length_m == 0.15
    assert robot.actuator_radius_m == 0.0125
    assert robot.max_extension_m == 0.065
    assert robot.module_twist_rad == pytest.approx(math.pi / 3)
    assert robot.mounting_offset_m == 0.0
    assert robot.max_pressure_bar == 4.0
    assert robot.pressure_per_length_bar_per_m == 100.0
    assert robot.deadzone_offset_bar == 0.0
    assert robot.regulator.name == "ITV3050" and robot.regulator.full_scale_pressure_bar == 9.0
    assert robot.joint_names == tuple(f"m{i}_pma{j}" for i in (1, 2, 3) for j in (1, 2, 3))
    assert robot.backbone_xi.shape == (31,) and robot.backbone_xi[1] == pytest.approx(0.1)
    assert robot.actuator_angles_rad.tolist() == pytest.approx([0, 2 * math.pi / 3, 4 * math.pi / 3])


def test_load_from_explicit_path(tmp_path):
    data = _data()
    data["robot"]["mounting_offset_m"] = 0.01
    path = tmp_path / "robot.yaml"
    path.write_text(yaml.safe_dump(data))
    assert load_robot(path).mounting_offset_m == 0.01


@pytest.mark.parametrize(
    ("section", "key", "value", "message"),
    [
        ("robot", "unactuated_length_m", None, "robot.unactuated_length_m is missing; expected a number > 0 (m)"),
        ("robot", "unactuated_length_m", -0.15, "robot.unactuated_length_m is -0.15; expected a number > 0 (m)"),
        ("robot", "max_extension_m", "long", "robot.max_extension_m is 'long'; expected a number > 0 (m)"),
        ("robot", "module_count", 2.5, "robot.module_count is 2.5; expected an integer >= 1"),
        ("robot", "joint_names", ["a", "a", "b", "c", "d", "e", "f", "g", "h"], "9 unique names"),
        ("robot", "colour", "red", "robot.colour is not a known key; expected one of [actuator_radius_m"),
        ("actuation", "max_pressure_bar", 6.0, "actuation.max_pressure_bar is 6.0; expected a number in (0, 4] (bar)"),
        ("actuation", "max_pressure_bar", float("nan"), "actuation.max_pressure_bar is nan"),
        ("actuation", "regulator_model", "ITV9999", "expected one of ['ITV3010', 'ITV3030', 'ITV3050']"),
        ("actuation", "supply_pressure_bar", 4.5, "at least max_pressure_bar + supply_margin_bar = 5 bar"),
        ("actuation", "deadzone_offset_bar", True, "actuation.deadzone_offset_bar is True"),
    ],
)
def test_invalid_files_name_the_key(section, key, value, message):
    data = _data()
    if value is None:
        del data[section][key]
    else:
        data[section][key] = value
    with pytest.raises(ConfigurationError) as info:
        robot_from_dict(data, source="bad.yaml")
    assert message in str(info.value) and "bad.yaml" in str(info.value)


def test_missing_section_and_missing_file(tmp_path):
    data = _data()
    del data["actuation"]
    with pytest.raises(ConfigurationError, match="actuation is missing; expected a mapping"):
        robot_from_dict(data)
    with pytest.raises(ConfigurationError, match="no such file"):
        load_robot(tmp_path / "nope.yaml")
    (tmp_path / "broken.yaml").write_text("robot: [unclosed")
    with pytest.raises(ConfigurationError, match="cannot be read as YAML"):
        load_robot(tmp_path / "broken.yaml")
    (tmp_path / "latin1.yaml").write_bytes("robot:\n  name: Gr\xf6\xdfe\n".encode("latin-1"))  # was a bare traceback
    with pytest.raises(ConfigurationError, match=r"latin1.yaml: not UTF-8 text \(byte b'\\xf6' at offset 17\)"):
        load_robot(tmp_path / "latin1.yaml")


def test_regulator_that_cannot_reach_the_limit_is_rejected():
    data = _data()
    data["actuation"]["regulator_model"] = "ITV3010"
    with pytest.raises(ConfigurationError, match="full_scale_pressure_bar"):
        robot_from_dict(data)


def test_a_key_at_the_top_instead_of_in_its_section_is_refused_not_ignored(tmp_path):
    """robot.yaml, a rig file and a camera calibration read their sections and ignored any other top-level key: a
    `max_pressure_bar: 2` at the top, or a rig's `backend_options:` with a NaN left unindented, had no effect and
    said nothing (a helper's config review). Every regulator model is checked, not only the one chosen now."""
    from srs_ros.core.rig import rig_from_dict
    from srs_ros.core.vision.camera_calibration import calibration_from_dict

    data = _data()
    data["max_pressure_bar"] = 2.0
    with pytest.raises(ConfigurationError, match="max_pressure_bar is not a known key"):
        robot_from_dict(data)
    data = _data()
    data["regulator_models"]["spare"] = dict(data["regulator_models"][data["actuation"]["regulator_model"]],
                                             supply_margin_bar=math.nan)
    with pytest.raises(ConfigurationError, match=r"regulator_models.spare.supply_margin_bar is nan"):
        robot_from_dict(data)
    rig = {"rig": {"name": "r", "backend": "mock", "command_rate_hz": 200.0, "setpoint_timeout_s": 0.2},
           "backend_options": {"pressure_time_constant_s": math.nan}}
    with pytest.raises(ConfigurationError, match="'backend_options' belongs to the rig block: indent it under rig:"):
        rig_from_dict(rig)
    calibration = {"camera_calibration": {"homography_image_to_floor": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]},
                   "intrinsics": {"k": [500, 0, 320, 0, 500, 240, 0, 0, 1], "d": [0, 0, 0, 0, 0]}}
    with pytest.raises(ConfigurationError, match="'intrinsics' belongs to the camera_calibration block"):
        calibration_from_dict(calibration)
