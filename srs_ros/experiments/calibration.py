"""Fitting the simulation's uncertain parameters to a measured table (the paper's Table I or a lab's own).

The robot's geometry is known; what the paper does not measure is not: the floor friction, the skin's
outer radius (the rolling distance per turn, 2 pi r), the muscles' pressure lag, the supply line's
transport delay and where the deadzone really ends. :func:`calibrate` searches those
(:data:`FIT_PARAMETERS`, a chosen subset) on the offline simulation
(:class:`~srs_ros.experiments.sweep.OfflineRunner`), coarse to fine: the starting values, Sobol points over
the parameters' ranges (SciPy ``qmc``), then SciPy's bounded Nelder-Mead from the best point. It minimises
the RMS log error of the resultant speed over the table's cells (:func:`cell_errors`; speeds are compared
through ``log((v + 1) / (v_meas + 1))`` with v in cm/s, so near-zero cells such as serpentine weigh little
unless the simulation moves there).
The search runs shorter runs than the table (``fit_duration_s``) and at most ``max_evaluations``
evaluations of the cost; every evaluation runs all cells in parallel. Before and after, every cell runs
at the table's own run time; a fit that does not lower that full-length error is not taken (the
configuration stays as it was and the result says so), so the reported error goes down or stays.

Cells whose amplitude cannot exceed the muscles' deadzone anywhere in the search space cannot move and are left
out of the search (they are still run before and after). :func:`target_report` checks the goals of a
calibration to the paper, and :func:`model_limits` says in numbers where the model cannot follow the measurements.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from contextlib import nullcontext
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import yaml

from srs_ros.core.errors import InvalidInputError
from srs_ros.core.files import write_atomically
from srs_ros.core.robot import RobotDescription, default_robot
from srs_ros.experiments.sweep import OfflineRunner
from srs_ros.experiments.table import Cell, MeasuredTable, RunRecord
from srs_ros.sim.config import SimConfig, sim_config_from_dict, to_dict

#: Speed (cm/s) added to both sides of the log-ratio: a cell measured at 0 and simulated at 0.3 cm/s costs
#: little, one measured at 8 and simulated at 4 costs log(9/5).
SPEED_FLOOR_CM_S = 1.0
#: Residual of a run that failed (diverged): as bad as a factor of 20.
FAILED_RESIDUAL = math.log(20.0)
#: Significant digits of a fitted value (what is written to sim.yaml is exactly what was evaluated).
FIT_DIGITS = 4
#: Default number of cost evaluations and the search's starting step (fraction of each parameter's range).
DEFAULT_MAX_EVALUATIONS = 40
INITIAL_STEP = 0.25
#: Seed of the Sobol points of the coarse search (the search is deterministic).
SOBOL_SEED = 0


@dataclass(frozen=True)
class FitParameter:
    """One uncertain parameter of ``config/sim.yaml``: section, key and the range searched."""

    name: str
    section: str
    key: str
    low: float
    high: float
    description: str

    def value(self, config: SimConfig) -> float:
        return float(getattr(getattr(config, self.section), self.key))


FIT_PARAMETERS: dict[str, FitParameter] = {p.name: p for p in (
    FitParameter("friction_coefficient", "contact", "friction_coefficient", 0.2, 1.5,
                 "isotropic Coulomb friction of the skin on the floor"),
    FitParameter("friction_along_body", "contact", "friction_along_body", 0.05, 1.5,
                 "anisotropic friction along the body"),
    FitParameter("friction_across_body", "contact", "friction_across_body", 0.05, 2.0,
                 "anisotropic friction across the body"),
    FitParameter("skin_radius_m", "body", "skin_radius_m", 0.0175, 0.05,  # from the muscles' axis 12.5 mm + 5 mm
                 "outer radius of the body: rolling distance per turn 2 pi r"),
    FitParameter("pressure_time_constant_s", "muscles", "pressure_time_constant_s", 0.02, 0.6,
                 "first-order lag of regulator and muscle"),
    FitParameter("transport_delay_s", "muscles", "transport_delay_s", 0.0, 0.3,
                 "supply-line transport delay"),
    FitParameter("max_pressure_rate_bar_per_s", "muscles", "max_pressure_rate_bar_per_s", 1.0, 40.0,
                 "fastest filling or venting of a muscle (a flow-limited supply; 0, no limit, is not searched)"),
    FitParameter("deadzone_bar", "muscles", "deadzone_bar", 1.0, 1.8,
                 "pressure below which a muscle does not extend (at least 1 bar: nothing moves at 1 bar)"),
    FitParameter("skin_bend_stiffness_nm_per_rad", "servo", "skin_bend_stiffness_nm_per_rad", 0.5, 10.0,
                 "the skin's resistance to bending, per module"),
    FitParameter("roll_damping_nms_per_rad", "contact", "roll_damping_nms_per_rad", 0.0, 0.05,
                 "viscous resistance to the body spinning about its axis (supply lines, carpet)"),
)}


#: The parameters fitted by default besides the friction of the configured model. Not roll_damping_nms_per_rad
#: (``--fit`` still takes it): a viscous resistance to the body's spin holds a fast spin and not a slow one, so
#: the fitted body rolled inward toward its opening at 0.25 Hz and to the other side at 0.75-1 Hz, where the
#: paper's robot kept its direction at every frequency (docs/studies/simulation.md, "Which way a held spin rolls").
DEFAULT_FIT_BEYOND_FRICTION = ("skin_radius_m", "pressure_time_constant_s", "transport_delay_s", "deadzone_bar")


def default_fit(config: SimConfig) -> tuple[str, ...]:
    """The parameters fitted by default: friction (of the configured model), skin radius, lag, delay, deadzone."""
    friction = (("friction_along_body", "friction_across_body") if config.contact.friction == "anisotropic"
                else ("friction_coefficient",))
    return (*friction, *DEFAULT_FIT_BEYOND_FRICTION)


def fit_parameters(names: Sequence[str]) -> list[FitParameter]:
    """The named parameters; :class:`InvalidInputError` for an unknown or repeated name."""
    if not names:
        raise InvalidInputError(f"no parameters to fit; expected some of {sorted(FIT_PARAMETERS)}.")
    unknown = [n for n in names if n not in FIT_PARAMETERS]
    if unknown:
        raise InvalidInputError(f"unknown fit parameter {unknown[0]!r}; expected some of {sorted(FIT_PARAMETERS)}.")
    if len(set(names)) != len(names):
        raise InvalidInputError(f"fit parameters {list(names)} repeat a name; give each once.")
    return [FIT_PARAMETERS[n] for n in names]


def apply_values(config: SimConfig, values: Mapping[str, float], robot: RobotDescription | None = None) -> SimConfig:
    """``config`` with the fit parameters ``values`` (name -> value), validated like ``config/sim.yaml``."""
    data = to_dict(config)
    for name, value in values.items():
        parameter = FIT_PARAMETERS[name]
        data[parameter.section][parameter.key] = float(value)
    source = config.source if config.source.endswith(" (calibrated)") else config.source + " (calibrated)"
    return sim_config_from_dict({"sim": data}, robot, source=source)


# ------------------------------------------------------------------------------------------
# Errors against a measured table
# ------------------------------------------------------------------------------------------
def cell_errors(records: Sequence[RunRecord], reference: MeasuredTable) -> np.ndarray:
    """Per run: ``log((v + floor) / (v_measured + floor))`` of the resultant speeds (failed runs: a factor of 20)."""
    out = np.empty(len(records))
    for i, record in enumerate(records):
        measured = reference.speed_cm_s(record.cell)
        if not (record.ok and math.isfinite(record.speed_cm_s)):
            out[i] = FAILED_RESIDUAL
        else:
            out[i] = math.log((record.speed_cm_s + SPEED_FLOOR_CM_S) / (measured + SPEED_FLOOR_CM_S))
    return out


def table_error(records: Sequence[RunRecord], reference: MeasuredTable) -> float:
    """RMS of :func:`cell_errors` (0 = every speed as measured)."""
    errors = cell_errors(records, reference)
    return float(np.sqrt(np.mean(errors ** 2))) if len(errors) else 0.0


# ------------------------------------------------------------------------------------------
# The search
# ------------------------------------------------------------------------------------------
@dataclass
class Evaluation:
    """One evaluation of the cost during the search."""

    index: int
    values: dict[str, float]
    error: float
    wall_time_s: float


@dataclass
class CalibrationResult:
    """What :func:`calibrate` found: the configuration to use, the runs before and after, the search history."""

    parameters: list[FitParameter]
    initial_values: dict[str, float]
    fitted_values: dict[str, float]
    config: SimConfig
    before: list[RunRecord]
    after: list[RunRecord]
    error_before: float
    error_after: float
    accepted: bool
    history: list[Evaluation] = field(default_factory=list)
    fit_cells: list[Cell] = field(default_factory=list)
    fit_duration_s: float = 0.0
    wall_time_s: float = 0.0


class _Budget(Exception):
    """The search used its evaluations."""


def _round(value: float) -> float:
    return float(f"{value:.{FIT_DIGITS}g}")


@dataclass(frozen=True)
class _SearchSpace:
    """What the search varies, over which box (a configured value outside a range widens it), on which cells."""

    parameters: list[FitParameter]
    lows: np.ndarray
    highs: np.ndarray
    initial: dict[str, float]
    fit_cells: list[Cell]
    fit_duration_s: float
    max_evaluations: int

    def decode(self, u: np.ndarray) -> dict[str, float]:
        """Unit-box point -> parameter values (rounded to what is written to sim.yaml)."""
        x = self.lows + np.clip(u, 0.0, 1.0) * (self.highs - self.lows)
        return {p.name: _round(v) for p, v in zip(self.parameters, x)}

    def encode(self, values: np.ndarray) -> np.ndarray:
        """Parameter values -> unit-box point (a flat range maps to 0)."""
        span = np.where(self.highs > self.lows, self.highs - self.lows, 1.0)
        return np.clip((values - self.lows) / span, 0.0, 1.0)


def _search_space(reference: MeasuredTable, config: SimConfig, parameters: Sequence[str] | None,
                  fit_duration_s: float | None, max_evaluations: int) -> _SearchSpace:
    """Check the request (:class:`InvalidInputError` says what is wrong) and set up the search box and cells."""
    params = fit_parameters(list(parameters) if parameters else list(default_fit(config)))
    if isinstance(max_evaluations, bool) or not isinstance(max_evaluations, int) or max_evaluations < 1:
        raise InvalidInputError(f"max_evaluations: {max_evaluations!r}; expected an integer >= 1.")
    fit_duration_s = float(fit_duration_s or reference.duration_s)
    if not (math.isfinite(fit_duration_s) and fit_duration_s > 0):
        raise InvalidInputError(f"fit_duration_s: {fit_duration_s!r}; expected a run time > 0 s.")
    for p in params:
        if config.contact.friction != "anisotropic" and p.name.startswith("friction_a"):
            raise InvalidInputError(f"{p.name} is fitted but the floor friction is {config.contact.friction}; "
                                    "fit friction_coefficient, or use anisotropic friction (--friction A,B).")
        if config.contact.friction == "anisotropic" and p.name == "friction_coefficient":  # the floor ignores it
            raise InvalidInputError("friction_coefficient is fitted but the floor friction is anisotropic: fit "
                                    "friction_along_body and friction_across_body.")
        if p.name == "max_pressure_rate_bar_per_s" and p.value(config) <= 0.0:
            raise InvalidInputError("max_pressure_rate_bar_per_s is fitted but the configuration has no flow limit "
                                    "(0); give a starting estimate under muscles: (e.g. "
                                    "max_pressure_rate_bar_per_s: 5) in the --sim-config file, then fit it.")
    lows = np.array([min(p.low, p.value(config)) for p in params])
    highs = np.array([max(p.high, p.value(config)) for p in params])
    deadzone_floor = next((lows[i] for i, p in enumerate(params) if p.name == "deadzone_bar"),
                          config.muscles.deadzone_bar)
    fit_cells = [c for c in reference.cells if c[1] > deadzone_floor]
    if not fit_cells:
        raise InvalidInputError(f"{reference.source}: every cell's amplitude is at or below the muscles' deadzone "
                                f"({deadzone_floor:g} bar): nothing moves, there is nothing to fit.")
    return _SearchSpace(params, lows, highs, {p.name: p.value(config) for p in params}, fit_cells, fit_duration_s,
                        max_evaluations)


class _Search:
    """The cost over the search box (cached, counted) and the coarse-to-fine search that minimises it."""

    def __init__(self, space: _SearchSpace, reference: MeasuredTable, config: SimConfig, runner: OfflineRunner,
                 on_evaluation: Callable[[Evaluation], None] | None):
        self.space, self.reference, self.config, self.runner = space, reference, config, runner
        self.on_evaluation = on_evaluation
        self.robot = default_robot()
        self.history: list[Evaluation] = []
        self._cache: dict[tuple, float] = {}

    @property
    def global_count(self) -> int:
        """Sobol points first: a power of two (19 made SciPy warn), at most half the budget; none for one parameter."""
        half = (self.space.max_evaluations - 1) // 2
        return 1 << (half.bit_length() - 1) if half and len(self.space.parameters) > 1 else 0

    def cost(self, u: np.ndarray) -> float:
        """RMS error of the search's short runs at ``u``; raises _Budget when the evaluations are used."""
        values = self.space.decode(u)
        key = tuple(values.values())
        if key in self._cache:
            return self._cache[key]
        if len(self.history) >= self.space.max_evaluations:
            raise _Budget
        t0 = time.perf_counter()
        records = self.runner.run(self.space.fit_cells, self.space.fit_duration_s,
                                  apply_values(self.config, values, self.robot), keep_track=False)
        error = self._cache[key] = table_error(records, self.reference)
        self.history.append(Evaluation(len(self.history) + 1, values, error, time.perf_counter() - t0))
        if self.on_evaluation:
            self.on_evaluation(self.history[-1])
        return error

    def run(self) -> Evaluation:
        """The start, Sobol points over the box, then bounded Nelder-Mead from the best; the best evaluation."""
        from scipy.optimize import minimize  # here: SciPy's 0.8 s import only for a calibration, not every srs_sweep
        from scipy.stats import qmc

        space = self.space
        count = len(space.parameters)
        try:
            self.cost(space.encode(np.array(list(space.initial.values()))))
            if self.global_count:  # coarse: the cost is rugged (contacts), a local search alone stalls near the start
                for u in qmc.Sobol(count, scramble=True, seed=SOBOL_SEED).random(self.global_count):
                    self.cost(u)
            start = space.encode(np.array(list(self.best().values.values())))
            step = INITIAL_STEP / 2 if self.global_count else INITIAL_STEP  # fine: around the best point
            simplex = [start] + [start + np.eye(count)[i] * (step if start[i] + step <= 1.0 else -step)
                                 for i in range(count)]
            minimize(self.cost, start, method="Nelder-Mead", bounds=[(0.0, 1.0)] * count,
                     options={"initial_simplex": np.array(simplex), "maxfev": space.max_evaluations,
                              "xatol": 0.01, "fatol": 1e-3})
        except _Budget:
            pass
        return self.best()

    def best(self) -> Evaluation:
        return min(self.history, key=lambda e: e.error)


