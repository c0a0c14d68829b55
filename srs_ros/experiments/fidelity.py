"""How faithful the simulated robot is to a measured table: the trends of Table I as counts, not one error.

A calibration error (:func:`srs_ros.experiments.calibration.table_error`) says how far the speeds are; these
figures say whether the model answers the paper's questions the right way round (issue 19):

- ``amplitude_trend``: columns (rolling gait x frequency) whose speed rises with every pressure step;
- ``cycle_distance_trend``: rows (rolling gait x pressure) whose distance per cycle (speed / frequency) falls
  with every frequency step;
- ``within_factor``: rolling cells at 2-4 bar within a factor of 2 of the measured speed; ``rms_log``: the RMS
  of ``log(simulated / measured)`` over them;
- ``inward_faster``: (pressure, frequency) pairs where inward rolling is faster than outward;
- ``still_cells``: 1 bar cells below :data:`~srs_ros.experiments.calibration.STILL_CM_S`;
- ``serpentine_top_cm_s``: the fastest serpentine cell (the paper's robot made no progress);
- ``turning_deg_per_cycle``: the median absolute heading change per cycle of the rolling runs at 4 bar;
- ``reversing_runs``: rolling runs at 2-4 bar with a cycle that moved against the run's net direction (the
  paper's robot "occasionally flipped back" at 2 bar 1 Hz);
- ``rolling_sides``: rolling runs at 2-4 bar that travelled to their gait's side of the body
  (:func:`travel_side`): inward rolling to the left of the tail -> head heading, toward the opening of a body whose
  bend stays put as it rolls, outward rolling to the right. The paper's robot kept its direction at every pressure
  and frequency; a body whose spin is held steps to the other side
  (docs/studies/simulation.md, "Which way a held spin rolls").

Only the rows of ``records`` matter (a failed run counts against every figure it belongs to).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from srs_ros.experiments.calibration import ROLLING_FACTOR, ROLLING_GAITS, STILL_CM_S
from srs_ros.experiments.table import MeasuredTable, RunRecord

#: Rolling cells counted for the factor and the RMS: the paper's pressures where the robot moves.
MOVING_FROM_BAR = 2.0


@dataclass(frozen=True)
class Count:
    """``hits`` of ``total`` (e.g. 7 of 8 columns)."""

    hits: int
    total: int

    def __str__(self) -> str:
        return f"{self.hits}/{self.total}"


@dataclass(frozen=True)
class FidelityFigures:
    """The figures of one sweep against a measured table (see the module docstring)."""

    within_factor: Count
    rms_log: float
    amplitude_trend: Count
    cycle_distance_trend: Count
    inward_faster: Count
    still_cells: Count
    serpentine_top_cm_s: float
    turning_deg_per_cycle: float
    reversing_runs: Count
    rolling_sides: Count


def _speed(by_cell: dict, cell) -> float:
    record = by_cell.get(cell)
    return record.speed_cm_s if record is not None and record.ok else math.nan


def _rising(values: Sequence[float]) -> bool:
    """Every step up (NaN never rises)."""
    return len(values) > 1 and all(b > a for a, b in zip(values, values[1:]))


def _rolling_grid(records: Sequence[RunRecord]) -> tuple[list[str], list[float], list[float]]:
    gaits = [g for g in ROLLING_GAITS if any(r.gait == g for r in records)]
    amplitudes = sorted({r.amplitude_bar for r in records if r.gait in gaits and r.amplitude_bar >= MOVING_FROM_BAR})
    frequencies = sorted({r.frequency_hz for r in records if r.gait in gaits})
    return gaits, amplitudes, frequencies


def trend_counts(records: Sequence[RunRecord]) -> tuple[Count, Count, Count]:
    """(amplitude trend, distance-per-cycle trend, inward faster than outward) of the rolling cells at 2-4 bar."""
    by_cell = {r.cell: r for r in records}
    gaits, amplitudes, frequencies = _rolling_grid(records)
    amplitude = [_rising([_speed(by_cell, (g, a, f)) for a in amplitudes]) for g in gaits for f in frequencies]
    falling = [_rising([-_speed(by_cell, (g, a, f)) / f for f in frequencies]) for g in gaits for a in amplitudes]
    pairs = [(a, f) for a in amplitudes for f in frequencies]
    inward = [_speed(by_cell, ("inward_rolling", a, f)) > _speed(by_cell, ("outward_rolling", a, f)) for a, f in pairs]
    both = len(gaits) == 2
    return (Count(sum(amplitude), len(amplitude)), Count(sum(falling), len(falling)),
            Count(sum(inward) if both else 0, len(pairs) if both else 0))


def speed_agreement(records: Sequence[RunRecord], reference: MeasuredTable) -> tuple[Count, float]:
    """Rolling cells at 2-4 bar within :data:`ROLLING_FACTOR` of the measured speed, and the RMS log ratio."""
    logs = []
    for r in records:
        if r.gait not in ROLLING_GAITS or r.amplitude_bar < MOVING_FROM_BAR or r.cell not in reference.cells:
            continue
        measured = reference.speed_cm_s(r.cell)
        ratio = r.speed_cm_s / measured if r.ok and measured > 0 else math.nan
        logs.append(math.log(ratio) if ratio > 0 else math.log(20.0))
    logs = np.array(logs)
    within = int(np.sum(np.abs(logs) <= math.log(ROLLING_FACTOR) + 1e-12))
    return Count(within, len(logs)), float(np.sqrt(np.mean(logs ** 2))) if len(logs) else math.nan


def cycle_motion(record: RunRecord) -> tuple[np.ndarray, np.ndarray]:
    """Per whole cycle of a run's track: displacement ``(k, 2)`` (m) and heading change ``(k,)`` (rad)."""
    track = record.track
    if track is None or len(track) < 2:
        return np.empty((0, 2)), np.empty(0)
    period_s = 1.0 / record.frequency_hz
    starts = np.arange(0.0, track[-1, 0] - period_s + 1e-9, period_s)
    at = [np.searchsorted(track[:, 0], t - 1e-9) for t in (*starts, starts[-1] + period_s)] if len(starts) else []
    if len(at) < 2:
        return np.empty((0, 2)), np.empty(0)
    rows = track[np.minimum(at, len(track) - 1)]
    heading = np.unwrap(track[:, 3])[np.minimum(at, len(track) - 1)]
    return np.diff(rows[:, 1:3], axis=0), np.diff(heading)


