"""The trend figures of a sweep (srs_ros.experiments.fidelity) on records built by hand."""

from __future__ import annotations

import math

import numpy as np

from srs_ros.experiments.fidelity import Count, cycle_motion, fidelity_figures, travel_side, trend_counts
from srs_ros.experiments.table import RunRecord, paper_table

PAPER = paper_table()


def _record(gait, amplitude, frequency, speed_cm_s, track=None):
    return RunRecord(gait, amplitude, frequency, speed_cm_s, 0.0, speed_cm_s * 0.15, 0.0, track=track)


def _paper_records():
    return [_record(*cell, PAPER.speed_cm_s(cell)) for cell in PAPER.cells]


def test_the_paper_itself_has_every_trend_and_every_cell_within_the_factor():
    figures = fidelity_figures(_paper_records(), PAPER)
    assert figures.amplitude_trend == Count(8, 8)
    assert figures.cycle_distance_trend == Count(6, 6)
    assert figures.inward_faster == Count(12, 12)
    assert figures.within_factor == Count(24, 24) and figures.rms_log == 0.0
    assert figures.still_cells == Count(12, 12)
    top = max(PAPER.speed_cm_s(c) for c in PAPER.cells if c[0] == "serpentine")
    assert math.isclose(figures.serpentine_top_cm_s, top)


def test_a_rolling_pin_that_covers_one_circumference_per_cycle_has_no_trend():
    """Speed = 12.6 cm x f at every pressure: flat in amplitude, constant distance per cycle."""
    records = [_record(g, a, f, 12.6 * f) for g, a, f in PAPER.cells]
    amplitude, cycle, _ = trend_counts(records)
    assert amplitude == Count(0, 8) and cycle == Count(0, 6)


def test_a_failed_run_counts_against_its_trends_and_cells():
    records = _paper_records()
    records[-1] = RunRecord.failed(records[-1].cell, "diverged")       # outward rolling 4 bar 1 Hz
    figures = fidelity_figures(records, PAPER)
    assert figures.amplitude_trend == Count(7, 8) and figures.cycle_distance_trend == Count(5, 6)
    assert figures.within_factor == Count(23, 24) and figures.rms_log > 0.5


def test_cycle_motion_splits_a_track_into_whole_cycles_with_turning():
    t = np.arange(0.0, 4.0 + 1e-9, 0.01)            # 1 Hz: four cycles, 0.1 m and 10 deg each
    track = np.column_stack([t, 0.1 * t, 0.0 * t, np.radians(10.0) * t])
    steps, turns = cycle_motion(_record("inward_rolling", 4.0, 1.0, 10.0, track))
    assert steps.shape == (4, 2) and np.allclose(steps, [[0.1, 0.0]] * 4)
    assert np.allclose(np.degrees(turns), 10.0)


def test_a_run_that_steps_back_in_one_cycle_counts_as_reversing():
    t = np.arange(0.0, 4.0 + 1e-9, 0.01)
    x = np.where(t < 2.0, 0.1 * t, 0.2 - 0.05 * (t - 2.0)) + 0.3 * (t >= 3.0) * (t - 3.0)
    track = np.column_stack([t, x, 0.0 * t, 0.0 * t])
    records = [_record("inward_rolling", 2.0, 1.0, 5.0, track)]
    assert fidelity_figures(records, PAPER).reversing_runs == Count(1, 1)


def test_reversals_count_only_runs_with_a_track_to_tell_and_a_failed_run_counts_against():
    """Records without tracks gave reversing_runs 0/24, read as "none reversed" where none was checked; a failed run
    was left out of it (a helper's review)."""
    assert fidelity_figures(_paper_records(), PAPER).reversing_runs == Count(0, 0)  # the paper's cells: no tracks
    t = np.arange(0.0, 4.0 + 1e-9, 0.01)
    straight = _record("inward_rolling", 2.0, 1.0, 5.0, np.column_stack([t, 0.1 * t, 0.0 * t, 0.0 * t]))
    failed = RunRecord.failed(("outward_rolling", 2.0, 1.0), "diverged")
    figures = fidelity_figures([straight, failed], PAPER)
    assert figures.reversing_runs == Count(1, 2) and figures.rolling_sides.total == 2


def _track_to(dx_m, dy_m, yaw_rad=0.0):
    """Four seconds from the origin straight to (dx, dy), the body's heading fixed."""
    t = np.arange(0.0, 4.0 + 1e-9, 0.1)
    return np.column_stack([t, dx_m * t / 4.0, dy_m * t / 4.0, np.full_like(t, yaw_rad)])


def test_the_side_of_travel_is_seen_from_the_body_whatever_its_heading():
    assert travel_side(_track_to(0.0, 0.3)) == 1.0                         # heading +x, moved +y: left
    assert math.isclose(travel_side(_track_to(0.3, 0.0, math.pi / 2)), -1.0)  # heading +y, moved +x: right
    assert math.isclose(travel_side(_track_to(0.2, 0.2)), math.sqrt(0.5))
    assert math.isnan(travel_side(_track_to(0.0, 0.0)))


def test_rolling_runs_count_when_inward_goes_left_and_outward_right_and_not_otherwise():
    left, right = _track_to(0.0, 0.3), _track_to(0.0, -0.3)
    kept = [_record("inward_rolling", 4.0, 1.0, 7.5, left), _record("outward_rolling", 4.0, 1.0, 7.5, right),
            _record("inward_rolling", 1.0, 1.0, 0.0, right)]                   # 1 bar: not a moving cell
    swapped = [_record("inward_rolling", 4.0, 1.0, 7.5, right), _record("outward_rolling", 2.0, 0.5, 7.5, left)]
    assert fidelity_figures(kept, PAPER).rolling_sides == Count(2, 2)
    assert fidelity_figures(swapped, PAPER).rolling_sides == Count(0, 2)
    assert fidelity_figures(_paper_records(), PAPER).rolling_sides == Count(0, 0)  # a table has no tracks