def calibrate(reference: MeasuredTable, config: SimConfig, parameters: Sequence[str] | None = None,
              fit_duration_s: float | None = None, max_evaluations: int = DEFAULT_MAX_EVALUATIONS,
              workers: int | None = None, on_evaluation: Callable[[Evaluation], None] | None = None,
              on_stage: Callable[[str], None] | None = None,
              on_result: Callable[[RunRecord], None] | None = None,
              runner: OfflineRunner | None = None) -> CalibrationResult:
    """Fit ``parameters`` (default :func:`default_fit`) of ``config`` to ``reference``; see the module docstring.

    ``on_stage(text)`` announces the stages (before, search, after), ``on_evaluation`` each cost evaluation,
    ``on_result`` each finished run of the before/after sweeps (for a progress bar). ``runner``: where the
    runs run (e.g. a Dask cluster's, :func:`~srs_ros.experiments.cluster.runner_for`; left open), instead
    of ``workers`` local processes.
    """
    started = time.perf_counter()
    space = _search_space(reference, config, parameters, fit_duration_s, max_evaluations)
    stage = on_stage or (lambda _text: None)
    cells, duration_s = list(reference.cells), reference.duration_s
    with nullcontext(runner) if runner is not None else OfflineRunner(workers) as runner:
        stage(f"before: {len(cells)} runs of {duration_s:g} s with {config.source}")
        before = runner.run(cells, duration_s, config, on_result=on_result)
        search = _Search(space, reference, config, runner, on_evaluation)
        stage(f"search: {[p.name for p in space.parameters]} over {len(space.fit_cells)} cells, runs of "
              f"{space.fit_duration_s:g} s, at most {space.max_evaluations} evaluations (the start, "
              f"{search.global_count} Sobol points over the ranges, then Nelder-Mead from the best)")
        best = search.run()
        fitted = apply_values(config, best.values, search.robot)
        stage(f"after: {len(cells)} runs of {duration_s:g} s with the best of {len(search.history)} evaluations "
              f"{best.values}")
        after = runner.run(cells, duration_s, fitted, on_result=on_result)
    error_before, error_after = table_error(before, reference), table_error(after, reference)
    accepted = error_after < error_before  # a fit that does not lower the error is not taken (an equal one was)
    if not accepted:  # the search's short runs misled it: keep what was there
        fitted, after, error_after = config, before, error_before
    return CalibrationResult(parameters=space.parameters, initial_values=space.initial,
                             fitted_values=best.values if accepted else dict(space.initial), config=fitted,
                             before=before, after=after, error_before=error_before, error_after=error_after,
                             accepted=accepted, history=search.history, fit_cells=space.fit_cells,
                             fit_duration_s=space.fit_duration_s, wall_time_s=time.perf_counter() - started)


