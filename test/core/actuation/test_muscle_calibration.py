"""The per-rig muscle calibration file and the length -> pressure maps built on it."""

import dataclasses

import numpy as np
import pytest
import yaml

from srs_ros.core.actuation.muscle_calibration import (
    CalibratedPressureMap,
    PaperPressureMap,
    calibration_from_dict,
    calibration_from_values,
    load_calibration,
    pressure_map,
    save_calibration,
)
from srs_ros.core.actuation.safety import clamped_joints
from srs_ros.core.errors import ConfigurationError, InvalidInputError
from srs_ros.core.robot import default_robot

ROBOT = default_robot()
NAMES = list(ROBOT.joint_names)
# The simulated muscles: 1 bar deadzone, 65 mm at 4 bar, 30 ms delay, 80 ms lag; m2_pma1 differs.
SIM_MUSCLE = {"deadzone_bar": 1.0, "extension_per_bar_m": 0.065 / 3.0, "saturation_bar": 4.0,
              "transport_delay_s": 0.03, "pressure_time_constant_s": 0.08}
ODD_MUSCLE = {"deadzone_bar": 1.4, "extension_per_bar_m": 0.015, "saturation_bar": 3.5,
              "transport_delay_s": 0.05, "pressure_time_constant_s": 0.12}


def values(**odd):
    entries = {name: dict(SIM_MUSCLE) for name in NAMES}
    entries["m2_pma1"] = dict(ODD_MUSCLE, **odd)
    return entries


def test_the_file_round_trips_and_keeps_each_muscle(tmp_path):
    calibration = calibration_from_values(values(), ROBOT, info={"rig": "sim", "fit": {"m1_pma1": {"n": 3}}})
    path = tmp_path / "sim_calibration.yaml"
    save_calibration(calibration, path, header="written by a test")
    assert path.read_text().startswith("# written by a test\nmuscle_calibration:")
    loaded = load_calibration(path, ROBOT)
    assert loaded.has_dynamics and loaded.info["rig"] == "sim" and loaded.source == str(path)
    for key in ("deadzone_bar", "extension_per_bar_m", "saturation_bar", "transport_delay_s",
                "pressure_time_constant_s"):
        assert getattr(loaded, key) == pytest.approx(getattr(calibration, key), rel=1e-5)
    assert loaded.deadzone_bar[3] == 1.4 and loaded.saturation_extension_m[3] == pytest.approx(0.015 * 2.1)
    assert loaded.extension_m(np.full(9, 2.5))[[0, 3]] == pytest.approx([0.0325, 0.015 * 1.1])


def test_a_static_only_calibration_has_no_dynamics():
    static = {name: {k: SIM_MUSCLE[k] for k in ("deadzone_bar", "extension_per_bar_m", "saturation_bar")}
              for name in NAMES}
    calibration = calibration_from_values(static, ROBOT)
    assert not calibration.has_dynamics and calibration.transport_delay_s is None


@pytest.mark.parametrize(("change", "message"), [
    (lambda d: d["muscle_calibration"]["muscles"].pop("m3_pma3"), r"muscles.m3_pma3 is missing; expected an entry"),
    (lambda d: d["muscle_calibration"]["muscles"].update(m4_pma1=SIM_MUSCLE),
     r"muscles.m4_pma1 is not a known key; expected one of \[m1_pma1"),
    (lambda d: d["muscle_calibration"].update(gain=1), "muscle_calibration.gain is not a known key"),
    (lambda d: d["muscle_calibration"]["muscles"]["m1_pma2"].update(deadzone_bar=-0.5),
     r"m1_pma2.deadzone_bar is -0.5; expected a number in \[0, 4\] \(bar\)"),
    (lambda d: d["muscle_calibration"]["muscles"]["m1_pma2"].update(deadzone_bar=4.0),
     "m1_pma2.deadzone_bar is 4.0; expected less than the robot's max_pressure_bar"),
    (lambda d: d["muscle_calibration"]["muscles"]["m1_pma2"].update(saturation_bar=0.8),
     "m1_pma2.saturation_bar is 0.8; expected more than its deadzone_bar"),
    (lambda d: d["muscle_calibration"]["muscles"]["m1_pma2"].update(extension_per_bar_m=True),
     "m1_pma2.extension_per_bar_m is True"),
    (lambda d: d["muscle_calibration"]["muscles"]["m1_pma2"].pop("transport_delay_s"),
     "m1_pma2.pressure_time_constant_s is 0.08; expected it with the rest of"),
    (lambda d: [d["muscle_calibration"]["muscles"][n].pop(k) for n in NAMES[:4]
                for k in ("transport_delay_s", "pressure_time_constant_s")], "the dynamics of every muscle or of none"),
    (lambda d: d["muscle_calibration"]["muscles"]["m1_pma2"].pop("saturation_bar"),
     "m1_pma2.saturation_bar is missing"),
    (lambda d: d.pop("muscle_calibration"), "cal.yaml: muscle_calibration is missing"),
])
def test_a_bad_file_is_refused_naming_muscle_key_value_and_what_is_expected(change, message):
    data = {"muscle_calibration": {"rig": "sim", "muscles": values()}}
    change(data)
    with pytest.raises(ConfigurationError, match=message):
        calibration_from_dict(data, ROBOT, source="cal.yaml")


