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
from srs_ros.core.schema import Field, Table, check_known, refusal, section

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


#: The ``robot:`` section of a robot file: geometry and mass.
#: The top-level sections of a robot description (robot.yaml); any other top-level key is refused.
ROBOT_SECTIONS = ("robot", "actuation", "regulator_models")

ROBOT_TABLE = Table("robot", (
    Field("name", str, description="name of the robot"),
    Field("module_count", int, minimum=1, unit="modules", description="soft modules in series, tail first"),
    Field("actuators_per_module", int, minimum=3, unit="actuators", description="extending PMAs per module"),
    Field("unactuated_length_m", float, minimum=0.0, above_minimum=True, unit="m", description="L0 of a module"),
    Field("actuator_radius_m", float, minimum=0.0, above_minimum=True, unit="m",
          description="r, distance of the actuators from the module axis"),
    Field("max_extension_m", float, minimum=0.0, above_minimum=True, unit="m", description="largest extension"),
    Field("module_twist_rad", float, unit="rad", description="sigma, twist between modules"),
    Field("mounting_offset_m", float, minimum=0.0, unit="m", description="delta, offset between modules"),
    Field("mass_kg", float, minimum=0.0, above_minimum=True, unit="kg", description="mass of the body"),
    Field("backbone_points_per_module", int, minimum=1, unit="points", description="backbone samples per module"),
    Field("joint_names", list, item=str, description="one unique name per actuator, module by module"),
), description="a mapping of the robot's geometry (name, module_count, ...)")
#: The ``actuation:`` section: the planning map, the pressure limit, the deadzone and the supply.
ACTUATION_TABLE = Table("actuation", (
    Field("pressure_per_length_bar_per_m", float, minimum=0.0, above_minimum=True, unit="bar/m",
          description="planning map P = k l"),
    Field("max_pressure_bar", float, minimum=0.0, maximum=ABSOLUTE_MAX_PRESSURE_BAR, above_minimum=True,
          unit="bar", description="hard limit of every command"),
    Field("deadzone_bar", float, minimum=0.0, unit="bar", description="no extension below this pressure"),
    Field("deadzone_offset_bar", float, minimum=0.0, unit="bar",
          description="added to every non-zero command (0 = off)"),
    Field("supply_pressure_bar", float, minimum=0.0, above_minimum=True, unit="bar", description="compressor"),
    Field("regulator_model", str, description="the name of an entry of regulator_models"),
), description="a mapping of the actuation constants (max_pressure_bar, ...)")
#: One entry of ``regulator_models:``.
REGULATOR_TABLE = Table("regulator_models.<model>", (
    Field("full_scale_pressure_bar", float, minimum=0.0, above_minimum=True, unit="bar",
          description="pressure at the full-scale command"),
    Field("command_full_scale_v", float, minimum=0.0, above_minimum=True, unit="V",
          description="full-scale command voltage"),
    Field("supply_margin_bar", float, minimum=0.0, unit="bar", description="supply needed above the output"),
), description="a mapping of full_scale_pressure_bar, command_full_scale_v, supply_margin_bar")


def robot_from_dict(data: Mapping[str, Any], source: str = "<dict>") -> RobotDescription:
    """Build and validate a :class:`RobotDescription` from the parsed YAML mapping.

    Raises :class:`ConfigurationError` naming the file, the key, the value found and the value expected
    (:mod:`srs_ros.core.schema`).
    """
    if isinstance(data, Mapping):  # a key at the top instead of under its section would be silently ignored
        check_known(data, ROBOT_SECTIONS, source)
    robot = _geometry(data, source)
    act = _actuation(data, source)
    regulator = _regulator(data, act, source)
    return RobotDescription(
        **{k: v for k, v in robot.items() if k != "joint_names"},
        joint_names=tuple(robot["joint_names"]),
        **{k: v for k, v in act.items() if k != "regulator_model"},
        regulator=regulator,
        source=source,
    )


def _geometry(data: Mapping[str, Any], source: str) -> dict[str, Any]:
    """The ``robot:`` section, with one unique joint name per actuator."""
    robot = ROBOT_TABLE.read(section(data, "robot", source, what=ROBOT_TABLE.description), source)
    names = robot["joint_names"]
    count = robot["module_count"] * robot["actuators_per_module"]
    if len(names) != count or len(set(names)) != count:
        raise refusal(source, ROBOT_TABLE.key("joint_names"), list(names),
                      f"{count} unique names (module_count x actuators_per_module)")
    return robot


