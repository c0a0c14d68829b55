"""The robot description: one dataclass, loaded from ``config/robot.yaml``, that feeds every module.

Constants of the robot (geometry, limits, pressure map, regulator range) live only in the YAML file;
code reads them from a :class:`RobotDescription` and never repeats them as literals.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from srs_ros.core.errors import ConfigurationError

#: Absolute ceiling of any commanded pressure, whatever a config file says (docs/conventions.md).
ABSOLUTE_MAX_PRESSURE_BAR = 4.0
#: Gait cycle frequencies every tool accepts (Hz): the paper plays 0.25-1 Hz; above 5 Hz the muscles
#: cannot follow, below 0.01 Hz a "cycle" is a posture held at pressure for minutes.
CYCLE_FREQUENCY_RANGE_HZ = (0.01, 5.0)

PACKAGE_NAME = "srs_ros"


@dataclass(frozen=True)
class RegulatorModel:
    """A proportional pressure regulator whose 0..command_full_scale_v input spans 0..full scale."""

    name: str
    full_scale_pressure_bar: float
    command_full_scale_v: float
    supply_margin_bar: float


@dataclass(frozen=True)
class RobotDescription:
    """Geometry, limits and actuation map of the SRS (docs/conventions.md, paper Sec. II-A and IV-B)."""

    name: str
    module_count: int
    actuators_per_module: int
    unactuated_length_m: float
    actuator_radius_m: float
    max_extension_m: float
    module_twist_rad: float
    mounting_offset_m: float
    mass_kg: float
    backbone_points_per_module: int
    joint_names: tuple[str, ...]
    pressure_per_length_bar_per_m: float
    max_pressure_bar: float
    deadzone_bar: float
    deadzone_offset_bar: float
    supply_pressure_bar: float
    regulator: RegulatorModel
    source: str = field(default="<defaults>", compare=False)

    @property
    def joint_count(self) -> int:
        """Number of actuators (joint-space dimension), 9 for the paper's robot."""
        return self.module_count * self.actuators_per_module

    @property
    def actuator_angles_rad(self) -> np.ndarray:
        """theta_j = (j-1) * 2 pi / n: angle of actuator j about the module's +Z, actuator 1 on +X."""
        n = self.actuators_per_module
        return np.arange(n) * (2.0 * math.pi / n)

    @property
    def body_length_xi(self) -> float:
        """Largest body coordinate xi (one unit per module)."""
        return float(self.module_count)

    @property
    def backbone_xi(self) -> np.ndarray:
        """The default backbone samples: xi = 0, 1/n, ..., module_count (31 points for 3 x 10)."""
        count = self.module_count * self.backbone_points_per_module + 1
        return np.linspace(0.0, self.body_length_xi, count)

    @property
    def joint_index(self) -> dict[str, int]:
        """Joint name -> index in q."""
        return {name: i for i, name in enumerate(self.joint_names)}

    @property
    def command_full_scale_pressure_bar(self) -> float:
        """Pressure that the regulator's full-scale command (10 V) sets."""
        return self.regulator.full_scale_pressure_bar


_ROBOT_KEYS: dict[str, tuple[type, str]] = {
    "name": (str, "a name"),
    "module_count": (int, "an integer >= 1"),
    "actuators_per_module": (int, "an integer >= 3"),
    "unactuated_length_m": (float, "a length > 0 in metres"),
    "actuator_radius_m": (float, "a radius > 0 in metres"),
    "max_extension_m": (float, "a length > 0 in metres"),
    "module_twist_rad": (float, "an angle in radians"),
    "mounting_offset_m": (float, "a length >= 0 in metres"),
    "mass_kg": (float, "a mass > 0 in kg"),
    "backbone_points_per_module": (int, "an integer >= 1"),
    "joint_names": (list, "a list of unique joint names, one per actuator"),
}
_ACTUATION_KEYS: dict[str, tuple[type, str]] = {
    "pressure_per_length_bar_per_m": (float, "a gain > 0 in bar per metre"),
    "max_pressure_bar": (float, f"a pressure in (0, {ABSOLUTE_MAX_PRESSURE_BAR}] bar"),
    "deadzone_bar": (float, "a pressure >= 0 in bar"),
    "deadzone_offset_bar": (float, "a pressure >= 0 in bar (0 = off)"),
    "supply_pressure_bar": (float, "a pressure > 0 in bar"),
    "regulator_model": (str, "the name of an entry of regulator_models"),
}
_REGULATOR_KEYS: dict[str, tuple[type, str]] = {
    "full_scale_pressure_bar": (float, "a pressure > 0 in bar"),
    "command_full_scale_v": (float, "a voltage > 0 in volts"),
    "supply_margin_bar": (float, "a pressure >= 0 in bar"),
}


