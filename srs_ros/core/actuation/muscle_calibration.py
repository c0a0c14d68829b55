"""Per-muscle calibration of a rig and the length -> pressure maps built on it (no ROS).

A :class:`MuscleCalibration` holds, for every muscle, its static characteristic as ``srs_identify``
measures it (:mod:`srs_ros.core.actuation.identification`)::

    l(P) = extension_per_bar_m * clip(P - deadzone_bar, 0, saturation_bar - deadzone_bar)

and, when identified, the supply line's dynamics (``transport_delay_s``, first-order
``pressure_time_constant_s``), the model of :mod:`srs_ros.core.actuation.muscle_model`. The per-rig file
(docs/identification.md)::

    muscle_calibration:
      rig: sim                            # informational: where it was measured, when, how
      created: '2026-11-21T10:00:00'
      method: steps 0.5..4 bar
      muscles:                            # every joint of the robot once
        m1_pma1: {deadzone_bar: 1.0, extension_per_bar_m: 0.02167, saturation_bar: 4.0,
                  transport_delay_s: 0.03, pressure_time_constant_s: 0.08}
      fit: {m1_pma1: {static_rms_m: 1.0e-05}}   # informational: residuals of the fits

A :class:`PressureMap` turns actuator lengths (m) into pressures (bar) and always ends in the one clamp
(:func:`srs_ros.core.actuation.pressure.clamp_pressures_bar`): :class:`PaperPressureMap` is the paper's
``P = 100 l``, :class:`CalibratedPressureMap` inverts each muscle's static characteristic.
"""

from __future__ import annotations

import abc
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from srs_ros.core.actuation.muscle_model import MUSCLE_OPTIONS
from srs_ros.core.actuation.pressure import (
    clamp_pressures_bar,
    lengths_to_pressures_bar,
    pressure_limit_bar,
    pressure_limited_length_m,
)
from srs_ros.core.errors import ConfigurationError
from srs_ros.core.robot import RobotDescription, default_robot, read_yaml
from srs_ros.core.schema import REQUIRED, Field, Table, check_known, document, mapping, missing, refusal
from srs_ros.core.validation import finite_array

#: Top-level key of a calibration file.
CALIBRATION_SECTION = "muscle_calibration"
#: One muscle's entry of a calibration file: its static characteristic, then (when identified) its dynamics.
MUSCLE_ENTRY = Table(f"{CALIBRATION_SECTION}.muscles.<joint>", (
    MUSCLE_OPTIONS["deadzone_bar"],
    Field("extension_per_bar_m", float, REQUIRED, 1e-5, 1.0, "m/bar", "extension per bar above the deadzone"),
    # Above the highest pressure tested when no knee was seen; beyond 4 bar it is never commanded.
    Field("saturation_bar", float, REQUIRED, 0.0, 100.0, "bar", "pressure of the largest extension"),
    MUSCLE_OPTIONS["transport_delay_s"],
    MUSCLE_OPTIONS["pressure_time_constant_s"],
), description="a mapping of deadzone_bar, extension_per_bar_m, saturation_bar and the dynamics")
#: The static characteristic of a muscle: key -> (lowest, highest) accepted value.
STATIC_KEYS: dict[str, tuple[float, float]] = {
    f.name: (f.minimum, f.maximum)
    for f in MUSCLE_ENTRY.only(("deadzone_bar", "extension_per_bar_m", "saturation_bar"))}
#: The supply line's dynamics of a muscle (the muscle model's ranges).
DYNAMIC_KEYS: dict[str, tuple[float, float]] = {
    f.name: (f.minimum, f.maximum) for f in MUSCLE_ENTRY.only(("transport_delay_s", "pressure_time_constant_s"))}
_INFO_KEYS = ("rig", "created", "method", "fit")
#: Every key of the calibration block.
_BLOCK_KEYS = ("muscles", *_INFO_KEYS)

#: Values of the ``pressure_map`` choice: the paper's P = 100 l, or the rig's calibration.
PAPER_MAP, CALIBRATED_MAP = "paper", "calibrated"


