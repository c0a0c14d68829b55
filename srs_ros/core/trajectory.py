"""Joint-space gait cycles: a gait's shapes fitted over one cycle, scaled to a pressure amplitude, timed.

:func:`generate_cycle` is the one entry point (paper Sec. III): it samples the gait's task-space
shape at N phases, fits the body to every shape (:mod:`srs_ros.core.fitting`, paper eq. 3), scales
the joint-space cycle to the requested pressure amplitude and times it by the frequency. The result,
a :class:`GaitCycle`, plays back smoothly by periodic cubic interpolation in phase and round-trips
through CSV.

Amplitude (CONVENTIONS.md): the gait's reference shape (its parameters, e.g. ``radius_m``) is fitted;
the fitted lengths are then multiplied by one factor ``k`` (:func:`pressure_amplitude_scale`) so
that the largest pressure of the cycle, ``P = 100 l`` (+ the optional deadzone offset), is exactly A.
Lengths scale the bending vectors linearly, so a larger A bends more (a smaller rolling radius, a
larger serpentine wave) as in the paper; ``fit_error_mm`` is the error of the fitted reference shape.
If ``k * l`` would exceed ``max_extension_m`` the request is refused (it cannot be reached).
"""

from __future__ import annotations

import csv
import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from srs_ros.core.actuation import lengths_to_pressures_bar, pressure_amplitude_scale
from srs_ros.core.errors import InvalidInputError
from srs_ros.core.fitting import FitSettings, fit_shapes
from srs_ros.core.gaits import GaitSpec, gait_curves, gait_spec, gaits_config, list_gaits
from srs_ros.core.interpolation import PeriodicTrajectory
from srs_ros.core.robot import CYCLE_FREQUENCY_RANGE_HZ, RobotDescription, default_robot

__all__ = ["GaitCycle", "GaitSpec", "generate_cycle", "list_gaits", "fit_settings", "MIN_SAMPLES"]

#: Fewest samples per cycle accepted (the periodic spline and the fit's warm starts need a few).
MIN_SAMPLES = 8


class PoorFitWarning(UserWarning):
    """Some samples of a cycle could not be fitted within the gait's ``poor_fit_mm``."""


def fit_settings() -> FitSettings:
    """The fitter settings of ``config/gaits.yaml`` (section ``fitting:``)."""
    return FitSettings.from_config(gaits_config().get("fitting"))


