"""The simulated muscles: deadzone, saturating extension, first-order lag and transport delay."""

import math

import numpy as np
import pytest

from srs_ros.core.actuation.muscle_model import (
    MUSCLE_OPTION_DEFAULTS,
    MuscleModel,
    MuscleParameters,
    extension_m,
    lag_step,
    muscle_parameters_from_options,
)
from srs_ros.core.errors import ConfigurationError
from srs_ros.core.robot import default_robot

PARAMS = MuscleParameters(deadzone_bar=1.0, pressure_time_constant_s=0.1, transport_delay_s=0.05,
                          max_extension_m=0.065, full_extension_pressure_bar=4.0)


def test_extension_has_a_deadzone_and_saturates_at_max_extension():
    pressure = np.array([0.0, 0.9, 1.0, 2.5, 4.0, 6.0])
    assert extension_m(pressure, PARAMS) == pytest.approx([0.0, 0.0, 0.0, 0.0325, 0.065, 0.065])


def test_lag_step_is_the_exact_first_order_response():
    after = lag_step(np.zeros(2), np.array([4.0, 2.0]), dt_s=0.1, time_constant_s=0.1)
    assert after == pytest.approx(np.array([4.0, 2.0]) * (1 - math.exp(-1)))
    assert lag_step(np.zeros(2), np.full(2, 3.0), 0.01, 0.0) == pytest.approx([3.0, 3.0])  # no lag


def test_a_flow_limited_muscle_ramps_at_its_rate_then_closes_in_exponentially():
    # 0 -> 4 bar with tau 0.1 s and at most 5 bar/s: a ramp until 0.5 bar short (at 0.7 s), then the lag.
    ramp = lag_step(np.zeros(2), np.array([4.0, 0.2]), dt_s=0.4, time_constant_s=0.1, max_rate_bar_per_s=5.0)
    assert ramp == pytest.approx([2.0, 0.2 * (1 - math.exp(-4))])  # the small step is not rate-limited
    after = lag_step(np.zeros(1), np.array([4.0]), dt_s=0.8, time_constant_s=0.1, max_rate_bar_per_s=5.0)
    assert after == pytest.approx([4.0 - 0.5 * math.exp(-1)])
    venting = lag_step(np.full(1, 4.0), np.zeros(1), dt_s=0.2, time_constant_s=0.0, max_rate_bar_per_s=5.0)
    assert venting == pytest.approx([3.0]) and lag_step(venting, np.zeros(1), 1.0, 0.0, 5.0) == pytest.approx([0.0])
    # In pieces or at once: the same exact solution.
    pieces = np.zeros(1)
    for _ in range(80):
        pieces = lag_step(pieces, np.array([4.0]), 0.01, 0.1, 5.0)
    assert pieces == pytest.approx(after)


def test_a_flow_limit_shrinks_a_fast_swing_and_not_a_slow_one():
    limited = muscle_parameters_from_options({"max_pressure_rate_bar_per_s": 5.0}, default_robot(), "test")
    swings = {}
    for frequency_hz in (0.25, 1.0):
        model = MuscleModel(limited, 1)
        times = np.arange(0.0, 8.0, 0.01)
        seen = []
        for t in times:
            model.command(np.array([2.0 - 2.0 * math.cos(2 * math.pi * frequency_hz * t)]), t)
            seen.append(model.state(t)[0][0])
        swings[frequency_hz] = np.ptp(seen[len(seen) // 2:])
    assert swings[0.25] > 3.8 and swings[1.0] < 0.7 * swings[0.25]


def test_a_command_arrives_after_the_transport_delay_then_lags():
    model = MuscleModel(PARAMS, count=9, start_s=10.0)
    model.command(np.full(9, 4.0), now_s=10.0)
    pressure, length = model.state(10.049)
    assert pressure == pytest.approx(np.zeros(9))  # still in the supply line
    pressure, _ = model.state(10.15)  # one time constant after arrival
    assert pressure == pytest.approx(np.full(9, 4.0 * (1 - math.exp(-1))))
    pressure, length = model.state(12.0)
    assert pressure == pytest.approx(np.full(9, 4.0)) and length == pytest.approx(np.full(9, 0.065))


def test_integration_does_not_depend_on_how_often_it_is_read():
    coarse, fine = MuscleModel(PARAMS, 9), MuscleModel(PARAMS, 9)
    for step in range(50):
        t = step * 0.01
        command = np.full(9, 2.0 + math.sin(step / 5.0))
        coarse.command(command, t)
        fine.command(command, t)
        fine.state(t + 0.005)
    assert coarse.state(0.6)[0] == pytest.approx(fine.state(0.6)[0])


def test_vent_brings_muscles_back_to_rest():
    model = MuscleModel(PARAMS, 9)
    model.command(np.full(9, 3.0), 0.0)
    model.command(np.zeros(9), 1.0)
    pressure, length = model.state(3.0)
    assert np.all(pressure < 1e-3) and np.all(length == 0.0)


def test_parameters_from_options_fill_defaults_from_the_robot_and_the_shared_defaults():
    robot = default_robot()
    params = muscle_parameters_from_options({}, robot, "test")
    assert params.deadzone_bar == robot.deadzone_bar and params.max_extension_m == robot.max_extension_m
    assert params.full_extension_pressure_bar == robot.max_pressure_bar
    assert params.pressure_time_constant_s == MUSCLE_OPTION_DEFAULTS["pressure_time_constant_s"]
    assert params.transport_delay_s == MUSCLE_OPTION_DEFAULTS["transport_delay_s"]
    assert muscle_parameters_from_options({"transport_delay_s": 0.1}, robot, "test").transport_delay_s == 0.1


@pytest.mark.parametrize(("options", "key"), [
    ({"pressure_time_constant_s": -0.1}, "pressure_time_constant_s"),
    ({"transport_delay_s": True}, "transport_delay_s"),
    ({"deadzone_bar": 4.0}, "deadzone_bar"),
    ({"lag_s": 0.1}, "lag_s"),
])
def test_bad_muscle_options_name_where_the_key_and_the_value(options, key):
    with pytest.raises(ConfigurationError, match=f"^sim.yaml: sim.muscles.{key} is "):
        muscle_parameters_from_options(options, default_robot(), "sim.yaml", path="sim.muscles")