# ------------------------------------------------------------------------------------------
# Output
# ------------------------------------------------------------------------------------------
def sim_yaml_text(config: SimConfig, header: str = "") -> str:
    """``config`` as a ``config/sim.yaml`` file (validated: :func:`~srs_ros.sim.config.load_sim_config` reads it)."""
    def plain(value):
        if isinstance(value, dict):
            return {k: plain(v) for k, v in value.items()}
        if isinstance(value, tuple):
            return [plain(v) for v in value]
        return value

    data = {"sim": plain(to_dict(config))}
    text = "".join(f"# {line}\n" if line else "#\n" for line in header.splitlines())
    text += yaml.safe_dump(data, sort_keys=False, default_flow_style=None)
    sim_config_from_dict(yaml.safe_load(text), source="the written sim.yaml")  # never write what cannot be read
    return text


def write_sim_yaml(path: str | Path, result: CalibrationResult, reference: MeasuredTable) -> Path:
    """Write the fitted configuration as a sim.yaml with a header saying how it was made (atomically)."""
    stamp = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    lines = [f"Simulation fitted by srs_sweep --calibrate to {reference.name} ({stamp}).",
             f"Fitted: {', '.join(f'{k} = {v:g}' for k, v in result.fitted_values.items())}"
             + ("" if result.accepted else " (the fit did not lower the error: the starting values are kept)") + ".",
             f"RMS log speed error over {len(result.before)} cells: {result.error_before:.3f} before, "
             f"{result.error_after:.3f} after ({len(result.history)} evaluations of "
             f"{result.fit_duration_s:g} s runs).",
             "Use it with: srs_sim --sim-config FILE, srs_sweep --sim-config FILE, or sim_world's sim_config_file."]
    return write_atomically(path, sim_yaml_text(result.config, "\n".join(lines)))