def _actuation(data: Mapping[str, Any], source: str) -> dict[str, Any]:
    """The ``actuation:`` section, its deadzone offset below the pressure limit."""
    act = ACTUATION_TABLE.read(section(data, "actuation", source, what=ACTUATION_TABLE.description), source)
    if act["deadzone_offset_bar"] >= act["max_pressure_bar"]:
        raise refusal(source, ACTUATION_TABLE.key("deadzone_offset_bar"), act["deadzone_offset_bar"],
                      f"a pressure below max_pressure_bar = {act['max_pressure_bar']:g} bar")
    return act


def _regulator(data: Mapping[str, Any], act: Mapping[str, Any], source: str) -> RegulatorModel:
    """The regulator model the actuation names: it reaches the pressure limit, the supply feeds it."""
    models = section(data, "regulator_models", source, what="a mapping of model name: {full_scale_pressure_bar, ...}")
    name = act["regulator_model"]
    if name not in models:
        raise refusal(source, ACTUATION_TABLE.key("regulator_model"), name,
                      f"one of {sorted(models)} (the keys of regulator_models)")
    for other in models:  # every model is checked, not only the one chosen now: a rig may choose another
        REGULATOR_TABLE.at(f"regulator_models.{other}").read(models[other], source)
    table = REGULATOR_TABLE.at(f"regulator_models.{name}")
    model = table.read(models[name], source)
    limit_bar = act["max_pressure_bar"]
    if model["full_scale_pressure_bar"] < limit_bar:
        raise refusal(source, table.key("full_scale_pressure_bar"), model["full_scale_pressure_bar"],
                      f"at least max_pressure_bar = {limit_bar:g} bar (the regulator must reach it)")
    needed_bar = limit_bar + model["supply_margin_bar"]
    if act["supply_pressure_bar"] < needed_bar:
        raise refusal(source, ACTUATION_TABLE.key("supply_pressure_bar"), act["supply_pressure_bar"],
                      f"at least max_pressure_bar + supply_margin_bar = {needed_bar:g} bar")
    return RegulatorModel(name=name, **model)


#: The package's robot description file, in :func:`config_dir`.
ROBOT_FILE = "robot.yaml"


def amplitude_field(robot: RobotDescription) -> Field:
    """A cycle's pressure amplitude: above the robot's deadzone offset, at most its limit (also the default)."""
    return Field("amplitude_bar", float, robot.max_pressure_bar, robot.deadzone_offset_bar, robot.max_pressure_bar,
                 unit="bar", description="largest pressure of the cycle", above_minimum=True)


def config_dir() -> Path:
    """The folder holding srs_ros's YAML files: the source tree's ``config/`` or ``share/srs_ros/config``.

    Works from a source checkout, an editable or wheel install and a colcon install, without ROS.
    """
    here = Path(__file__).resolve()
    for parent in here.parents:
        for candidate in (parent / "config", parent / "share" / PACKAGE_NAME / "config"):
            if (candidate / ROBOT_FILE).is_file():
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
    except UnicodeDecodeError as exc:
        raise ConfigurationError(f"{path}: not UTF-8 text (byte {exc.object[exc.start:exc.start + 1]!r} at offset "
                                 f"{exc.start}); expected a YAML file: save it as UTF-8.") from None
    except (OSError, yaml.YAMLError) as exc:
        raise ConfigurationError(f"{path}: cannot be read as YAML ({exc}).") from exc


def load_robot(path: str | Path | None = None) -> RobotDescription:
    """Load the robot description from ``path`` (default: ``config/robot.yaml`` of the package)."""
    path = Path(path) if path else config_dir() / ROBOT_FILE
    return _load_robot_cached(str(path.resolve()), path.stat().st_mtime_ns if path.exists() else 0)


@lru_cache(maxsize=8)
def _load_robot_cached(path: str, _mtime_ns: int) -> RobotDescription:
    return robot_from_dict(read_yaml(path), source=path)


def default_robot() -> RobotDescription:
    """The package's own robot description (cached)."""
    return load_robot(None)
