"""Joint-space gait cycles: a gait's shapes fitted over one cycle, scaled to a pressure amplitude, timed.

:func:`generate_cycle` is the one entry point (paper Sec. III): it samples the gait's task-space
shape at N phases, fits the body to every shape (:mod:`srs_ros.core.gait.fitting`, paper eq. 3), scales
the joint-space cycle to the requested pressure amplitude and times it by the frequency. The result,
a :class:`GaitCycle`, plays back smoothly by periodic cubic interpolation in phase and round-trips
through CSV.

Amplitude (docs/conventions.md, Gaits): the cycle at amplitude A is a shape of the gait bent just enough
that its largest pressure, ``P = 100 l`` (+ the optional deadzone offset), is exactly A; a larger A bends
more (a smaller rolling radius, a larger serpentine wave) as in the paper. Rolling gaits are solved
exactly: every shape is one constant-curvature arc, whose three lengths per module are sinusoids 120 deg
apart, so the arc radius for A is found by a 1-D root search and the cycle is that arc, not a fit.
Other gaits are fitted: the gait's amplitude parameters (``amplitude:`` in ``config/gaits.yaml``, e.g. a
serpenoid's angle, a helix's radius and pitch) are bent (a secant step on the factor the fitted cycle misses
A by) and the shape refitted, until the factor is within 1 % of 1; the fit nearest to 1 is then scaled by its
factor, if that is within 5 %; a shape no bend brings there is refused. Either way
``fit_error_mm`` and the reported parameters describe the shape that is commanded, not a reference.
If A needs more than ``max_extension_m`` the request is refused (it cannot be reached).
"""

from __future__ import annotations

import csv
import io
import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from srs_ros.core.actuation.pressure import lengths_to_pressures_bar, pressure_amplitude_scale
from srs_ros.core.errors import ConfigurationError, InvalidInputError
from srs_ros.core.files import write_atomically
from srs_ros.core.gait.fitting import FitSettings, fit_error_mm, fit_shapes
from srs_ros.core.gait.interpolation import PeriodicTrajectory
from srs_ros.core.gait.library import (
    ROLLING_TURNS,
    GaitSpec,
    gait_spec,
    gaits_config,
    gaits_config_path,
    list_gaits,
    rolling_arc_lengths,
    rolling_radius_for_peak,
    shape_curves,
)
from srs_ros.core.gait.request import FREQUENCY_FIELD, MIN_SAMPLES, SAMPLES_FIELD, amplitude_field, any_samples
from srs_ros.core.robot import RobotDescription, default_robot, read_yaml
from srs_ros.core.schema import Field, Table

__all__ = ["GaitCycle", "GaitSpec", "generate_cycle", "list_gaits", "fit_settings", "MIN_SAMPLES"]



class PoorFitWarning(UserWarning):
    """Some samples of a cycle could not be fitted within the gait's ``poor_fit_mm``."""


def fit_settings() -> FitSettings:
    """The fitter settings of ``config/gaits.yaml`` (section ``fitting:``)."""
    return FitSettings.from_config(gaits_config().get("fitting"), str(gaits_config_path()))