@dataclass(frozen=True, eq=False)
class GaitCycle:
    """One joint-space cycle of a gait, ready to play (sample ``i`` at phase ``i / N``).

    ``lengths_m`` (N, 9) actuator length changes in joint order ``joint_names``, within
    ``[0, max_extension_m]``; ``fit_error_mm`` (N,) RMS distance of the 31 backbone points to the
    gait shape (of the fitted reference shape); ``poor_samples`` samples still poor after the retry;
    ``parameters`` the gait parameters used, with derived values (``amplitude_scale``, ...).
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
        return (f"{self.gait}: A = {self.amplitude_bar:g} bar, f = {self.frequency_hz:g} Hz, N = {self.sample_count}, "
                f"fit error mean {float(np.mean(self.fit_error_mm)):.3f} mm, worst "
                f"{float(np.max(self.fit_error_mm)):.3f} mm, {poor}")

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
        with path.open("w", newline="", encoding="utf-8") as stream:
            writer = csv.writer(stream)
            writer.writerow(self.csv_header())
            for row in rows:
                writer.writerow([repr(float(v)) for v in row[:-1]] + [int(row[-1])])
        meta = {"gait": self.gait, "amplitude_bar": float(self.amplitude_bar),
                "frequency_hz": float(self.frequency_hz), "joint_names": list(self.joint_names),
                "poor_samples": [int(i) for i in self.poor_samples],
                "parameters": {k: _plain(v) for k, v in self.parameters.items()}}
        _sidecar(path).write_text(yaml.safe_dump(meta, sort_keys=False), encoding="utf-8")
        return path

    @classmethod
    def from_csv(cls, path: str | Path, robot: RobotDescription | None = None) -> GaitCycle:
        """Read a cycle written by :meth:`to_csv` (the sidecar, if missing, is inferred from the columns)."""
        robot = robot or default_robot()
        path = Path(path)
        try:
            with path.open("r", newline="", encoding="utf-8") as stream:
                reader = csv.reader(stream)
                header = next(reader)
                table = [row for row in reader if row]
        except (OSError, StopIteration) as exc:
            raise InvalidInputError(f"{path}: cannot read a trajectory CSV ({exc}).") from None
        needed = ["phase", "time_s", *robot.joint_names, "fit_error_mm"]
        missing = [name for name in needed if name not in header]
        if missing:
            raise InvalidInputError(f"{path}: missing column(s) {missing}; expected at least {needed}.")
        try:
            data = np.array([[float(row[header.index(n)]) for n in needed] for row in table])
        except (ValueError, IndexError) as exc:
            raise InvalidInputError(f"{path}: a row is not numeric or is short ({exc}).") from None
        meta: dict[str, Any] = {}
        if _sidecar(path).is_file():
            meta = yaml.safe_load(_sidecar(path).read_text(encoding="utf-8")) or {}
        lengths = data[:, 2:2 + robot.joint_count]
        if "frequency_hz" in meta:
            frequency = float(meta["frequency_hz"])
        elif len(data) > 1 and data[1, 1] > data[0, 1]:
            frequency = 1.0 / (len(data) * (data[1, 1] - data[0, 1]))
        else:
            raise InvalidInputError(f"{path}: cannot infer the frequency (no sidecar {_sidecar(path).name}, "
                                    "time_s not increasing).")
        amplitude = float(meta.get("amplitude_bar", float(lengths_to_pressures_bar(lengths, robot).max())))
        poor = tuple(int(i) for i in meta.get("poor_samples", ()))
        if not meta and "poor" in header:
            poor = tuple(i for i, row in enumerate(table) if int(float(row[header.index("poor")])))
        return cls(gait=str(meta.get("gait", path.stem)), amplitude_bar=amplitude, frequency_hz=frequency,
                   lengths_m=lengths, fit_error_mm=data[:, -1], poor_samples=poor,
                   parameters=dict(meta.get("parameters", {})), joint_names=tuple(robot.joint_names), robot=robot)


def _sidecar(path: Path) -> Path:
    return path.with_name(path.name + ".yaml")


def _plain(value: Any) -> Any:
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return value.item()
    return value


def _check_request(gait: str, amplitude_bar: float, frequency_hz: float, samples: int,
                   robot: RobotDescription) -> GaitSpec:
    spec = gait_spec(gait)
    low_hz, high_hz = CYCLE_FREQUENCY_RANGE_HZ
    if isinstance(amplitude_bar, bool) or not isinstance(amplitude_bar, (int, float, np.number)) or not (
            math.isfinite(amplitude_bar) and robot.deadzone_offset_bar < amplitude_bar <= robot.max_pressure_bar):
        raise InvalidInputError(
            f"amplitude_bar: expected a pressure in ({robot.deadzone_offset_bar:g}, {robot.max_pressure_bar:g}] bar "
            f"(the largest pressure of the cycle), got {amplitude_bar!r}.")
    if isinstance(frequency_hz, bool) or not isinstance(frequency_hz, (int, float, np.number)) or not (
            math.isfinite(frequency_hz) and low_hz <= frequency_hz <= high_hz):
        raise InvalidInputError(f"frequency_hz: expected a cycle frequency in [{low_hz:g}, {high_hz:g}] Hz (the paper "
                                f"uses 0.25-1.0), got {frequency_hz!r}.")
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < MIN_SAMPLES:
        raise InvalidInputError(f"samples: expected an integer >= {MIN_SAMPLES} samples per cycle (default 64), "
                                f"got {samples!r}.")
    return spec


def generate_cycle(gait: str, amplitude_bar: float, frequency_hz: float, samples: int = 64,
                   robot: RobotDescription | None = None, params: Mapping[str, Any] | None = None) -> GaitCycle:
    """Fit ``gait`` over one cycle of ``samples`` shapes, scale it to ``amplitude_bar``, time it by ``frequency_hz``.

    Raises :class:`InvalidInputError` for an unknown gait, ``amplitude_bar`` outside
    ``(0, max_pressure_bar]``, ``frequency_hz <= 0``, ``samples < 8``, or unknown/out-of-range gait
    parameters (the message lists what is allowed). Samples whose fit stays poor after the global
    retry are listed in ``poor_samples`` and a :class:`PoorFitWarning` is issued.
    """
    robot = robot or default_robot()
    spec = _check_request(gait, amplitude_bar, frequency_hz, samples, robot)
    settings = fit_settings()
    phase = np.arange(samples) / samples
    curves, s_m, used = gait_curves(spec.name, phase, robot, params, settings.curve_points)
    fit = fit_shapes(curves, s_m, robot, settings, poor_fit_mm=used["poor_fit_mm"], periodic=True)
    reference_peak_bar = float(fit.lengths_m.max()) * robot.pressure_per_length_bar_per_m
    scale = pressure_amplitude_scale(fit.lengths_m, float(amplitude_bar), robot)
    lengths = fit.lengths_m * scale
    if lengths.max() > robot.max_extension_m * (1.0 + 1e-9):
        raise InvalidInputError(
            f"amplitude_bar: {amplitude_bar:g} bar needs {lengths.max() * 1e3:.1f} mm of extension, more than the "
            f"{robot.max_extension_m * 1e3:.1f} mm an actuator has; ask for less amplitude or a gentler shape.")
    lengths = np.clip(lengths, 0.0, robot.max_extension_m)
    poor = tuple(int(i) for i in np.flatnonzero(fit.poor))
    used = {**used, "samples": int(samples), "amplitude_scale": float(scale),
            "reference_peak_bar": reference_peak_bar, "retried_samples": len(fit.retried)}
    cycle = GaitCycle(gait=spec.name, amplitude_bar=float(amplitude_bar), frequency_hz=float(frequency_hz),
                      lengths_m=lengths, fit_error_mm=fit.error_mm, poor_samples=poor, parameters=used,
                      joint_names=tuple(robot.joint_names), robot=robot)
    if poor:
        warnings.warn(f"{cycle.summary()}: samples {list(poor)} fit worse than poor_fit_mm = "
                      f"{used['poor_fit_mm']:g} mm "
                      "after the global retry; check the shape parameters (the body may not reach this shape).",
                      PoorFitWarning, stacklevel=2)
    return cycle
