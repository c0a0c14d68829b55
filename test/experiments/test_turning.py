"""The turning experiments: a short run measures turn and travel; the turn map they write reads back."""

import math

import numpy as np
import pytest
import yaml

from srs_ros.core.errors import ConfigurationError
from srs_ros.core.navigation.settings import DIRECTIONS, STOP_PHASES, turning_map_from_dict
from srs_ros.core.robot import default_robot
from srs_ros.experiments.turning import (
    TurnMeasurement,
    cone_scales,
    measure_turn_phase,
    play_cycle,
    rolling_cycle,
    turning_map_yaml,
)
from srs_ros.sim.config import load_sim_config


def test_a_short_run_measures_turn_and_travel():
    (run,) = measure_turn_phase("inward_rolling", 4.0, 1.0, 0.35, cycles=3, skip_cycles=1, start_yaws_rad=(0.0,))
    assert run.label == "inward_rolling" and run.value == 0.35
    assert math.isfinite(run.turn_deg_per_cycle) and 0.02 < run.travel_m_per_cycle < 0.2
    assert run.speed_m_s == run.travel_m_per_cycle


def test_a_run_that_does_not_end_on_a_sample_still_measures_its_last_cycle():
    """At 0.7 Hz, 3 cycles end at 4.286 s, between two 0.05 s samples: the last cycle was lost and, with the first two
    left out, every figure was NaN (srs_turning printed +nan rows; a helper's review)."""
    (run,) = measure_turn_phase("inward_rolling", 4.0, 0.7, 0.35, cycles=3, skip_cycles=2, start_yaws_rad=(0.0,))
    assert math.isfinite(run.turn_deg_per_cycle) and math.isfinite(run.travel_m_per_cycle)
    rows = play_cycle(rolling_cycle(4.0, 0.7, 0.0), 3 / 0.7, load_sim_config(), default_robot())
    assert rows[-1, 0] == pytest.approx(3 / 0.7, abs=0.005)  # the end is recorded


def test_a_switch_to_another_cycle_changes_the_run_from_the_switch_on_only():
    """bench_level_change.py's change of turn level: the player cross-fades to the other cycle at the switch."""
    robot = default_robot()
    config = load_sim_config(robot=robot)
    straight, turning = (rolling_cycle(4.0, 1.0, level, robot) for level in (0.0, 0.35))
    kept = play_cycle(straight, 2.0, config, robot, sample_every_s=0.1)
    switched = play_cycle(straight, 2.0, config, robot, sample_every_s=0.1, switch_to=(1.0, turning))
    before, after = kept[:, 0] < 1.0, kept[:, 0] > 1.6
    np.testing.assert_array_equal(switched[before], kept[before])  # the same run until the switch
    assert np.max(np.abs(switched[after, 1:3] - kept[after, 1:3])) > 0.005  # m: another gait after it


def test_the_written_turn_map_reads_back():
    runs = {d: [TurnMeasurement(d, 4.0, 1.0, v, yaw, 10.0 * v + yaw, 1.0, 0.1) for v in (-0.2, 0.2)
                for yaw in (0.0, 2.0)] for d in DIRECTIONS}
    stops = {d: np.full((len(STOP_PHASES), 2), 0.1) for d in DIRECTIONS}
    mapped = turning_map_from_dict(yaml.safe_load(turning_map_yaml(runs, stops, 4.0, 1.0, "test")), "written")
    np.testing.assert_allclose(mapped["inward_rolling"].turn_rate_deg_per_cycle, [-1.0, 3.0])
    np.testing.assert_allclose(mapped["outward_rolling"].stop_offset_m, 0.1)
    stops["inward_rolling"][0, 0] = np.nan  # a stop never measured: refused, not written as the text 'nan'
    with pytest.raises(ConfigurationError, match="the turn map to be written: turning_map.inward_rolling.stop_off"):
        turning_map_yaml(runs, stops, 4.0, 1.0, "test")


def test_cone_scales_grow_toward_the_head_and_peak_at_one():
    assert np.allclose(cone_scales(1.0), (1 / 3, 2 / 3, 1.0))
    assert np.allclose(cone_scales(-1.0), (1.0, 2 / 3, 1 / 3))