def test_the_calibrated_map_inverts_every_muscle_and_commands_4_bar_for_65_mm():
    calibration = calibration_from_values(values(), ROBOT)
    cal_map = CalibratedPressureMap(calibration, ROBOT)
    assert cal_map.limited_length_m[0] == pytest.approx(0.065)  # 4 bar, where the simulated muscles saturate
    assert cal_map.limited_length_m[3] == pytest.approx(0.015 * 2.1)  # its own saturation (3.5 bar) comes first
    assert cal_map.pressures_bar(np.full(9, 0.065))[0] == pytest.approx(4.0)
    lengths = np.linspace(0.001, 1.0, 50)[:, None] * cal_map.limited_length_m
    pressures = cal_map.pressures_bar(lengths)
    assert np.all((pressures >= 0.0) & (pressures <= 4.0))
    assert calibration.extension_m(pressures) == pytest.approx(lengths, abs=1e-12)  # exact inverse, each muscle
    assert cal_map.pressures_bar(np.zeros(9)) == pytest.approx(np.zeros(9))  # a zero setpoint vents
    assert cal_map.pressures_bar(np.full(9, 1e307)) == pytest.approx([4.0, 4, 4, 3.5, 4, 4, 4, 4, 4])
    with pytest.raises(InvalidInputError, match="finite"):
        cal_map.pressures_bar(np.r_[np.nan, np.zeros(8)])


def test_the_paper_map_is_p_100_l_with_its_own_limit():
    paper = pressure_map("paper", ROBOT)
    assert isinstance(paper, PaperPressureMap) and paper.describe() == "P = 100 l"
    assert paper.pressures_bar(np.full(9, 0.025)) == pytest.approx(np.full(9, 2.5))
    assert paper.limited_length_m == pytest.approx(np.full(9, 0.04))
    assert paper.gain_bar_per_m == pytest.approx(np.full(9, 100.0))


def test_the_clamp_warning_follows_the_selected_map():
    lengths = np.r_[0.05, 0.066, np.zeros(7)]
    cal_map = CalibratedPressureMap(calibration_from_values(values(), ROBOT), ROBOT)
    assert clamped_joints(lengths, ROBOT) == ["m1_pma1", "m1_pma2"]  # P = 100 l: 0.05 m needs 5 bar
    assert clamped_joints(lengths, ROBOT, cal_map.limited_length_m) == ["m1_pma2"]  # only beyond 65 mm


def test_a_lowered_pressure_limit_shortens_the_calibrated_stroke():
    robot = dataclasses.replace(ROBOT, max_pressure_bar=3.0)
    cal_map = CalibratedPressureMap(calibration_from_values(values(), robot), robot)
    assert cal_map.limited_length_m[0] == pytest.approx(2.0 * 0.065 / 3.0)
    assert cal_map.pressures_bar(np.full(9, 0.065)).max() == pytest.approx(3.0)


def test_the_calibrated_map_needs_a_calibration_of_this_robot():
    with pytest.raises(ConfigurationError, match="needs a calibration file"):
        pressure_map("calibrated", ROBOT)
    with pytest.raises(ConfigurationError, match="expected 'paper'"):
        pressure_map("linear", ROBOT)
    calibration = calibration_from_values(values(), ROBOT)
    other = dataclasses.replace(calibration, joint_names=tuple(reversed(NAMES)))
    with pytest.raises(ConfigurationError, match="expected the robot's joints"):
        CalibratedPressureMap(other, ROBOT)


def test_the_file_is_plain_yaml_with_the_documented_keys(tmp_path):
    path = tmp_path / "c.yaml"
    save_calibration(calibration_from_values(values(), ROBOT, info={"rig": "sim"}), path)
    data = yaml.safe_load(path.read_text())["muscle_calibration"]
    assert data["rig"] == "sim" and set(data["muscles"]) == set(NAMES)
    assert data["muscles"]["m2_pma1"] == ODD_MUSCLE