def format_cell_errors(reference: MeasuredTable, before: Sequence[RunRecord], after: Sequence[RunRecord]) -> str:
    """Per cell: the measured speed, the simulated speed before and after and their ratios to the measured one."""
    lines = [f"{'gait':<16} {'A bar':>5} {'f Hz':>5} | {'measured':>8} | {'before':>7} {'ratio':>6} | "
             f"{'after':>7} {'ratio':>6}   (resultant speed, cm/s)"]
    after_by = {r.cell: r for r in after}

    def ratio(record: RunRecord, measured: float) -> str:
        if not record.ok:
            return "failed"
        if measured < 0.005:
            return "-" if record.speed_cm_s < 0.005 else "moves"
        return f"{record.speed_cm_s / measured:.2f}"

    def speed(record: RunRecord) -> str:
        return f"{record.speed_cm_s:7.2f}" if record.ok else "   --  "

    for record in before:
        measured = reference.speed_cm_s(record.cell)
        later = after_by[record.cell]
        lines.append(f"{record.gait:<16} {record.amplitude_bar:5g} {record.frequency_hz:5g} | {measured:8.2f} | "
                     f"{speed(record)} {ratio(record, measured):>6} | {speed(later)} {ratio(later, measured):>6}")
    return "\n".join(lines)