#: The side of the body each rolling gait travels to (+1: left of the tail -> head heading).
GAIT_SIDE = {"inward_rolling": 1.0, "outward_rolling": -1.0}


def travel_side(track: np.ndarray) -> float:
    """Where a run went, seen from the body: the sine of the angle from its mean heading to its net displacement.

    ``track`` rows are ``time_s, x_m, y_m, yaw_rad`` (yaw: tail -> head). +1 is square to the left, -1 square to the
    right, 0 along the body; NaN for a run that did not move.
    """
    yaw = track[:, 3]
    heading = math.atan2(float(np.mean(np.sin(yaw))), float(np.mean(np.cos(yaw))))
    dx, dy = track[-1, 1:3] - track[0, 1:3]
    distance = math.hypot(dx, dy)
    return (math.cos(heading) * dy - math.sin(heading) * dx) / distance if distance > 0 else math.nan


def side_count(records: Sequence[RunRecord]) -> Count:
    """Rolling runs at 2-4 bar with a track that travelled to their gait's side (:data:`GAIT_SIDE`).

    A failed run counts against it.
    """
    runs = [r for r in records if r.gait in GAIT_SIDE and r.amplitude_bar >= MOVING_FROM_BAR
            and (r.track is not None or not r.ok)]
    return Count(sum(bool(r.ok and travel_side(r.track) * GAIT_SIDE[r.gait] > 0.0) for r in runs), len(runs))


def motion_figures(records: Sequence[RunRecord]) -> tuple[float, Count]:
    """Median |turning| per cycle (deg) of rolling runs at the top pressure; runs that stepped backwards in a cycle.

    Of the runs with a track to tell (a run without one is not counted: "0/24" read as "none reversed" where none
    was checked; a helper's review), and a failed run, which counts as a reversal: against the model.
    """
    rolling = [r for r in records if r.gait in ROLLING_GAITS and r.amplitude_bar >= MOVING_FROM_BAR]
    top = max((r.amplitude_bar for r in rolling if r.ok), default=math.nan)
    turning, reversing, counted = [], 0, 0
    for r in rolling:
        if not r.ok:
            reversing, counted = reversing + 1, counted + 1
            continue
        steps, turns = cycle_motion(r)
        if not len(steps):
            continue
        counted += 1
        if r.amplitude_bar == top:
            turning.extend(np.degrees(np.abs(turns)))
        net = steps.sum(axis=0)
        if np.linalg.norm(net) > 0 and np.any(steps @ net < 0.0):
            reversing += 1
    return (float(np.median(turning)) if turning else math.nan), Count(reversing, counted)


def fidelity_figures(records: Sequence[RunRecord], reference: MeasuredTable) -> FidelityFigures:
    """Every figure of the module docstring for one sweep (tracks are needed for turning and reversals)."""
    within, rms = speed_agreement(records, reference)
    amplitude, falling, inward = trend_counts(records)
    still = [r for r in records if r.amplitude_bar <= 1.0]
    serpentine = [r.speed_cm_s for r in records if r.gait == "serpentine" and r.ok]
    turning, reversing = motion_figures(records)
    return FidelityFigures(
        within_factor=within, rms_log=rms, amplitude_trend=amplitude, cycle_distance_trend=falling,
        inward_faster=inward,
        still_cells=Count(sum(r.ok and r.speed_cm_s < STILL_CM_S for r in still), len(still)),
        serpentine_top_cm_s=max(serpentine, default=math.nan), turning_deg_per_cycle=turning,
        reversing_runs=reversing, rolling_sides=side_count(records))