@dataclass(frozen=True)
class MuscleCalibration:
    """Identified muscles of one rig, arrays in the robot's joint order (see the module docstring).

    ``transport_delay_s`` and ``pressure_time_constant_s`` are None where the dynamics were not
    identified (e.g. a rig without pressure read-back calibrated from a ruler table).
    """

    joint_names: tuple[str, ...]
    deadzone_bar: np.ndarray
    extension_per_bar_m: np.ndarray
    saturation_bar: np.ndarray
    transport_delay_s: np.ndarray | None = None
    pressure_time_constant_s: np.ndarray | None = None
    info: dict[str, Any] = field(default_factory=dict)
    source: str = "<calibration>"

    @property
    def has_dynamics(self) -> bool:
        """True when the delay and time constant of every muscle are known."""
        return self.transport_delay_s is not None and self.pressure_time_constant_s is not None

    @property
    def saturation_extension_m(self) -> np.ndarray:
        """Largest static extension of each muscle (m), reached at ``saturation_bar``."""
        return self.extension_per_bar_m * (self.saturation_bar - self.deadzone_bar)

    def extension_m(self, pressure_bar) -> np.ndarray:
        """Static extension (m) of every muscle at ``pressure_bar`` ``(..., n)``: the forward characteristic."""
        pressure = finite_array("pressure_bar", pressure_bar, (len(self.joint_names),), "bar")
        span_bar = self.saturation_bar - self.deadzone_bar
        return self.extension_per_bar_m * np.clip(pressure - self.deadzone_bar, 0.0, span_bar)

    def muscle_values(self, index: int) -> dict[str, float]:
        """The file's values of muscle ``index`` (static keys, and dynamic keys when identified)."""
        keys = list(STATIC_KEYS) + (list(DYNAMIC_KEYS) if self.has_dynamics else [])
        return {key: float(getattr(self, key)[index]) for key in keys}


def calibration_from_values(values: Mapping[str, Mapping[str, float]], robot: RobotDescription,
                            info: Mapping[str, Any] | None = None, source: str = "<calibration>") -> MuscleCalibration:
    """Validate ``{joint name: {key: value}}`` (every joint once) into a :class:`MuscleCalibration`.

    Raises :class:`ConfigurationError` starting with ``source`` and naming the muscle, the key, the
    value and what is expected.
    """
    path = f"{CALIBRATION_SECTION}.muscles"
    values = mapping(values, source, path, f"a mapping of joint name: {{{', '.join(STATIC_KEYS)}, ...}}")
    names = list(robot.joint_names)
    check_known(values, names, source, path)
    absent = [name for name in names if name not in values]
    if absent:
        raise missing(source, f"{path}.{absent[0]}", f"an entry for every joint of the robot {names} (identify "
                                                     "them all, or merge into an existing file)")
    rows = [_muscle_row(values[name], robot, source, name) for name in names]
    with_dynamics = [name for name, row in zip(names, rows) if "transport_delay_s" in row]
    if with_dynamics and len(with_dynamics) != len(names):
        without = next(name for name in names if name not in with_dynamics)
        raise missing(source, f"{path}.{without}.transport_delay_s", f"the dynamics of every muscle or of none "
                                                                     f"({with_dynamics} have them)")
    column = {key: np.array([row[key] for row in rows]) for key in rows[0]}
    return MuscleCalibration(joint_names=tuple(names), info=dict(info or {}), source=source, **column)


def _muscle_row(entry: Any, robot: RobotDescription, source: str, name: str) -> dict[str, float]:
    table = MUSCLE_ENTRY.at(f"{CALIBRATION_SECTION}.muscles.{name}")
    entry = mapping(entry, source, table.path, MUSCLE_ENTRY.description)
    dynamic = [key for key in DYNAMIC_KEYS if key in entry]
    if dynamic and len(dynamic) != len(DYNAMIC_KEYS):
        raise refusal(source, table.key(dynamic[0]), entry[dynamic[0]],
                      f"it with the rest of {list(DYNAMIC_KEYS)} (the identified dynamics), or neither")
    row = table.only([*STATIC_KEYS, *dynamic]).read(entry, source, extra=DYNAMIC_KEYS)
    if row["deadzone_bar"] >= robot.max_pressure_bar:
        raise refusal(source, table.key("deadzone_bar"), row["deadzone_bar"], f"less than the robot's "
                      f"max_pressure_bar = {robot.max_pressure_bar:g} bar, or the muscle never extends")
    if row["saturation_bar"] <= row["deadzone_bar"]:
        raise refusal(source, table.key("saturation_bar"), row["saturation_bar"],
                      f"more than its deadzone_bar = {row['deadzone_bar']:g} bar")
    return row