@dataclass(frozen=True, eq=False)
class GaitCycle:
    """One joint-space cycle of a gait, ready to play (sample ``i`` at phase ``i / N``).

    ``lengths_m`` (N, 9) actuator length changes in joint order ``joint_names``, within
    ``[0, max_extension_m]``; ``fit_error_mm`` (N,) RMS distance of the commanded body's 31 backbone
    points to the gait shape it is commanded to take; ``poor_samples`` samples still poor after the
    retry; ``parameters`` the gait parameters of that shape (solved for the amplitude, with the given
    values as ``reference_<name>``) and derived values.
    """

    gait: str
    amplitude_bar: float
    frequency_hz: float
    lengths_m: np.ndarray
    fit_error_mm: np.ndarray
    poor_samples: tuple[int, ...]
    parameters: dict
    joint_names: tuple[str, ...]
    robot: RobotDescription = field(default_factory=default_robot, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_spline", PeriodicTrajectory(self.lengths_m))

    @property
    def sample_count(self) -> int:
        """N, the number of samples of the cycle."""
        return int(self.lengths_m.shape[0])

    @property
    def period_s(self) -> float:
        """Cycle period 1 / f in seconds."""
        return 1.0 / self.frequency_hz

    @property
    def phase(self) -> np.ndarray:
        """Phase of every sample, ``i / N`` (N,)."""
        return np.arange(self.sample_count) / self.sample_count

    @property
    def time_s(self) -> np.ndarray:
        """Time of every sample within the cycle, ``phase * period_s`` (N,)."""
        return self.phase * self.period_s

    @property
    def ok(self) -> bool:
        """True when no sample is poor."""
        return not self.poor_samples

    @property
    def pressures_bar(self) -> np.ndarray:
        """Commanded pressures (N, 9) in bar, through the one clamp (``P = 100 l``)."""
        return lengths_to_pressures_bar(self.lengths_m, self.robot)

    def lengths_at(self, phase) -> np.ndarray:
        """Lengths (m) at any phase (wrapped), periodic cubic interpolation: shape ``phase.shape + (9,)``.

        The spline may overshoot a little where a length touches a bound (the least-extension solution
        has kinks there); values are limited to ``[0, max_extension_m]``.
        """
        return np.clip(self._spline.values(phase), 0.0, self.robot.max_extension_m)

    def velocities_at(self, phase) -> np.ndarray:
        """Length rates (m/s) at any phase: d(lengths)/d(phase) * frequency_hz."""
        return self._spline.derivatives(phase) * self.frequency_hz

    def summary(self) -> str:
        """One line for people: gait, amplitude, frequency, samples, fit errors, poor samples."""
        poor = f"{len(self.poor_samples)} poor sample(s) {list(self.poor_samples)}" if self.poor_samples \
            else "no poor samples"
        shape = ", ".join(f"{name} {self.parameters[name]:.4g}" for name in self.shape_parameters)
        return (f"{self.gait}: A = {self.amplitude_bar:g} bar, f = {self.frequency_hz:g} Hz, N = {self.sample_count}, "
                f"{'shape ' + shape + ', ' if shape else ''}fit error mean {float(np.mean(self.fit_error_mm)):.3f} mm, "
                f"worst {float(np.max(self.fit_error_mm)):.3f} mm, {poor}")

    @property
    def shape_parameters(self) -> tuple[str, ...]:
        """The parameters solved for the amplitude (e.g. ``radius_m`` of a rolling arc), in gaits.yaml order."""
        return tuple(f"{key[len('reference_'):]}" for key in self.parameters
                     if key.startswith("reference_") and key[len("reference_"):] in self.parameters)

    # ----------------------------------------------------------------------------------------
    # CSV
    # ----------------------------------------------------------------------------------------
    def csv_header(self) -> list[str]:
        """``phase, time_s, <joint> (m) x 9, fit_error_mm, <joint>_bar x 9, poor``."""
        return ["phase", "time_s", *self.joint_names, "fit_error_mm", *(f"{n}_bar" for n in self.joint_names),
                "poor"]

    def to_csv(self, path: str | Path) -> Path:
        """Write the cycle as CSV (one header row, numbers only; pandas and MATLAB ``readtable`` read it).

        The gait name, amplitude, frequency and parameters go to a sidecar ``<path>.yaml`` that
        :meth:`from_csv` reads back when present.
        """
        path = Path(path)
        poor = np.zeros(self.sample_count, dtype=int)
        poor[list(self.poor_samples)] = 1
        rows = np.column_stack([self.phase, self.time_s, self.lengths_m, self.fit_error_mm, self.pressures_bar,
                                poor])
        stream = io.StringIO(newline="")
        writer = csv.writer(stream)
        writer.writerow(self.csv_header())
        for row in rows:
            writer.writerow([repr(float(v)) for v in row[:-1]] + [int(row[-1])])
        meta = {"gait": self.gait, "amplitude_bar": float(self.amplitude_bar),
                "frequency_hz": float(self.frequency_hz), "joint_names": list(self.joint_names),
                "poor_samples": [int(i) for i in self.poor_samples],
                "parameters": {k: _plain(v) for k, v in self.parameters.items()}}
        # Each whole or not at all, the sidecar first: a CSV is never left without the metadata it is read with,
        # nor an older CSV beside new metadata (it read back with another cycle's frequency and amplitude).
        path.unlink(missing_ok=True)
        write_atomically(_sidecar(path), yaml.safe_dump(meta, sort_keys=False))
        write_atomically(path, stream.getvalue())
        return path

    @classmethod
    def from_csv(cls, path: str | Path, robot: RobotDescription | None = None) -> GaitCycle:
        """Read a cycle written by :meth:`to_csv` (the sidecar, if missing, is inferred from the columns).

        The sidecar is checked by :func:`sidecar_table`, the rows must be finite numbers: a refusal
        (:class:`InvalidInputError`) names the file, and the key or the row.
        """
        robot = robot or default_robot()
        path = Path(path)
        header, table = _read_csv(path)
        needed = ["phase", "time_s", *robot.joint_names, "fit_error_mm"]
        missing_columns = [name for name in needed if name not in header]
        if missing_columns:
            raise InvalidInputError(f"{path}: missing column(s) {missing_columns}; expected at least {needed}.")
        data = _numbers(path, header, table, needed)
        if len(data) < MIN_SAMPLES:
            raise InvalidInputError(f"{path}: {len(data)} row(s) of samples; expected at least {MIN_SAMPLES} (a "
                                    "cycle as GaitCycle.to_csv writes it, a row a sample).")
        lengths = data[:, 2:2 + robot.joint_count]
        meta = _read_sidecar(path, robot, len(data))
        frequency = meta["frequency_hz"]
        if frequency is None:
            if not (len(data) > 1 and data[1, 1] > data[0, 1]):
                raise InvalidInputError(f"{path}: cannot infer the frequency (no sidecar {_sidecar(path).name}, "
                                        "time_s not increasing).")
            frequency = FREQUENCY_FIELD.check(1.0 / (len(data) * (data[1, 1] - data[0, 1])),
                                              f"{path} (its time_s steps)", error=InvalidInputError)
        _check_lengths(path, lengths, robot)
        amplitude = meta["amplitude_bar"]
        if amplitude is None:
            amplitude = float(lengths_to_pressures_bar(lengths, robot).max())
        poor = meta["poor_samples"]
        if poor is None and "poor" in header:
            poor = np.flatnonzero(_numbers(path, header, table, ["poor"])[:, 0]).tolist()
        return cls(gait=meta["gait"] or path.stem, amplitude_bar=amplitude, frequency_hz=frequency,
                   lengths_m=lengths, fit_error_mm=data[:, -1], poor_samples=tuple(poor or ()),
                   parameters=dict(meta["parameters"] or {}), joint_names=tuple(robot.joint_names), robot=robot)


def _check_lengths(path: Path, lengths: np.ndarray, robot: RobotDescription) -> None:
    """Refuse a length outside [0, max_extension_m], naming its row and column (a file read before anything plays)."""
    bad = np.argwhere(~((lengths >= 0.0) & (lengths <= robot.max_extension_m)))
    if bad.size:
        row, column = (int(i) for i in bad[0])
        raise InvalidInputError(f"{path}:{row + 2}: {robot.joint_names[column]} is {lengths[row, column]:g} m; "
                                f"expected a length in [0, {robot.max_extension_m:g}] m (the muscle's extension), "
                                f"{len(bad)} value(s) outside in all.")


def sidecar_table(robot: RobotDescription) -> Table:
    """The keys of a cycle CSV's sidecar ``<csv>.yaml`` (:meth:`GaitCycle.to_csv`); each may be left out."""
    return Table("the sidecar", (
        Field("gait", str, None, nonempty=True, description="the gait's name"),
        replace(amplitude_field(robot), default=None),
        replace(FREQUENCY_FIELD, default=None),
        Field("joint_names", list, None, item=str, expected_text=f"the robot's joints {list(robot.joint_names)}"),
        Field("poor_samples", list, None, minimum=0, item=int, description="samples fitted poorly"),
        Field("parameters", dict, None, description="the gait's parameters")))


def _read_csv(path: Path) -> tuple[list[str], list[list[str]]]:
    try:
        with path.open("r", newline="", encoding="utf-8") as stream:
            reader = csv.reader(stream)
            header = next(reader)
            return header, [row for row in reader if row]
    except (OSError, StopIteration, UnicodeDecodeError, csv.Error) as exc:
        raise InvalidInputError(f"{path}: cannot read a trajectory CSV ({exc or 'empty'}).") from None


def _numbers(path: Path, header: list[str], table: list[list[str]], columns: list[str]) -> np.ndarray:
    """The named columns of every row as finite numbers."""
    for line, row in enumerate(table, start=2):
        try:
            values = [float(row[header.index(n)]) for n in columns]
        except (ValueError, IndexError):
            raise InvalidInputError(f"{path}:{line}: a row is short or not numeric ({','.join(row)}); expected a "
                                    f"number in each of {columns}.") from None
        if not all(math.isfinite(v) for v in values):
            raise InvalidInputError(f"{path}:{line}: a value is not finite ({','.join(row)}); expected finite "
                                    "numbers.")
    return np.array([[float(row[header.index(n)]) for n in columns] for row in table]).reshape(-1, len(columns))


def _read_sidecar(path: Path, robot: RobotDescription, samples: int) -> dict[str, Any]:
    """The sidecar's values checked by :func:`sidecar_table` (every key None without a sidecar)."""
    table = sidecar_table(robot)
    sidecar = _sidecar(path)
    if not sidecar.is_file():
        return dict.fromkeys(table.names)
    try:
        meta = table.read(read_yaml(sidecar) or {}, str(sidecar), error=InvalidInputError)
    except ConfigurationError as exc:
        raise InvalidInputError(str(exc)) from None
    if meta["joint_names"] is not None and list(meta["joint_names"]) != list(robot.joint_names):
        raise InvalidInputError(f"{sidecar}: joint_names {list(meta['joint_names'])}; expected the robot's "
                                f"{list(robot.joint_names)} (a cycle of another robot description).")
    if meta["poor_samples"] and max(meta["poor_samples"]) >= samples:
        raise InvalidInputError(f"{sidecar}: poor_samples up to {max(meta['poor_samples'])}; expected sample "
                                f"indices below the CSV's {samples} rows.")
    return meta


def _sidecar(path: Path) -> Path:
    return path.with_name(path.name + ".yaml")


def _plain(value: Any) -> Any:
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return value.item()
    return value


def _check_request(gait: str, amplitude_bar: float, frequency_hz: float, samples: int,
                   robot: RobotDescription) -> GaitSpec:
    spec = gait_spec(gait)
    for field_, value in ((amplitude_field(robot), amplitude_bar), (FREQUENCY_FIELD, frequency_hz),
                          (any_samples(), samples)):
        field_.check(value, "generate_cycle", error=InvalidInputError)
    return spec


def generate_cycle(gait: str, amplitude_bar: float, frequency_hz: float, samples: int = SAMPLES_FIELD.default,
                   robot: RobotDescription | None = None, params: Mapping[str, Any] | None = None) -> GaitCycle:
    """The cycle of ``gait`` at ``amplitude_bar`` (shape solved for it), ``samples`` shapes, timed by ``frequency_hz``.

    Raises :class:`InvalidInputError` for an unknown gait, ``amplitude_bar`` outside
    ``(0, max_pressure_bar]``, ``frequency_hz <= 0``, ``samples < 8``, unknown/out-of-range gait
    parameters (the message lists what is allowed), or an amplitude beyond the actuators' extension.
    Samples whose fit stays poor after the global retry are listed in ``poor_samples`` and a
    :class:`PoorFitWarning` is issued.
    """
    robot = robot or default_robot()
    spec = _check_request(gait, amplitude_bar, frequency_hz, samples, robot)
    settings = fit_settings()
    given = spec.resolve(params)
    phase = np.arange(samples) / samples
    peak_m = (float(amplitude_bar) - robot.deadzone_offset_bar) / robot.pressure_per_length_bar_per_m
    if peak_m > robot.max_extension_m * (1.0 + 1e-9):
        raise InvalidInputError(
            f"amplitude_bar: {amplitude_bar:g} bar needs {peak_m * 1e3:.1f} mm of extension, more than the "
            f"{robot.max_extension_m * 1e3:.1f} mm an actuator has; ask for less amplitude.")
    if spec.name in ROLLING_TURNS:
        lengths, error, shape, used, fits, retried = _solve_rolling(spec, given, phase, peak_m, robot, settings)
    else:
        lengths, error, shape, used, fits, retried = _fit_for_amplitude(spec, given, phase, float(amplitude_bar),
                                                                        robot, settings)
    if lengths.max() > robot.max_extension_m * (1.0 + 1e-9):
        raise InvalidInputError(
            f"amplitude_bar: {amplitude_bar:g} bar needs {lengths.max() * 1e3:.1f} mm of extension, more than the "
            f"{robot.max_extension_m * 1e3:.1f} mm an actuator has; ask for less amplitude or a gentler shape.")
    lengths = np.clip(lengths, 0.0, robot.max_extension_m)
    poor = tuple(int(i) for i in np.flatnonzero(error > used["poor_fit_mm"]))
    used = {**used, **{f"reference_{name}": given[name] for name in spec.amplitude_parameters},
            "samples": int(samples), "shape_fits": fits, "retried_samples": retried}
    cycle = GaitCycle(gait=spec.name, amplitude_bar=float(amplitude_bar), frequency_hz=float(frequency_hz),
                      lengths_m=lengths, fit_error_mm=error, poor_samples=poor, parameters=used,
                      joint_names=tuple(robot.joint_names), robot=robot)
    if poor:
        warnings.warn(f"{cycle.summary()}: samples {list(poor)} fit worse than poor_fit_mm = "
                      f"{used['poor_fit_mm']:g} mm "
                      "after the global retry; check the shape parameters (the body may not reach this shape).",
                      PoorFitWarning, stacklevel=2)
    return cycle


#: Refits of a fitted gait's shape while its amplitude factor is more than this far from 1.
AMPLITUDE_TOLERANCE = 0.01
#: Most fits per cycle in that loop (a secant step: usually two to four).
MAX_SHAPE_FITS = 8
#: The nearest fit is scaled by its factor if that is at most this far from 1; else the amplitude is refused.
AMPLITUDE_LEFTOVER = 0.05


def _secant_bend(log_bend: float, log_factor: float, last: tuple[float, float] | None) -> float:
    """The next log bend: a secant step to log factor 0, or the factor itself first (and where the slope is odd)."""
    step = log_factor
    if last is not None and log_factor != last[1] and log_bend != last[0]:
        slope = (log_factor - last[1]) / (log_bend - last[0])  # about -p: the peak grows as bend ** p
        if -4.0 <= slope <= -0.25:
            step = -log_factor / slope
    return log_bend + step


def _amplitude_factor(spec: GaitSpec, shape: dict, lengths_m: np.ndarray, amplitude_bar: float,
                      robot: RobotDescription) -> float:
    """The factor that scales ``lengths_m`` to peak at ``amplitude_bar``; a straight shape is named as the cause."""
    try:
        return pressure_amplitude_scale(lengths_m, amplitude_bar, robot)
    except InvalidInputError:
        if float(np.max(lengths_m)) > 0.0:
            raise
        raise InvalidInputError(f"{spec.name}: with {_amplitude_text(spec, shape)} the shape is straight, and no "
                                f"amplitude bends a straight shape; give {' or '.join(spec.amplitude_parameters)} a "
                                "value other than 0.") from None


def _amplitude_text(spec: GaitSpec, shape: dict) -> str:
    return ", ".join(f"{name} = {shape[name]:.4g}" for name in spec.amplitude_parameters) or "its parameters"


def _solve_rolling(spec: GaitSpec, given: dict, phase: np.ndarray, peak_m: float, robot: RobotDescription,
                   settings: FitSettings):
    """The exact rolling cycle that peaks at ``peak_m``: (lengths, error mm, shape, parameters, fits, retried)."""
    turns, turn_phase = ROLLING_TURNS[spec.name], given["turn_phase_rad"]
    shape = {**given, "radius_m": rolling_radius_for_peak(peak_m, phase, robot, turns, turn_phase)}
    # A dense polyline: at 4 bar the arc nearly closes a circle and the fitter's 201 points would add 0.2 mm.
    curves, _, used = shape_curves(spec.name, phase, robot, shape, 10 * settings.curve_points)
    lengths = rolling_arc_lengths(phase, shape["radius_m"], robot, turns, turn_phase)
    return lengths, fit_error_mm(lengths, curves, robot), shape, used, 0, 0


def _fit_for_amplitude(spec: GaitSpec, given: dict, phase: np.ndarray, amplitude_bar: float,
                       robot: RobotDescription, settings: FitSettings):
    """Fit, bend the shape by the amplitude factor, refit, until the factor is ~1: the commanded cycle and its error.

    The bend is found by a secant step on log(factor) over log(bend): the peak length grows faster than the
    bend, so bending by the factor itself overshot and oscillated, and after four fits the cycle was a fit
    scaled by up to 28 % (serpentine at 512 samples: 23 mm errors; a helper's review). The fitter may jump
    between near-equal solutions as the bend changes, so the factor need not reach 1: the fit nearest to it is
    taken if it is within :data:`AMPLITUDE_LEFTOVER`, and a shape no bend brings there is refused.
    """
    log_bend, last, tried = 0.0, None, []  # last: (log bend, log factor) of the fit before
    while True:  # without the global retry (slow) until the shape is settled
        shape = spec.bent(given, math.exp(log_bend)) if log_bend else dict(given)
        curves, s_m, used = shape_curves(spec.name, phase, robot, shape, settings.curve_points)
        fit = fit_shapes(curves, s_m, robot, settings, poor_fit_mm=math.inf, periodic=True)
        factor = _amplitude_factor(spec, shape, fit.lengths_m, amplitude_bar, robot)
        tried.append((abs(math.log(factor)), len(tried), (shape, curves, s_m, used, fit, factor)))
        if abs(factor - 1.0) <= AMPLITUDE_TOLERANCE or not spec.amplitude_parameters or len(tried) >= MAX_SHAPE_FITS:
            break
        log_bend, last = _secant_bend(log_bend, math.log(factor), last), (log_bend, math.log(factor))
    fits = len(tried)
    shape, curves, s_m, used, fit, factor = min(tried)[2]
    if spec.amplitude_parameters and abs(factor - 1.0) > AMPLITUDE_LEFTOVER:
        if factor < 1.0:  # too much even at the least bend: what the amplitude parameters do not scale asks for it
            changed = [f"{p.name} = {shape[p.name]:g}" for p in spec.parameters if p.name not in
                       spec.amplitude_parameters and p.name in shape and shape[p.name] != p.default] or ["its defaults"]
            raise InvalidInputError(
                f"{spec.name}: even its least bent shape tried ({_amplitude_text(spec, shape)}) needs "
                f"{amplitude_bar / factor:.2f} bar, more than {amplitude_bar:g} bar: the part of the shape the "
                f"amplitude does not scale ({', '.join(changed)}) asks for that alone; bring it nearer its default "
                "or raise the amplitude.")
        raise InvalidInputError(
            f"{spec.name}: no shape of its kind reaches {amplitude_bar:g} bar in {fits} fits (the nearest "
            f"{factor:.3g} times off, at {_amplitude_text(spec, shape)}): the body cannot bend so; change "
            f"{', '.join(spec.amplitude_parameters)} or the amplitude.")
    if np.any(fit.error_mm > given["poor_fit_mm"]):
        fit = fit_shapes(curves, s_m, robot, settings, poor_fit_mm=given["poor_fit_mm"], periodic=True)
        factor = pressure_amplitude_scale(fit.lengths_m, amplitude_bar, robot)
    retried = len(fit.retried)
    lengths = fit.lengths_m * factor
    error = fit_error_mm(np.clip(lengths, 0.0, robot.max_extension_m), curves, robot)
    return lengths, error, shape, used, fits, retried