def _typed(section: Mapping[str, Any], key: str, spec: tuple[type, str], where: str) -> Any:
    if key not in section:
        raise ConfigurationError(f"{where}: missing key '{key}' (expected {spec[1]}).")
    value = section[key]
    kind, expected = spec
    if kind is float and isinstance(value, (int, float)) and not isinstance(value, bool):
        value = float(value)
        if not math.isfinite(value):
            raise ConfigurationError(f"{where}: '{key}' is {value!r}; expected {expected}.")
        return value
    if not isinstance(value, kind) or isinstance(value, bool):
        raise ConfigurationError(
            f"{where}: '{key}' is {value!r} ({type(value).__name__}); expected {expected}."
        )
    return value


def _section(data: Mapping[str, Any], key: str, where: str) -> Mapping[str, Any]:
    section = data.get(key) if isinstance(data, Mapping) else None
    if not isinstance(section, Mapping):
        raise ConfigurationError(f"{where}: missing section '{key}:' (a mapping of keys to values).")
    return section


def _check(condition: bool, where: str, key: str, value: Any, expected: str) -> None:
    if not condition:
        raise ConfigurationError(f"{where}: '{key}' is {value!r}; expected {expected}.")


def robot_from_dict(data: Mapping[str, Any], source: str = "<dict>") -> RobotDescription:
    """Build and validate a :class:`RobotDescription` from the parsed YAML mapping.

    Raises :class:`ConfigurationError` naming the key, the value found and the value expected.
    """
    robot_section = _section(data, "robot", source)
    act_section = _section(data, "actuation", source)
    models_section = _section(data, "regulator_models", source)
    where_r, where_a = f"{source} [robot]", f"{source} [actuation]"
    robot = {k: _typed(robot_section, k, s, where_r) for k, s in _ROBOT_KEYS.items()}
    act = {k: _typed(act_section, k, s, where_a) for k, s in _ACTUATION_KEYS.items()}

    for key in ("unactuated_length_m", "actuator_radius_m", "max_extension_m", "mass_kg"):
        _check(robot[key] > 0, where_r, key, robot[key], _ROBOT_KEYS[key][1])
    _check(robot["mounting_offset_m"] >= 0, where_r, "mounting_offset_m",
           robot["mounting_offset_m"], _ROBOT_KEYS["mounting_offset_m"][1])
    _check(robot["module_count"] >= 1, where_r, "module_count", robot["module_count"], "an integer >= 1")
    _check(robot["actuators_per_module"] >= 3, where_r, "actuators_per_module",
           robot["actuators_per_module"], "an integer >= 3")
    _check(robot["backbone_points_per_module"] >= 1, where_r, "backbone_points_per_module",
           robot["backbone_points_per_module"], "an integer >= 1")
    names = robot["joint_names"]
    count = robot["module_count"] * robot["actuators_per_module"]
    _check(len(names) == count and len(set(names)) == count and all(isinstance(n, str) for n in names),
           where_r, "joint_names", names, f"{count} unique names (module_count x actuators_per_module)")

    _check(act["pressure_per_length_bar_per_m"] > 0, where_a, "pressure_per_length_bar_per_m",
           act["pressure_per_length_bar_per_m"], _ACTUATION_KEYS["pressure_per_length_bar_per_m"][1])
    _check(0 < act["max_pressure_bar"] <= ABSOLUTE_MAX_PRESSURE_BAR, where_a, "max_pressure_bar",
           act["max_pressure_bar"], _ACTUATION_KEYS["max_pressure_bar"][1])
    for key in ("deadzone_bar", "deadzone_offset_bar"):
        _check(act[key] >= 0, where_a, key, act[key], _ACTUATION_KEYS[key][1])
    _check(act["deadzone_offset_bar"] < act["max_pressure_bar"], where_a, "deadzone_offset_bar",
           act["deadzone_offset_bar"], "a pressure below max_pressure_bar")

    model_name = act["regulator_model"]
    if model_name not in models_section:
        raise ConfigurationError(
            f"{where_a}: 'regulator_model' is {model_name!r}; expected one of "
            f"{sorted(models_section)} (the keys of regulator_models)."
        )
    where_m = f"{source} [regulator_models.{model_name}]"
    model_data = models_section[model_name]
    if not isinstance(model_data, Mapping):
        raise ConfigurationError(f"{where_m}: expected a mapping with {sorted(_REGULATOR_KEYS)}.")
    model = {k: _typed(model_data, k, s, where_m) for k, s in _REGULATOR_KEYS.items()}
    for key in ("full_scale_pressure_bar", "command_full_scale_v"):
        _check(model[key] > 0, where_m, key, model[key], _REGULATOR_KEYS[key][1])
    _check(model["full_scale_pressure_bar"] >= act["max_pressure_bar"], where_m,
           "full_scale_pressure_bar", model["full_scale_pressure_bar"],
           f"at least max_pressure_bar = {act['max_pressure_bar']} bar (the regulator must reach it)")
    needed = act["max_pressure_bar"] + model["supply_margin_bar"]
    _check(act["supply_pressure_bar"] >= needed, where_a, "supply_pressure_bar",
           act["supply_pressure_bar"], f"at least max_pressure_bar + supply_margin_bar = {needed} bar")

    return RobotDescription(
        **{k: v for k, v in robot.items() if k != "joint_names"},
        joint_names=tuple(names),
        **{k: v for k, v in act.items() if k != "regulator_model"},
        regulator=RegulatorModel(name=model_name, **model),
        source=source,
    )


