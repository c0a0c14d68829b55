"""The trend figures of a sweep (srs_ros.experiments.fidelity) on records built by hand."""

from __future__ import annotations

import math

import numpy as np

from srs_ros.experiments.fidelity import Count, cycle_motion, fidelity_figures, trend_counts
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
