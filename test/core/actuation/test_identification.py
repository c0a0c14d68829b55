"""Identification: step and chirp plans, the static and dynamic fits, and a whole run on the mock muscles."""

import dataclasses
import math
import warnings

import numpy as np
import pytest
from srs_testing import ManualClock

from srs_ros.backends.mock import MockBackend
from srs_ros.core.actuation.identification import (
    chirp_plan,
    fit_line_dynamics,
    fit_static_characteristic,
    identify,
    read_length_table,
    run_plan,
    step_plan,
)
from srs_ros.core.actuation.muscle_model import MuscleModel, muscle_parameters_from_options
from srs_ros.core.errors import ConfigurationError, FitError
from srs_ros.core.robot import default_robot
from srs_ros.tools.identify import BackendIO

ROBOT = default_robot()


def test_a_step_plan_starts_vented_and_vents_after_every_step():
    plan = step_plan(9, 100.0, [1.0, 3.0], hold_s=0.5, vent_s=0.2, groups=[[0], [4, 5]])
    assert [(s.joints, s.level_bar) for s in plan.steps] == [((0,), 1.0), ((0,), 3.0), ((4, 5), 1.0), ((4, 5), 3.0)]
    assert plan.duration_s == pytest.approx(0.2 + 4 * 0.7, abs=0.011)
    assert np.all(plan.pressure_bar[plan.times_s < 0.2 - 1e-9] == 0.0)
    for step in plan.steps:
        held = (plan.times_s >= step.start_s - 1e-9) & (plan.times_s < step.end_s - 1e-9)
        after = (plan.times_s >= step.end_s - 1e-9) & (plan.times_s < step.end_s + 0.2 - 1e-9)
        assert np.all(plan.pressure_bar[held][:, step.joints] == step.level_bar)
        assert np.count_nonzero(plan.pressure_bar[held]) == held.sum() * len(step.joints)  # only its joints
        assert after.sum() >= 19 and np.all(plan.pressure_bar[after] == 0.0)  # then vented
        assert step.settled_s == pytest.approx(step.end_s - 0.25 * 0.5)
    assert plan.pressure_bar[-1].max() == 0.0


def test_a_chirp_stays_in_its_range_and_starts_at_the_low_end():
    plan = chirp_plan(9, 200.0, [[2]], 1.0, 3.0, 0.2, 4.0, duration_s=5.0, vent_s=0.5)
    driven = plan.pressure_bar[:, 2]
    on = driven > 0
    assert driven[on][0] == pytest.approx(1.0) and driven.max() <= 3.0 and driven[on].min() >= 1.0 - 1e-12
    assert np.count_nonzero(plan.pressure_bar[:, [0, 1, 3, 4, 5, 6, 7, 8]]) == 0 and plan.steps == ()


def test_the_static_fit_finds_deadzone_gain_and_a_knee_it_has_seen():
    pressure = np.arange(0.25, 4.01, 0.25)
    length = 0.02 * np.clip(pressure - 0.9, 0.0, 3.2 - 0.9)  # saturates at 3.2 bar
    fit = fit_static_characteristic(pressure + 0.001 * np.sin(7 * pressure), length)
    assert fit.deadzone_bar == pytest.approx(0.9, abs=0.02) and fit.extension_per_bar_m == pytest.approx(0.02, rel=0.02)
    assert fit.saturation_seen and fit.saturation_bar == pytest.approx(3.2, abs=0.03)
    linear = fit_static_characteristic(pressure, 0.02 * np.clip(pressure - 0.9, 0.0, None), tested_bar=4.0)
    assert not linear.saturation_seen and linear.saturation_bar == 4.0  # no knee up to the highest pressure


def test_the_static_fit_refuses_a_muscle_that_barely_extends():
    with pytest.raises(FitError, match="m1_pma3: extended at 1 distinct pressure"):
        fit_static_characteristic([0.5, 1.0, 2.0], [0.0, 0.0, 0.004], where="m1_pma3")