def config_dir() -> Path:
    """The folder holding srs_ros's YAML files: the source tree's ``config/`` or ``share/srs_ros/config``.

    Works from a source checkout, an editable or wheel install and a colcon install, without ROS.
    """
    here = Path(__file__).resolve()
    for parent in here.parents:
        for candidate in (parent / "config", parent / "share" / PACKAGE_NAME / "config"):
            if (candidate / "robot.yaml").is_file():
                return candidate
    raise ConfigurationError(
        f"cannot find {PACKAGE_NAME}'s config folder (robot.yaml) above {here}; "
        "pass the file explicitly (robot_description_file)."
    )


def config_file(path: str | Path) -> Path:
    """A file named in a config: as given if absolute or found from the working directory, else in config/."""
    path = Path(path).expanduser()
    return path if path.is_absolute() or path.exists() else config_dir() / path


def read_yaml(path: str | Path) -> Any:
    """Parse a YAML file, raising :class:`ConfigurationError` with the path on any failure."""
    path = Path(path)
    # A FIFO or device as a config file would block the reader (and a node's executor) forever.
    if path.exists() and not path.is_file():
        raise ConfigurationError(f"{path}: not a regular file (a directory, pipe or device); "
                                 "expected a YAML file.")
    try:
        with path.open("r", encoding="utf-8") as stream:
            return yaml.safe_load(stream)
    except FileNotFoundError:
        raise ConfigurationError(f"{path}: no such file.") from None
    except (OSError, yaml.YAMLError) as exc:
        raise ConfigurationError(f"{path}: cannot be read as YAML ({exc}).") from exc


def load_robot(path: str | Path | None = None) -> RobotDescription:
    """Load the robot description from ``path`` (default: ``config/robot.yaml`` of the package)."""
    path = Path(path) if path else config_dir() / "robot.yaml"
    return _load_robot_cached(str(path.resolve()), path.stat().st_mtime_ns if path.exists() else 0)


@lru_cache(maxsize=8)
def _load_robot_cached(path: str, _mtime_ns: int) -> RobotDescription:
    return robot_from_dict(read_yaml(path), source=path)


def default_robot() -> RobotDescription:
    """The package's own robot description (cached)."""
    return load_robot(None)