@dataclass(frozen=True)
class TargetCheck:
    """One goal of a calibration to the paper, whether it is met and the figures behind it."""

    goal: str
    met: bool
    detail: str


#: Speed below which a run "does not move" (cm/s): Table I prints it as 0.00.
STILL_CM_S = 0.005
#: Serpentine makes no real progress in the paper: every simulated cell below this (cm/s).
SERPENTINE_LIMIT_CM_S = 1.0
#: Rolling cells within this factor of the paper's resultant speed, in at least this share of them.
ROLLING_FACTOR = 2.0
ROLLING_SHARE = 0.75
ROLLING_GAITS = ("inward_rolling", "outward_rolling")


def target_report(records: Sequence[RunRecord], reference: MeasuredTable) -> list[TargetCheck]:
    """The goals of a calibration to the paper, checked on ``records`` (cells the table does not have are ignored)."""
    runs = [r for r in records if r.cell in reference.cells]
    checks = []
    still = [r for r in runs if reference.speed_cm_s(r.cell) < STILL_CM_S and r.amplitude_bar <= 1.0]
    moving = [r for r in still if not (r.ok and r.speed_cm_s < STILL_CM_S)]
    if still:
        checks.append(TargetCheck("1 bar cells do not move", not moving,
                                  f"{len(still) - len(moving)} of {len(still)} below {STILL_CM_S} cm/s"
                                  + (f"; moving: {[_name(r) for r in moving]}" if moving else "")))
    serpentine = [r for r in runs if r.gait == "serpentine"]
    fast = [r for r in serpentine if not (r.ok and r.speed_cm_s < SERPENTINE_LIMIT_CM_S)]
    if serpentine:
        top = max((r.speed_cm_s for r in serpentine if r.ok), default=math.nan)
        checks.append(TargetCheck(f"serpentine under {SERPENTINE_LIMIT_CM_S:g} cm/s in every cell", not fast,
                                  f"{len(serpentine) - len(fast)} of {len(serpentine)} cells, fastest {top:.2f} cm/s"
                                  + (f"; too fast or failed: {[_name(r) for r in fast]}" if fast else "")))
    rolling = [r for r in runs if r.gait in ROLLING_GAITS and r.amplitude_bar >= 2.0]
    if rolling:
        within = [r for r in rolling if r.ok and 1.0 / ROLLING_FACTOR <= r.speed_cm_s / max(
            reference.speed_cm_s(r.cell), 1e-9) <= ROLLING_FACTOR]
        needed = math.ceil(ROLLING_SHARE * len(rolling))
        outside = [f"{_name(r)} {r.speed_cm_s:.2f} vs {reference.speed_cm_s(r.cell):.2f}"
                   for r in rolling if r not in within]
        checks.append(TargetCheck(f"rolling cells at 2-4 bar within a factor of {ROLLING_FACTOR:g} of the measured "
                                  f"speed in at least {ROLLING_SHARE:.0%}", len(within) >= needed,
                                  f"{len(within)} of {len(rolling)} (need {needed})"
                                  + (f"; outside: {outside}" if outside else "")))
    by_cell = {r.cell: r for r in runs}
    pairs = []
    for r in runs:
        if r.gait != "inward_rolling" or r.amplitude_bar < 2.0:
            continue
        other = by_cell.get(("outward_rolling", r.amplitude_bar, r.frequency_hz))
        if other is not None and reference.speed_cm_s(r.cell) > reference.speed_cm_s(other.cell):
            pairs.append((r, other))
    if pairs:
        wrong = [f"{r.amplitude_bar:g} bar {r.frequency_hz:g} Hz" for r, o in pairs
                 if not (r.ok and o.ok and r.speed_cm_s > o.speed_cm_s)]
        checks.append(TargetCheck("inward faster than outward where the measurements say so", not wrong,
                                  f"{len(pairs) - len(wrong)} of {len(pairs)} cells"
                                  + (f"; not faster at {wrong}" if wrong else "")))
    return checks