def test_the_dynamics_fit_recovers_delay_and_lag_from_the_model_it_inverts():
    params = muscle_parameters_from_options({"transport_delay_s": 0.07, "pressure_time_constant_s": 0.15}, ROBOT, "t")
    model = MuscleModel(params, 1)
    command_s = np.arange(0, 4.0, 0.01)
    command = np.where((command_s % 1.0) < 0.6, 1.0 + 2.0 * (command_s // 1.0 % 2), 0.0)
    samples = []
    for t, p in zip(command_s, command):
        model.command([p], t)
        samples.append(model.state(t + 0.004)[0][0])  # read a little after each command
    fit = fit_line_dynamics(command_s, command, command_s + 0.004, np.array(samples))
    assert fit.transport_delay_s == pytest.approx(0.07, rel=0.03)
    assert fit.pressure_time_constant_s == pytest.approx(0.15, rel=0.03)
    with pytest.raises(FitError, match="does not follow"):
        fit_line_dynamics(command_s, command, command_s, np.zeros(len(command_s)), where="m1_pma1")


MUSCLES = {"pressure_time_constant_s": 0.1, "transport_delay_s": 0.05, "deadzone_bar": 0.8, "max_extension_m": 0.055,
           "per_muscle": {"m2_pma1": {"deadzone_bar": 1.3, "transport_delay_s": 0.12,
                                      "pressure_time_constant_s": 0.16, "max_extension_m": 0.07}}}


def test_identification_on_the_mock_rig_recovers_each_muscle_within_20_percent():
    clock = ManualClock()
    with MockBackend(ROBOT, MUSCLES, clock=clock) as backend:
        plan = step_plan(9, 200.0, [0.5, 1.0, 1.5, 2.5, 3.5, 4.0], 1.2, 0.5, [[0, 3, 8]])
        recording = run_plan(BackendIO(backend, clock, clock.sleep), plan)
    found = identify(ROBOT, [0, 3, 8], recording, plan)
    assert set(found.values) == {"m1_pma1", "m2_pma1", "m3_pma3"} and not found.warnings
    expected = {"m1_pma1": (0.8, 0.055 / 3.2, 0.05, 0.1), "m3_pma3": (0.8, 0.055 / 3.2, 0.05, 0.1),
                "m2_pma1": (1.3, 0.07 / 2.7, 0.12, 0.16)}
    for name, (deadzone, gain, delay, tau) in expected.items():
        got = found.values[name]
        assert got["deadzone_bar"] == pytest.approx(deadzone, rel=0.2)
        assert got["extension_per_bar_m"] == pytest.approx(gain, rel=0.2)
        assert got["transport_delay_s"] == pytest.approx(delay, rel=0.2)
        assert got["pressure_time_constant_s"] == pytest.approx(tau, rel=0.2)
        assert got["saturation_bar"] == 4.0  # linear up to the highest level tested


def test_identification_from_a_chirp():
    clock = ManualClock()
    with MockBackend(ROBOT, MUSCLES, clock=clock) as backend:
        plan = chirp_plan(9, 200.0, [[3]], 1.0, 3.0, 0.2, 4.0, duration_s=6.0, vent_s=0.5)
        said = []  # how far the run is, every PROGRESS_EVERY_S (a chirp has no steps to announce: 95 s went silent)
        recording = run_plan(BackendIO(backend, clock, clock.sleep), plan.then(plan).then(plan),
                             on_progress=said.append)
        recording = run_plan(BackendIO(backend, clock, clock.sleep), plan)
    assert said == pytest.approx([10.0, 20.0], abs=0.006), said
    found = identify(ROBOT, [3], recording, plan, static=False)
    assert found.values["m2_pma1"]["transport_delay_s"] == pytest.approx(0.12, rel=0.05)
    assert found.values["m2_pma1"]["pressure_time_constant_s"] == pytest.approx(0.16, rel=0.05)


def test_a_short_hold_is_reported_not_hidden():
    clock = ManualClock()
    with MockBackend(ROBOT, MUSCLES, clock=clock) as backend:
        plan = step_plan(9, 200.0, [0.5, 1.5, 2.5, 4.0], 0.3, 0.3, [[3]])
        recording = run_plan(BackendIO(backend, clock, clock.sleep), plan)
    assert any("m2_pma1: still moving" in w and "--hold-s" in w
               for w in identify(ROBOT, [3], recording, plan, dynamics=False).warnings)


def test_a_ruler_table_gives_the_static_characteristic(tmp_path):
    table = tmp_path / "ruler.csv"
    rows = [f"{name},{p},{0.02 * max(p - 1.1, 0.0)}" for name in ROBOT.joint_names for p in (0.5, 1.5, 2.5, 3.5)]
    table.write_text("joint,pressure_bar,length_m\n" + "\n".join(rows) + "\n")
    found = identify(ROBOT, range(9), static=True, dynamics=False, length_table=read_length_table(table, ROBOT))
    assert found.values["m3_pma2"]["deadzone_bar"] == pytest.approx(1.1, abs=1e-3)
    assert found.values["m3_pma2"]["saturation_bar"] == pytest.approx(3.5)
    bad = tmp_path / "bad.csv"
    bad.write_text("joint,pressure_bar,length_m\nm1_pma1,2.0,0.02\nm9_pma1,2.0,0.02\n")
    with pytest.raises(ConfigurationError, match=r"bad.csv:3: joint is 'm9_pma1'; expected one of \['m1_pma1', "):
        read_length_table(bad, ROBOT)


@pytest.mark.parametrize(("text", "refusal"), [
    ("muscle,bar,m\n", "bad.csv: the header line is 'muscle,bar,m'; expected joint,pressure_bar,length_m (in any "
                       "order)."),
    ("joint,pressure_bar,length_m\nm1_pma1,2.0,0.02\nm1_pma1,9.0,0.02\n",
     "bad.csv:3: pressure_bar is 9.0; expected a number in [0, 4] (bar)."),
    ("pressure_bar,joint,length_m\n2.0,m1_pma1,abc\n", "bad.csv:2: length_m is 'abc'; expected a number in "
                                                     "[-0.005, 0.195] (m)."),
    ("joint,pressure_bar,length_m\nm1_pma1,nan,0.02\n", "bad.csv:2: pressure_bar is nan; expected a number in [0, 4]"),
    ("joint,pressure_bar,length_m\nm1_pma1,2.0\n", "bad.csv:2: the row is 'm1_pma1,2.0'; expected 3 cells, one a "
                                                "column."),
    # A length typed in cm (a helper's review: it failed later naming the output file), or a sign lost.
    ("joint,pressure_bar,length_m\nm1_pma1,2.0,0.02\nm1_pma1,3.0,60\n", "bad.csv:3: length_m is 60.0; expected a "
                                                                      "number in [-0.005, 0.195] (m)."),
    ("joint,pressure_bar,length_m\nm1_pma1,2.0,-0.06\n", "bad.csv:2: length_m is -0.06; expected a number in "),
    ("joint,pressure_bar,length_m\nm1_pma1,2.0,0.02,7\n", "bad.csv:2: the row is 'm1_pma1,2.0,0.02,7'; expected 3 "
                                                      "cells, one a column."),
])
def test_a_bad_value_in_a_ruler_table_is_refused_with_file_line_column_and_what_is_expected(tmp_path, text, refusal):
    bad = tmp_path / "bad.csv"
    bad.write_text(text)
    with pytest.raises(ConfigurationError) as refused:
        read_length_table(bad, ROBOT)
    assert str(refused.value).startswith(f"{bad.parent}/{refusal}")


def test_a_muscle_whose_length_was_never_read_is_said_so():
    """All-NaN lengths warned "Mean of empty slice" and failed as 'extended at 0 distinct pressure(s)'."""
    clock = ManualClock()
    with MockBackend(ROBOT, MUSCLES, clock=clock) as backend:
        plan = step_plan(9, 200.0, [0.5, 1.5, 2.5, 4.0], 0.6, 0.3, [[3]])
        recording = run_plan(BackendIO(backend, clock, clock.sleep), plan)
    recording.length_m[:, 3] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(FitError, match="m2_pma1: no length was measured"):
            identify(ROBOT, [3], recording, plan, dynamics=False)


def test_a_read_back_dated_before_its_command_is_warned_of_not_fitted_as_no_delay():
    """A read-back dated 0.05 s early fitted delay 0 and a wrong tau without a word (a helper's review)."""
    clock = ManualClock()
    with MockBackend(ROBOT, MUSCLES, clock=clock) as backend:
        plan = step_plan(9, 200.0, [0.5, 1.5, 2.5, 4.0], 0.6, 0.3, [[0]])
        recording = run_plan(BackendIO(backend, clock, clock.sleep), plan)
    found = identify(ROBOT, [0], recording, plan, static=False)
    assert found.values["m1_pma1"]["transport_delay_s"] == pytest.approx(0.05, rel=0.2) and not found.warnings
    early = dataclasses.replace(recording, sample_s=recording.sample_s - 0.1)  # dated 0.1 s early: -0.05 s delay
    said = identify(ROBOT, [0], early, plan, static=False).warnings
    assert len(said) == 1 and said[0].startswith("m1_pma1: the dynamics fit put the delay at 0 s"), said


def test_dynamics_need_a_pressure_read_back():
    plan = step_plan(9, 100.0, [1.0, 2.0, 3.0], 0.3, 0.2, [[0]])
    with pytest.raises(ConfigurationError, match="pressure read-back"):
        identify(ROBOT, [0], None, plan, static=False)


def test_the_run_records_what_was_sent_through_the_clamp():
    clock = ManualClock()
    with MockBackend(ROBOT, {}, clock=clock) as backend:
        plan = step_plan(9, 50.0, [2.0], 0.2, 0.1, [[1]])
        recording = run_plan(BackendIO(backend, clock, clock.sleep), plan)
    assert recording.command_bar.shape == plan.pressure_bar.shape
    assert np.array_equal(recording.command_bar, plan.pressure_bar)
    assert recording.command_s == pytest.approx(plan.times_s)
    assert recording.length_m is not None and 1.5 < recording.pressure_bar[:, 1].max() < 2.0  # lagging toward 2
    assert not np.any(recording.pressure_bar[:, [0, *range(2, 9)]]) and math.isclose(recording.sample_s[0], 0.0)