def calibration_from_dict(data: Any, robot: RobotDescription | None = None,
                          source: str = "<dict>") -> MuscleCalibration:
    """Validate a parsed calibration file (with its top-level ``muscle_calibration:`` key)."""
    robot = robot or default_robot()
    section_ = document(data, CALIBRATION_SECTION, source, what="a mapping with muscles: one entry per joint with "
                        "deadzone_bar, extension_per_bar_m, saturation_bar, ... (srs_identify writes it)",
                        sections=_BLOCK_KEYS)
    check_known(section_, _BLOCK_KEYS, source, CALIBRATION_SECTION)
    info = {key: section_[key] for key in _INFO_KEYS if key in section_}
    return calibration_from_values(section_.get("muscles"), robot, info, source)


def load_calibration(path: str | Path, robot: RobotDescription | None = None) -> MuscleCalibration:
    """Load and validate a rig's calibration file (written by ``srs_identify``)."""
    return calibration_from_dict(read_yaml(path), robot, source=str(path))


def calibration_to_dict(calibration: MuscleCalibration) -> dict[str, Any]:
    """The file's content (plain Python types) of ``calibration``."""
    muscles = {name: {key: float(f"{value:.7g}") for key, value in calibration.muscle_values(i).items()}
               for i, name in enumerate(calibration.joint_names)}
    return {CALIBRATION_SECTION: {**{k: v for k, v in calibration.info.items() if k != "fit"}, "muscles": muscles,
                                  **({"fit": calibration.info["fit"]} if "fit" in calibration.info else {})}}


def save_calibration(calibration: MuscleCalibration, path: str | Path, header: str = "") -> None:
    """Write ``calibration`` as YAML to ``path`` (``header``: comment lines put on top)."""
    text = yaml.safe_dump(calibration_to_dict(calibration), sort_keys=False, default_flow_style=None, width=120)
    comment = "".join(f"# {line}\n" for line in header.splitlines())
    Path(path).write_text(comment + text, encoding="utf-8")


class PressureMap(abc.ABC):
    """Actuator lengths (m) -> regulator pressures (bar), ending in the one clamp.

    Lengths are first limited to ``[0, limited_length_m]`` (per muscle: the longest length the map
    commands within the pressure limit), so a huge finite setpoint cannot overflow; a zero length is
    0 bar, so a zero setpoint vents.
    """

    #: Name of the map (``pressure_map`` parameter value).
    name: str = "abstract"

    def __init__(self, robot: RobotDescription):
        """A map for ``robot`` (its joint count and pressure limit)."""
        self.robot = robot

    @property
    @abc.abstractmethod
    def limited_length_m(self) -> np.ndarray:
        """Per muscle, the longest length (m) the map commands within the pressure limit; longer ones are limited."""

    @abc.abstractmethod
    def reference_pressures_bar(self, lengths_m) -> np.ndarray:
        """Pressures (bar) for lengths ``(..., 9)`` (m), within ``[0, limit]`` but not yet through the clamp."""

    @property
    @abc.abstractmethod
    def gain_bar_per_m(self) -> np.ndarray:
        """Per muscle, dP/dl (bar/m) of the map where the muscle extends (between 0 and its limited length)."""

    @abc.abstractmethod
    def describe(self) -> str:
        """How lengths become pressures, for people (log lines, diagnostics)."""

    def pressures_bar(self, lengths_m) -> np.ndarray:
        """Commanded pressures (bar) for lengths ``(..., 9)`` (m), through the one clamp."""
        return clamp_pressures_bar(self.reference_pressures_bar(lengths_m), self.robot)

    def _lengths(self, lengths_m) -> np.ndarray:
        return finite_array("lengths_m", lengths_m, (self.robot.joint_count,), "m")