def _name(record: RunRecord) -> str:
    return f"{record.gait} {record.amplitude_bar:g} bar {record.frequency_hz:g} Hz"


def model_limits(records: Sequence[RunRecord], reference: MeasuredTable, config: SimConfig) -> list[str]:
    """Where the simulation cannot follow the measurements, in numbers: distance per cycle of the rolling gaits.

    A body rolling without slip covers 2 pi r per cycle whatever the frequency, so its speed grows in
    proportion to f. Where the measured distance per cycle changes with frequency by far more than the
    simulated one (e.g. a real robot that lifts and tumbles at low frequency and flips back at high
    frequency), no choice of the fitted parameters makes every cell agree.
    """
    notes = []
    by_cell = {r.cell: r for r in records}
    groups = sorted({(c[0], c[1]) for c in reference.cells if c[0] in ROLLING_GAITS and c[1] >= 2.0})
    per_turn_cm = 200.0 * math.pi * config.body.skin_radius_m
    for gait, amplitude in groups:
        cells = sorted((c for c in reference.cells if c[:2] == (gait, amplitude) and c in by_cell), key=lambda c: c[2])
        cells = [c for c in cells if by_cell[c].ok]
        if len(cells) < 2:
            continue
        low, high = cells[0], cells[-1]
        measured = [reference.speed_cm_s(c) / c[2] for c in (low, high)]
        simulated = [by_cell[c].speed_cm_s / c[2] for c in (low, high)]
        if min(measured + simulated) <= 0:
            continue
        spread_measured, spread_simulated = measured[0] / measured[1], simulated[0] / simulated[1]
        if max(spread_measured / spread_simulated, spread_simulated / spread_measured) > 1.5:
            notes.append(f"{gait} {amplitude:g} bar: distance per cycle {measured[0]:.1f} cm at {low[2]:g} Hz -> "
                         f"{measured[1]:.1f} cm at {high[2]:g} Hz measured, {simulated[0]:.1f} -> "
                         f"{simulated[1]:.1f} cm simulated (2 pi r = {per_turn_cm:.1f} cm)")
    return notes

