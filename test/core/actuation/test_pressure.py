"""Length -> pressure -> volts through the one clamp (docs/conventions.md, Pressure map)."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from srs_ros.core.actuation.pressure import (
    clamp_pressures_bar,
    command_v_to_pressures_bar,
    lengths_to_pressures_bar,
    pressure_amplitude_scale,
    pressures_to_command_v,
    pressures_to_lengths_m,
)
from srs_ros.core.errors import InvalidInputError
from srs_ros.core.rig import load_rig, rig_from_dict
from srs_ros.core.robot import default_robot

ROBOT = default_robot()


def test_paper_pressure_map_and_itv3050_volts():
    lengths = np.array([0.0, 0.01, 0.02, 0.03, 0.04, 0.05, 0.065, -0.01, 0.015])
    pressure = lengths_to_pressures_bar(lengths)
    assert pressure == pytest.approx([0, 1, 2, 3, 4, 4, 4, 0, 1.5])
    volts = pressures_to_command_v(pressure)
    assert volts[4] == pytest.approx(40 / 9)  # 4 bar on a 9 bar regulator: 4.444 V
    assert volts == pytest.approx(pressure * 10 / 9)


@given(arrays(np.float64, 9, elements=st.floats(-1e6, 1e6)))
def test_clamp_never_lets_a_value_out(pressure):
    clamped = clamp_pressures_bar(pressure)
    assert np.all(clamped >= 0) and np.all(clamped <= 4.0)
    volts = pressures_to_command_v(pressure)
    assert np.all(volts >= 0) and np.all(volts <= 10 * 4.0 / 9.0 + 1e-12)


@pytest.mark.parametrize("bad", [np.full(9, np.nan), np.r_[np.zeros(8), np.inf], np.zeros(8), np.zeros(10)])
def test_clamp_rejects_nan_and_wrong_sizes(bad):
    with pytest.raises(InvalidInputError, match="pressure_bar"):
        clamp_pressures_bar(bad)
    with pytest.raises(InvalidInputError):
        pressures_to_command_v(bad)


def test_deadzone_offset_applies_only_to_extending_actuators():
    robot = dataclasses.replace(ROBOT, deadzone_offset_bar=1.0)
    pressure = lengths_to_pressures_bar(np.r_[0.0, 0.005, 0.035, np.zeros(6)], robot)
    assert pressure[:3] == pytest.approx([0.0, 1.5, 4.0])
    assert pressures_to_lengths_m(pressure, robot)[:2] == pytest.approx([0.0, 0.005])


def test_command_round_trip_and_other_regulator():
    pressure = np.linspace(0, 4, 9)
    assert command_v_to_pressures_bar(pressures_to_command_v(pressure)) == pytest.approx(pressure)
    rig = rig_from_dict({"rig": {"name": "r", "backend": "mock", "regulator_model": "ITV3030",
                                 "command_rate_hz": 100, "setpoint_timeout_s": 0.2}})
    assert pressures_to_command_v(np.full(9, 4.0), rig.robot) == pytest.approx(np.full(9, 8.0))


def test_amplitude_scale():
    cycle = np.tile(np.linspace(0, 0.02, 9), (4, 1))
    scale = pressure_amplitude_scale(cycle, 3.0)
    assert lengths_to_pressures_bar(cycle * scale).max() == pytest.approx(3.0)
    with pytest.raises(InvalidInputError, match=r"amplitude_bar is 4.5; expected a number in \(0, 4\] \(bar\)"):
        pressure_amplitude_scale(cycle, 4.5)


def test_shipped_mock_rig():
    rig = load_rig()
    assert rig.backend == "mock" and rig.setpoint_timeout_s == 0.2 and rig.robot.regulator.name == "ITV3050"


def test_rig_regulator_keeps_a_lowered_pressure_limit():
    lowered = dataclasses.replace(ROBOT, max_pressure_bar=2.0)
    rig = rig_from_dict({"rig": {"name": "r", "backend": "mock", "regulator_model": "ITV3030",
                                 "command_rate_hz": 100, "setpoint_timeout_s": 0.2}}, lowered)
    assert rig.robot.regulator.name == "ITV3030" and rig.robot.max_pressure_bar == 2.0
    assert clamp_pressures_bar(np.full(9, 3.0), rig.robot) == pytest.approx(np.full(9, 2.0))
