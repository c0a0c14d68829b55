"""Identify each muscle from step or chirp commands: command plans, their run, and the fits (no ROS).

A :class:`CommandPlan` is a sequence of regulator commands at the rig's command rate: steps from
vented to a level and back (:func:`step_plan`, every step followed by a vent) or a chirp
(:func:`chirp_plan`). :func:`run_plan` sends it through a :class:`RigIO` (a backend, the simulated
world) and records what was sent and what the rig measured. From the record:

- the static characteristic of a muscle (:func:`fit_static_characteristic`) comes from the settled
  end of each step, pressure read-back (or the commanded level) against measured length:
  ``l = g * clip(P - P_dz, 0, P_sat - P_dz)``, or from a ruler-and-pressure table
  (:func:`read_length_table`);
- the supply line's dynamics (:func:`fit_line_dynamics`) come from the pressure read-back against
  the commands: transport delay ``d`` and first-order time constant ``tau`` of
  :mod:`srs_ros.core.actuation.muscle_model`, fitted by simulating the model on the commands actually sent.

:func:`identify` does both per muscle and returns the values of a calibration file
(:mod:`srs_ros.core.actuation.muscle_calibration`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

import numpy as np
from scipy.optimize import least_squares, minimize
from scipy.signal import lfilter

from srs_ros.core.errors import ConfigurationError, FitError
from srs_ros.core.robot import RobotDescription
from srs_ros.core.schema import Field, Table, read_csv_rows

#: Largest transport delay the dynamics fit searches by default (s): several times the line lags modelled (0.08-0.2 s).
DEFAULT_MAX_DELAY_S = 0.5

#: Share of a step's hold at its end over which it counts as settled (averaged for the static fit).
SETTLED_SHARE = 0.25
#: Lengths below this share of the largest measured one are "not extending" (noise floor of the fit).
EXTENSION_NOISE_SHARE = 0.02
#: Resolution (s) of the time grid the dynamics are simulated on (command times round to it).
DYNAMICS_GRID_S = 1e-3
#: Time constants (s) the dynamics fit searches before refining.
TIME_CONSTANT_RANGE_S = (1e-3, 3.0)


@dataclass(frozen=True)
class Step:
    """One step: ``joints`` held at ``level_bar`` from ``start_s`` to ``end_s`` (s), settled after ``settled_s``."""

    joints: tuple[int, ...]
    level_bar: float
    start_s: float
    settled_s: float
    end_s: float


@dataclass(frozen=True)
class CommandPlan:
    """Commands ``pressure_bar`` ``(n, 9)`` (bar) to send at ``times_s`` ``(n,)`` (s from the start); its steps."""

    times_s: np.ndarray
    pressure_bar: np.ndarray
    steps: tuple[Step, ...] = ()
    description: str = ""

    @property
    def duration_s(self) -> float:
        """Time from the first command to the last (s)."""
        return float(self.times_s[-1]) if len(self.times_s) else 0.0

    def then(self, other: CommandPlan) -> CommandPlan:
        """The plan followed by ``other`` (one command period later)."""
        period_s = float(self.times_s[1] - self.times_s[0]) if len(self.times_s) > 1 else 0.0
        shift_s = self.duration_s + period_s
        steps = self.steps + tuple(Step(s.joints, s.level_bar, s.start_s + shift_s, s.settled_s + shift_s,
                                        s.end_s + shift_s) for s in other.steps)
        return CommandPlan(np.concatenate([self.times_s, other.times_s + shift_s]),
                           np.concatenate([self.pressure_bar, other.pressure_bar]), steps,
                           "; ".join(d for d in (self.description, other.description) if d))


def _timeline(duration_s: float, rate_hz: float, joint_count: int) -> tuple[np.ndarray, np.ndarray]:
    count = int(math.ceil(duration_s * rate_hz - 1e-9)) + 1
    return np.arange(count) / rate_hz, np.zeros((count, joint_count))


def step_plan(joint_count: int, rate_hz: float, levels_bar: Sequence[float], hold_s: float, vent_s: float,
              groups: Sequence[Sequence[int]]) -> CommandPlan:
    """Steps from 0 bar to each level for every group of joints, each held ``hold_s`` then vented ``vent_s``.

    The plan opens with ``vent_s`` at 0 bar. ``groups``: joints stepped together, e.g. ``[[0], [1], ...]``
    one muscle at a time, or ``[range(9)]`` all at once. Duration: ``vent_s + groups * levels * (hold_s + vent_s)``.
    """
    steps, start_s = [], vent_s
    for joints in groups:
        for level in levels_bar:
            end_s = start_s + hold_s
            steps.append(Step(tuple(int(j) for j in joints), float(level), start_s, end_s - SETTLED_SHARE * hold_s,
                              end_s))
            start_s = end_s + vent_s
    times_s, pressure = _timeline(start_s, rate_hz, joint_count)
    for step in steps:
        rows = (times_s >= step.start_s - 1e-9) & (times_s < step.end_s - 1e-9)
        pressure[np.ix_(rows, step.joints)] = step.level_bar
    levels = ", ".join(f"{v:g}" for v in levels_bar)
    return CommandPlan(times_s, pressure, tuple(steps), f"steps to [{levels}] bar held {hold_s:g} s, vented "
                                                        f"{vent_s:g} s, {len(groups)} group(s)")


def chirp_plan(joint_count: int, rate_hz: float, groups: Sequence[Sequence[int]], low_bar: float, high_bar: float,
               start_hz: float, end_hz: float, duration_s: float, vent_s: float) -> CommandPlan:
    """A linear chirp between ``low_bar`` and ``high_bar`` from ``start_hz`` to ``end_hz`` per group, vented between.

    ``P(t) = mid - half * cos(2 pi (f0 t + (f1 - f0) t^2 / (2 T)))``: it starts at ``low_bar``. For the
    dynamics only (no settled steps).
    """
    mid, half = 0.5 * (low_bar + high_bar), 0.5 * (high_bar - low_bar)
    times_s, pressure = _timeline(vent_s + len(groups) * (duration_s + vent_s), rate_hz, joint_count)
    for number, joints in enumerate(groups):
        start_s = vent_s + number * (duration_s + vent_s)
        rows = (times_s >= start_s - 1e-9) & (times_s < start_s + duration_s - 1e-9)
        t = times_s[rows] - start_s
        phase = start_hz * t + (end_hz - start_hz) * t * t / (2.0 * duration_s)
        pressure[np.ix_(rows, list(joints))] = (mid - half * np.cos(2.0 * math.pi * phase))[:, None]
    return CommandPlan(times_s, pressure, (), f"chirp {low_bar:g}-{high_bar:g} bar, {start_hz:g}-{end_hz:g} Hz over "
                                              f"{duration_s:g} s, {len(groups)} group(s)")


@dataclass(frozen=True)
class Measurement:
    """What a rig measured at ``time_s`` (s, the rig I/O's clock): pressures (bar), lengths (m); None if it cannot."""

    time_s: float
    pressure_bar: np.ndarray | None
    length_m: np.ndarray | None


class RigIO(Protocol):
    """What identification needs of a rig: a clock, waiting, commands (through the one clamp) and measurements."""

    def now_s(self) -> float:
        """The rig's clock (s)."""

    def wait_until(self, time_s: float) -> None:
        """Return at ``time_s`` on the rig's clock (sleep, or step a simulation)."""

    def write_pressures(self, pressure_bar: np.ndarray) -> np.ndarray:
        """Send one command (bar) through the one clamp; return what was sent."""

    def measure(self) -> Measurement:
        """The newest measurement and the time it was taken."""


@dataclass(frozen=True)
class Recording:
    """A plan as run: commands sent at ``command_s`` (s from the start) and samples measured at ``sample_s``.

    ``pressure_bar`` / ``length_m`` ``(m, 9)`` are None where the rig cannot measure them; samples are
    unique in time (a read-back seen twice counts once).
    """

    command_s: np.ndarray
    command_bar: np.ndarray
    sample_s: np.ndarray
    pressure_bar: np.ndarray | None
    length_m: np.ndarray | None


def run_plan(io: RigIO, plan: CommandPlan, on_step: Callable[[int, Step], None] | None = None,
             on_progress: Callable[[float], None] | None = None) -> Recording:
    """Send ``plan`` at its times through ``io`` and record, saying how far it is.

    ``on_step(index, step)`` as each step starts, ``on_progress(plan_s)`` every :data:`PROGRESS_EVERY_S` of the
    plan (a chirp has no steps to say). The caller vents and closes afterwards (and on any exception, Ctrl-C included).
    """
    count, joints = plan.pressure_bar.shape
    command_s, sent_bar = np.empty(count), np.empty((count, joints))
    sample_s = np.empty(count)
    pressure, length = np.full((count, joints), np.nan), np.full((count, joints), np.nan)
    starts = [step.start_s for step in plan.steps]
    next_step = 0
    start_s = io.now_s()
    for k in range(count):
        io.wait_until(start_s + plan.times_s[k])
        while on_step is not None and next_step < len(starts) and starts[next_step] <= plan.times_s[k] + 1e-9:
            on_step(next_step, plan.steps[next_step])
            next_step += 1
        if on_progress is not None and k and plan.times_s[k] // PROGRESS_EVERY_S > plan.times_s[k - 1] // \
                PROGRESS_EVERY_S:
            on_progress(float(plan.times_s[k]))
        command_s[k] = io.now_s() - start_s
        sent_bar[k] = io.write_pressures(plan.pressure_bar[k])
        measurement = io.measure()
        sample_s[k] = measurement.time_s - start_s
        if measurement.pressure_bar is not None:
            pressure[k] = measurement.pressure_bar
        if measurement.length_m is not None:
            length[k] = measurement.length_m
    _, unique = np.unique(sample_s, return_index=True)
    return Recording(command_s, sent_bar, sample_s[unique], _measured(pressure[unique]), _measured(length[unique]))


def _measured(values: np.ndarray) -> np.ndarray | None:
    """``values`` without the rows where nothing was measured; None if nothing ever was."""
    rows = np.all(np.isfinite(values), axis=1)
    return values if rows.all() else (None if not rows.any() else np.where(rows[:, None], values, np.nan))


# -- the static characteristic -----------------------------------------------------------------
@dataclass(frozen=True)
class StaticFit:
    """``l = g * clip(P - P_dz, 0, P_sat - P_dz)``; ``saturation_seen`` False: no knee up to ``saturation_bar``."""

    deadzone_bar: float
    extension_per_bar_m: float
    saturation_bar: float
    saturation_seen: bool
    rms_m: float
    points: int


def _characteristic(pressure_bar, deadzone_bar, gain_m_per_bar, saturation_bar):
    return gain_m_per_bar * np.clip(pressure_bar - deadzone_bar, 0.0, max(saturation_bar - deadzone_bar, 0.0))


def fit_static_characteristic(pressure_bar, length_m, where: str = "muscle", tested_bar: float = 0.0) -> StaticFit:
    """Fit deadzone, extension per bar and saturation to settled (pressure bar, length m) points.

    A coarse grid over (deadzone, saturation) with the best gain in closed form, refined by least
    squares. The saturation is "seen" only if a point lies above the knee; otherwise it is the
    highest pressure measured or commanded (``tested_bar``): the muscle extends linearly up to there
    (a read-back a hair short of a 4 bar command must not put a knee below 4 bar). Raises
    :class:`FitError` when fewer than two distinct pressures extend the muscle (what to do: more
    levels, higher pressure, check the muscle).
    """
    pressure = np.asarray(pressure_bar, dtype=float)
    length = np.asarray(length_m, dtype=float)
    keep = np.isfinite(pressure) & np.isfinite(length)
    pressure, length = pressure[keep], length[keep]
    if not length.size:
        raise FitError(f"{where}: no length was measured (every settled read-back of it was missing); expected a "
                       "length sensor reading at each level: check the muscle's length channel.")
    top_m = float(length.max())
    extending = length > max(EXTENSION_NOISE_SHARE * top_m, 1e-6)
    if len(np.unique(np.round(pressure[extending], 3))) < 2:
        raise FitError(f"{where}: extended at {len(np.unique(np.round(pressure[extending], 3)))} distinct pressure(s) "
                       f"of {len(pressure)} (largest extension {top_m * 1e3:.2f} mm); expected at least two to fit "
                       "the deadzone and the gain: add levels above the deadzone, or check the supply and the muscle.")
    high_bar = float(pressure.max())
    deadzones = np.linspace(0.0, high_bar, 201)[:, None, None]
    knees = np.linspace(0.0, high_bar, 201)[None, :, None]
    x = np.clip(pressure - deadzones, 0.0, np.maximum(knees - deadzones, 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        gain = np.sum(x * length, axis=-1, keepdims=True) / np.sum(x * x, axis=-1, keepdims=True)
    cost = np.where(knees > deadzones, np.sum((length - gain * x) ** 2, axis=-1, keepdims=True), np.inf)
    i, j, _ = np.unravel_index(np.nanargmin(cost), cost.shape)
    start = np.array([deadzones[i, 0, 0], gain[i, j, 0], knees[0, j, 0]])
    lower, upper = np.array([0.0, 1e-9, 0.0]), np.array([high_bar, np.inf, high_bar])
    refined = least_squares(lambda p: _characteristic(pressure, *p) - length, np.clip(start, lower, upper),
                            bounds=(lower, upper + 1e-12), x_scale=np.array([1.0, max(start[1], 1e-6), 1.0]))
    deadzone, gain_m, saturation = (float(v) for v in refined.x)
    seen = bool(np.any(pressure > saturation + 0.02 * high_bar))
    if not seen:
        saturation = max(high_bar, tested_bar)
    rms = float(np.sqrt(np.mean((_characteristic(pressure, deadzone, gain_m, saturation) - length) ** 2)))
    return StaticFit(deadzone, gain_m, saturation, seen, rms, int(len(pressure)))


def settled_points(recording: Recording, plan: CommandPlan, joint: int) -> tuple[np.ndarray, np.ndarray]:
    """Per step of ``plan`` that drives ``joint``: mean pressure (read-back, else the level) and length when settled."""
    pressures, lengths = [], []
    for step in plan.steps:
        if joint not in step.joints:
            continue
        rows = (recording.sample_s >= step.settled_s) & (recording.sample_s < step.end_s)
        if recording.length_m is None or not np.any(np.isfinite(recording.length_m[rows, joint])):
            continue  # no length read while settled: no point (nanmean warned of an empty slice)
        measured = None if recording.pressure_bar is None else np.nanmean(recording.pressure_bar[rows, joint])
        pressures.append(step.level_bar if measured is None or not np.isfinite(measured) else measured)
        lengths.append(np.nanmean(recording.length_m[rows, joint]))
    return np.array(pressures), np.array(lengths)


#: How often a run says how far it is (s of the plan).
PROGRESS_EVERY_S = 10.0
#: A fitted delay at most this (s) is at the fit's lower bound, 0: no real supply line is that short.
NO_DELAY_S = 0.002
#: The length changes a ruler table may hold: down to this below 0 (m; reading error) ...
LENGTH_TABLE_SLACK_M = 0.005
#: ... and up to this many times the robot's largest extension (a value typed in cm is 100 times too large).
LENGTH_TABLE_TIMES = 3.0


def length_table_schema(robot: RobotDescription) -> Table:
    """The columns of a ruler-and-pressure table for ``robot``: one measured point a row."""
    return Table("", (
        Field("joint", str, choices=tuple(robot.joint_names), description="the muscle measured"),
        Field("pressure_bar", float, minimum=0.0, maximum=robot.max_pressure_bar, unit="bar",
              description="the pressure held"),
        Field("length_m", float, minimum=-LENGTH_TABLE_SLACK_M, maximum=LENGTH_TABLE_TIMES * robot.max_extension_m,
              unit="m", description="the length change measured at that pressure (a few mm below 0 is a ruler's "
              "error; more than a few times the robot's largest extension, a value in other units)"),
    ))


def read_length_table(path: str | Path, robot: RobotDescription) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """A ruler-and-pressure table: CSV with a header ``joint,pressure_bar,length_m``, one measured point a row.

    Returns ``{joint: (pressures bar, lengths m)}``. Raises :class:`ConfigurationError` in the schema's one
    format, naming the file and line, the column, the cell and what is expected
    (:func:`~srs_ros.core.schema.read_csv_rows`).
    """
    points: dict[str, list[tuple[float, float]]] = {}
    for row in read_csv_rows(path, length_table_schema(robot)):
        points.setdefault(row["joint"], []).append((row["pressure_bar"], row["length_m"]))
    return {joint: (np.array([p for p, _ in rows]), np.array([v for _, v in rows])) for joint, rows in
            points.items()}


# -- the line's dynamics -----------------------------------------------------------------------
@dataclass(frozen=True)
class DynamicsFit:
    """Transport delay and first-order time constant (s) of one muscle's line, and the read-back residual."""

    transport_delay_s: float
    pressure_time_constant_s: float
    rms_bar: float
    samples: int


def _held_commands(grid_s: np.ndarray, command_s: np.ndarray, command_bar: np.ndarray) -> np.ndarray:
    """The command in force at each instant of ``grid_s`` (0 bar before the first)."""
    held = np.searchsorted(command_s, grid_s, side="right") - 1
    return np.where(held >= 0, command_bar[np.maximum(held, 0)], 0.0)


def _lag_response(inputs: np.ndarray, step_s: float, time_constant_s: float) -> np.ndarray:
    """First-order lag (from 0 bar) of ``inputs`` held over steps of ``step_s``: the pressure at each step's end."""
    keep = math.exp(-step_s / time_constant_s) if time_constant_s > 0.0 else 0.0
    return lfilter([0.0, 1.0 - keep], [1.0, -keep], inputs)


def fit_line_dynamics(command_s, command_bar, sample_s, pressure_bar, max_delay_s: float = DEFAULT_MAX_DELAY_S,
                      where: str = "muscle") -> DynamicsFit:
    """Fit ``d`` and ``tau`` so that the delayed first-order lag of the sent commands matches the read-back.

    ``command_s`` (n,) when each command (bar, (n,)) was sent, ``sample_s`` (m,) when each read-back
    pressure (bar, (m,)) was measured, on one clock; the muscle starts vented. A grid over (d, tau),
    refined by Nelder-Mead. Raises :class:`FitError` if the read-back never follows the commands.
    """
    command_s, command_bar = np.asarray(command_s, float), np.asarray(command_bar, float)
    keep = np.isfinite(pressure_bar)
    sample_s, measured = np.asarray(sample_s, float)[keep], np.asarray(pressure_bar, float)[keep]
    if command_bar.max(initial=0.0) <= 0.0 or measured.size < 10 or measured.max() < 0.2 * command_bar.max():
        raise FitError(f"{where}: the pressure read-back ({measured.max(initial=0.0):.2f} bar at most) does not follow "
                       f"the commands (up to {command_bar.max(initial=0.0):.2f} bar); check the regulator's monitor "
                       "wiring and the supply.")
    grid_s = np.arange(min(command_s[0], sample_s.min()) - max_delay_s, sample_s.max() + DYNAMICS_GRID_S,
                       DYNAMICS_GRID_S)
    inputs = _held_commands(grid_s, command_s, command_bar)

    def residual(delay_s: float, response: np.ndarray) -> np.ndarray:
        return np.interp(sample_s - delay_s, grid_s, response, left=0.0) - measured

    delays = np.arange(0.0, max_delay_s + 1e-9, 0.004)
    best = (np.inf, 0.0, 0.0)
    for tau in np.geomspace(*TIME_CONSTANT_RANGE_S, 32):
        response = _lag_response(inputs, DYNAMICS_GRID_S, tau)
        shifted = np.interp(sample_s[None, :] - delays[:, None], grid_s, response, left=0.0)
        cost = np.sum((shifted - measured) ** 2, axis=1)
        k = int(np.argmin(cost))
        best = min(best, (float(cost[k]), float(delays[k]), float(tau)))

    def objective(x: np.ndarray) -> float:
        delay_s, tau = float(np.clip(x[0], 0.0, max_delay_s)), float(np.exp(x[1]))
        return float(np.sum(residual(delay_s, _lag_response(inputs, DYNAMICS_GRID_S, tau)) ** 2))

    result = minimize(objective, np.array([best[1], math.log(best[2])]), method="Nelder-Mead",
                      options={"xatol": 1e-4, "fatol": 1e-10, "initial_simplex": np.array(
                          [[best[1], math.log(best[2])], [best[1] + 0.004, math.log(best[2])],
                           [best[1], math.log(best[2]) + 0.1]])})
    delay_s, tau = float(np.clip(result.x[0], 0.0, max_delay_s)), float(np.exp(result.x[1]))
    rms = float(np.sqrt(objective(result.x) / measured.size))
    return DynamicsFit(delay_s, tau, rms, int(measured.size))


# -- both, per muscle --------------------------------------------------------------------------
@dataclass
class Identification:
    """Identified values per joint name (keys of a calibration file), fit residuals and warnings."""

    values: dict[str, dict[str, float]] = field(default_factory=dict)
    fit: dict[str, dict[str, float]] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)


def identify(robot: RobotDescription, joints: Sequence[int], recording: Recording | None = None,
             plan: CommandPlan | None = None, static: bool = True, dynamics: bool = True,
             length_table: Mapping[str, tuple[np.ndarray, np.ndarray]] | None = None,
             max_delay_s: float = DEFAULT_MAX_DELAY_S) -> Identification:
    """Identify ``joints``: their static characteristic and/or their line's dynamics.

    The static characteristic comes from ``length_table`` if given, else from the settled steps of
    ``recording`` (run of ``plan``); the dynamics from the recording's pressure read-back.

    Raises :class:`FitError` naming the muscle when a fit cannot be made, and
    :class:`ConfigurationError` when the data for what is asked is missing.
    """
    result = Identification()
    for joint in joints:
        name = robot.joint_names[joint]
        values, fit = result.values.setdefault(name, {}), result.fit.setdefault(name, {})
        if static:
            if length_table is not None:
                if name not in length_table:
                    raise ConfigurationError(f"length table: no rows for {name}; expected measured points of every "
                                             "muscle identified (or leave it out with --channels).")
                pressures, lengths = length_table[name]
                tested_bar = 0.0
            else:
                pressures, lengths = settled_points(recording, plan, joint)
                tested_bar = max((s.level_bar for s in plan.steps if joint in s.joints), default=0.0)
            static_fit = fit_static_characteristic(pressures, lengths, name, tested_bar)
            values.update(deadzone_bar=static_fit.deadzone_bar, extension_per_bar_m=static_fit.extension_per_bar_m,
                          saturation_bar=static_fit.saturation_bar)
            fit.update(static_rms_m=static_fit.rms_m, static_points=static_fit.points,
                       saturation_seen=static_fit.saturation_seen)
            _check_settled(recording, plan, joint, name, result.warnings)
        if dynamics:
            line = fit_line_dynamics(*_joint_window(recording, joint), max_delay_s=max_delay_s, where=name)
            values.update(transport_delay_s=line.transport_delay_s,
                          pressure_time_constant_s=line.pressure_time_constant_s)
            fit.update(dynamics_rms_bar=line.rms_bar, dynamics_samples=line.samples)
            at_bound = (line.pressure_time_constant_s >= 0.99 * TIME_CONSTANT_RANGE_S[1]
                        or line.transport_delay_s >= 0.99 * max_delay_s)
            if at_bound:
                result.warnings.append(f"{name}: the dynamics fit ran into its bounds (delay "
                                       f"{line.transport_delay_s:.3f} s, tau {line.pressure_time_constant_s:.3f} s): "
                                       "hold the steps longer or raise --max-delay-s")
            if line.transport_delay_s <= NO_DELAY_S:  # the fit cannot go below 0: a read-back dated too early
                result.warnings.append(f"{name}: the dynamics fit put the delay at 0 s (tau "
                                       f"{line.pressure_time_constant_s:.3f} s, rms {line.rms_bar:.3f} bar); a supply "
                                       "line always delays: a read-back dated before its command fits this way, so "
                                       "check how the backend dates its read-back before using these values")
    return result


def _joint_window(recording: Recording, joint: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The commands and read-back of one joint around the time it was driven (it starts vented)."""
    if recording is None or recording.pressure_bar is None:
        raise ConfigurationError("the dynamics need the regulators' pressure read-back, and this rig reports none.")
    driven = np.flatnonzero(recording.command_bar[:, joint] > 0.0)
    if driven.size == 0:
        raise ConfigurationError(f"joint {joint + 1} was never commanded above 0 bar; nothing to identify.")
    first = max(int(driven[0]) - 1, 0)
    end_s = recording.command_s[min(int(driven[-1]) + 1, len(recording.command_s) - 1)] + 1.0
    start_s = recording.command_s[first]
    rows = (recording.sample_s >= start_s) & (recording.sample_s <= end_s)
    commands = slice(first, None)
    return (recording.command_s[commands], recording.command_bar[commands, joint], recording.sample_s[rows],
            recording.pressure_bar[rows, joint])


def _check_settled(recording: Recording | None, plan: CommandPlan | None, joint: int, name: str,
                   warnings: list[str]) -> None:
    """Warn when a step's length still moved during its settled window (the hold was too short)."""
    if recording is None or plan is None or recording.length_m is None:
        return
    top_m = np.nanmax(recording.length_m[:, joint], initial=0.0)
    for step in plan.steps:
        rows = (recording.sample_s >= step.settled_s) & (recording.sample_s < step.end_s)
        if joint in step.joints and rows.sum() >= 2 and top_m > 0.0:
            window = recording.length_m[rows, joint]
            if abs(window[-1] - window[0]) > EXTENSION_NOISE_SHARE * top_m:
                warnings.append(f"{name}: still moving at the end of the {step.level_bar:g} bar step "
                                f"({(window[-1] - window[0]) * 1e3:+.2f} mm): raise --hold-s")
                return