class PaperPressureMap(PressureMap):
    """The paper's planning map ``P = 100 l`` (robot's ``pressure_per_length_bar_per_m`` and deadzone offset)."""

    name = PAPER_MAP

    @property
    def limited_length_m(self) -> np.ndarray:
        """0.04 m for every muscle at 4 bar with ``P = 100 l``."""
        return np.full(self.robot.joint_count, pressure_limited_length_m(self.robot))

    def reference_pressures_bar(self, lengths_m) -> np.ndarray:
        """``P = gain * l`` (+ the deadzone offset where extending), :func:`lengths_to_pressures_bar`."""
        return lengths_to_pressures_bar(lengths_m, self.robot)

    @property
    def gain_bar_per_m(self) -> np.ndarray:
        """100 bar/m for every muscle."""
        return np.full(self.robot.joint_count, self.robot.pressure_per_length_bar_per_m)

    def describe(self) -> str:
        """E.g. ``P = 100 l``."""
        offset = self.robot.deadzone_offset_bar
        return f"P = {self.robot.pressure_per_length_bar_per_m:g} l" + (f" + {offset:g} bar" if offset else "")


class CalibratedPressureMap(PressureMap):
    """Each muscle's static characteristic inverted: ``P = deadzone_bar + l / extension_per_bar_m`` for l > 0.

    A muscle reaches its ``saturation_extension_m`` at ``saturation_bar`` (0.065 m at 4 bar for the
    simulated ones); lengths beyond what the pressure limit reaches are limited to it.
    """

    name = CALIBRATED_MAP

    def __init__(self, calibration: MuscleCalibration, robot: RobotDescription):
        """The map of ``calibration``, whose muscles must be ``robot``'s joints."""
        super().__init__(robot)
        if tuple(calibration.joint_names) != tuple(robot.joint_names):
            raise ConfigurationError(f"{calibration.source}: calibrated muscles {list(calibration.joint_names)}; "
                                     f"expected the robot's joints {list(robot.joint_names)}.")
        self.calibration = calibration
        top_bar = np.minimum(calibration.saturation_bar, pressure_limit_bar(robot))
        self._limited_m = calibration.extension_per_bar_m * np.maximum(top_bar - calibration.deadzone_bar, 0.0)

    @property
    def limited_length_m(self) -> np.ndarray:
        """Per muscle: its extension at the pressure limit or at saturation, whichever comes first."""
        return self._limited_m.copy()

    def reference_pressures_bar(self, lengths_m) -> np.ndarray:
        """``P = P_dz + l / g`` for ``0 < l <= limited_length_m``, 0 bar for ``l <= 0``."""
        lengths = np.clip(self._lengths(lengths_m), 0.0, self._limited_m)
        cal = self.calibration
        return np.where(lengths > 0.0, cal.deadzone_bar + lengths / cal.extension_per_bar_m, 0.0)

    @property
    def gain_bar_per_m(self) -> np.ndarray:
        """``1 / extension_per_bar_m`` of each muscle."""
        return 1.0 / self.calibration.extension_per_bar_m

    def describe(self) -> str:
        """E.g. ``the calibrated map of sim_muscles.yaml (P = 1.00 bar + l / 0.0217 m/bar, mean of 9 muscles)``."""
        cal = self.calibration
        return (f"the calibrated map of {cal.source} (P = {np.mean(cal.deadzone_bar):.2f} bar + l / "
                f"{np.mean(cal.extension_per_bar_m):.4f} m/bar, mean of {len(cal.joint_names)} muscles)")


def pressure_map(name: str, robot: RobotDescription, calibration: MuscleCalibration | None = None) -> PressureMap:
    """The map called ``name`` (:data:`PAPER_MAP` or :data:`CALIBRATED_MAP`, which needs ``calibration``)."""
    if name == PAPER_MAP:
        return PaperPressureMap(robot)
    if name == CALIBRATED_MAP:
        if calibration is None:
            raise ConfigurationError(f"pressure_map '{CALIBRATED_MAP}' needs a calibration file (calibration_file); "
                                     "make one with srs_identify --rig FILE.")
        return CalibratedPressureMap(calibration, robot)
    raise ConfigurationError(f"pressure_map: {name!r}; expected '{PAPER_MAP}' (P = 100 l) or '{CALIBRATED_MAP}' "
                             "(the rig's calibration file).")
