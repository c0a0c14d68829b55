"""Lag compensation: leads the delay, inverts the lag, never leaves the one clamp, says when it is cut."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from srs_ros.core.actuation.compensation import (
    LineDynamics,
    SetpointShaper,
    compensated_pressures_bar,
    setpoint_shaper,
)
from srs_ros.core.actuation.muscle_calibration import (
    CalibratedPressureMap,
    PaperPressureMap,
    calibration_from_values,
    save_calibration,
)
from srs_ros.core.actuation.muscle_model import MuscleModel, muscle_parameters_from_options
from srs_ros.core.errors import ConfigurationError, InvalidInputError
from srs_ros.core.gait.playback import GaitPlayback
from srs_ros.core.gait.trajectory import generate_cycle
from srs_ros.core.robot import default_robot

ROBOT = default_robot()
NAMES = ROBOT.joint_names
DYNAMICS = LineDynamics(np.full(9, 0.03), np.full(9, 0.08))
SIM = {"deadzone_bar": 1.0, "extension_per_bar_m": 0.065 / 3.0, "saturation_bar": 4.0,
       "transport_delay_s": 0.03, "pressure_time_constant_s": 0.08}
CALIBRATION = calibration_from_values({name: SIM for name in NAMES}, ROBOT)
CALIBRATED = CalibratedPressureMap(CALIBRATION, ROBOT)


def test_the_docstring_example_leads_the_delay_and_inverts_the_lag():
    pressure, cut = compensated_pressures_bar(PaperPressureMap(ROBOT), DYNAMICS, np.full(9, 0.02), np.full(9, 0.1))
    assert pressure == pytest.approx(np.full(9, 2.3 + 0.08 * 100 * 0.1))  # 3.1 bar
    assert not cut.any()


def test_a_lead_beyond_the_limit_is_cut_to_4_bar_and_counted():
    shaper = SetpointShaper(CALIBRATED, DYNAMICS, compensation=True)
    rising = shaper.pressures_bar(np.full(9, 0.06), np.full(9, 0.3), 0.0)  # wants 3.77 + 0.11 + 1.1 bar
    assert rising == pytest.approx(np.full(9, 4.0)) and shaper.compensation_clamped == 1
    falling = shaper.pressures_bar(np.full(9, 0.01), np.full(9, -0.3), 0.005)  # wants below 0 bar
    assert falling == pytest.approx(np.zeros(9)) and shaper.compensation_clamped == 2
    shaper.compensation = False
    assert shaper.pressures_bar(np.full(9, 0.06), np.full(9, 0.3), 0.01) == pytest.approx(
        CALIBRATED.pressures_bar(np.full(9, 0.06)))  # off: the map alone, nothing counted
    assert shaper.compensation_clamped == 2


def test_without_velocities_the_shaper_differences_successive_setpoints():
    shaper = SetpointShaper(CALIBRATED, DYNAMICS, compensation=True)
    ramp = [shaper.pressures_bar(np.full(9, 0.01 + 0.02 * t), None, t) for t in (0.0, 0.005, 0.010)]
    analytic, _ = compensated_pressures_bar(CALIBRATED, DYNAMICS, np.full(9, 0.0102), np.full(9, 0.02))
    assert ramp[2] == pytest.approx(analytic)
    assert ramp[0] == pytest.approx(CALIBRATED.pressures_bar(np.full(9, 0.01)))  # first setpoint: no rate yet
    after_gap = shaper.pressures_bar(np.full(9, 0.03), None, 5.0)  # a pause is no velocity
    assert after_gap == pytest.approx(CALIBRATED.pressures_bar(np.full(9, 0.03)))


finite_lengths = st.floats(min_value=-1e300, max_value=1e300, allow_nan=False)
small_lengths = st.floats(min_value=-0.02, max_value=0.1, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(lengths=st.lists(st.one_of(small_lengths, finite_lengths), min_size=9, max_size=9),
       velocities=st.lists(st.floats(min_value=-1e300, max_value=1e300, allow_nan=False), min_size=9, max_size=9),
       delay=st.floats(0.0, 2.0), tau=st.floats(0.0, 10.0), calibrated=st.booleans())
def test_never_outside_0_to_4_bar_or_non_finite_whatever_the_setpoint(lengths, velocities, delay, tau, calibrated):
    pressure_map = CALIBRATED if calibrated else PaperPressureMap(ROBOT)
    pressure, cut = compensated_pressures_bar(pressure_map, LineDynamics(np.full(9, delay), np.full(9, tau)),
                                              lengths, velocities)
    assert pressure.shape == (9,) and np.all(np.isfinite(pressure))
    assert np.all((pressure >= 0.0) & (pressure <= 4.0))
    assert not np.any(cut & (pressure > 0.0) & (pressure < 4.0))  # a cut is always at a limit


@settings(max_examples=100, deadline=None)
@given(steps=st.lists(st.tuples(st.one_of(st.floats(-0.1, 0.2), finite_lengths), st.floats(1e-6, 0.05)), min_size=2,
                      max_size=20))
def test_steps_without_velocities_stay_in_the_clamp(steps):
    shaper = SetpointShaper(CALIBRATED, DYNAMICS, compensation=True)
    now_s = 0.0
    for length_m, dt_s in steps:
        now_s += dt_s
        pressure = shaper.pressures_bar(np.full(9, length_m), None, now_s)
        assert np.all(np.isfinite(pressure)) and np.all((pressure >= 0.0) & (pressure <= 4.0))


def test_a_huge_finite_setpoint_without_velocities_is_limited_and_the_next_one_taken():
    """A length of 1e308 m differenced 10 ms after 2 cm was an infinite rate: refused as an unexpected error, and the
    setpoint after it refused too (a safety review). It is limited like any finite length instead."""
    shaper = SetpointShaper(CALIBRATED, DYNAMICS, compensation=True)
    shaper.pressures_bar(np.full(9, 0.02), None, 0.0)
    assert np.all(shaper.pressures_bar(np.full(9, 1e308), None, 0.01) == 4.0)
    after = shaper.pressures_bar(np.full(9, 0.03), None, 0.02)  # a fall from the limit: the lead vents
    assert np.all((after >= 0.0) & (after < 4.0))
    steady = shaper.pressures_bar(np.full(9, 0.03), None, 0.03)
    assert steady == pytest.approx(CALIBRATED.pressures_bar(np.full(9, 0.03)))


def test_non_finite_setpoints_are_refused_not_sent():
    shaper = SetpointShaper(CALIBRATED, DYNAMICS, compensation=True)
    with pytest.raises(InvalidInputError, match="finite"):
        shaper.pressures_bar(np.full(9, 0.02), np.r_[math.inf, np.zeros(8)], 0.0)
    with pytest.raises(InvalidInputError, match="shape"):
        shaper.pressures_bar(np.full(8, 0.02), None, 0.0)


def test_compensation_needs_the_dynamics_and_says_how_to_get_them():
    shaper = SetpointShaper(CALIBRATED)
    assert "srs_identify" in shaper.compensation_refusal()
    with pytest.raises(ConfigurationError, match="compensation_delay_s"):
        shaper.compensation = True


def test_the_shaper_from_the_node_parameters(tmp_path):
    path = tmp_path / "cal.yaml"
    save_calibration(CALIBRATION, path)
    shaper = setpoint_shaper(ROBOT, "calibrated", str(path), compensation=True)
    assert shaper.map.name == "calibrated" and shaper.dynamics.transport_delay_s == pytest.approx(np.full(9, 0.03))
    paper = setpoint_shaper(ROBOT, "paper", str(path), delay_s=0.05)  # the paper's map, the calibrated lag
    assert paper.map.name == "paper" and paper.dynamics.transport_delay_s == pytest.approx(np.full(9, 0.05))
    assert paper.dynamics.pressure_time_constant_s == pytest.approx(np.full(9, 0.08))
    assert setpoint_shaper(ROBOT, "paper").dynamics is None
    with pytest.raises(ConfigurationError, match="calibration_file is empty"):
        setpoint_shaper(ROBOT, "calibrated")
    with pytest.raises(ConfigurationError, match="lag compensation needs"):
        setpoint_shaper(ROBOT, "paper", compensation=True)


def _rms_length_error_m(shaper: SetpointShaper, frequency_hz: float) -> float:
    """Inward rolling through the player and the shaper into the simulated muscles; RMS after 2 cycles."""
    params = muscle_parameters_from_options({}, ROBOT, "test")  # the simulated rig's muscles
    muscles = MuscleModel(params, 9)
    player = GaitPlayback(ramp_time_s=0.5, max_length_m=ROBOT.max_extension_m)
    player.load(generate_cycle("inward_rolling", 4.0, frequency_hz, 64).lengths_m, frequency_hz)
    player.start()
    errors, rate_hz = [], 200.0
    for k in range(int(4.0 / frequency_hz * rate_hz)):
        t = k / rate_hz
        setpoint = player.step(1.0 / rate_hz)
        muscles.command(shaper.pressures_bar(setpoint.positions_m, setpoint.velocities_m_per_s, t), t)
        if t >= 0.5 + 2.0 / frequency_hz:
            errors.append(setpoint.positions_m - muscles.state(t)[1])
    return float(np.sqrt(np.mean(np.square(errors))))


def test_at_1_hz_compensation_more_than_halves_the_length_error_of_the_calibrated_map():
    without = _rms_length_error_m(SetpointShaper(CALIBRATED, DYNAMICS), 1.0)
    with_lead = _rms_length_error_m(SetpointShaper(CALIBRATED, DYNAMICS, compensation=True), 1.0)
    paper = _rms_length_error_m(SetpointShaper(PaperPressureMap(ROBOT)), 1.0)
    assert with_lead < 0.5 * without < 0.5 * paper
