"""A rig: which backend drives the regulators, with which options and rates (``config/rigs/*.yaml``).

The robot description says what the snake is; a rig file says how this lab's bench drives it
(backend, its channels, regulator model, command rate, setpoint timeout).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from srs_ros.core.errors import ConfigurationError
from srs_ros.core.robot import RobotDescription, config_dir, default_robot, read_yaml, robot_from_dict

#: Allowed ranges of the rig's rates (inclusive).
COMMAND_RATE_RANGE_HZ = (1.0, 1000.0)
SETPOINT_TIMEOUT_RANGE_S = (0.01, 5.0)


@dataclass(frozen=True)
class RigConfig:
    """One rig: the backend name and options, the robot with this rig's regulator model, and rates."""

    name: str
    backend: str
    robot: RobotDescription
    command_rate_hz: float
    setpoint_timeout_s: float
    backend_options: dict[str, Any] = field(default_factory=dict)
    source: str = "<defaults>"


def default_rig_path() -> Path:
    """The mock rig shipped with the package."""
    return config_dir() / "rigs" / "mock.yaml"


def _number(section: Mapping[str, Any], key: str, low: float, high: float, where: str) -> float:
    value = section.get(key)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not (low <= value <= high):
        raise ConfigurationError(f"{where}: '{key}' is {value!r}; expected a number in [{low}, {high}].")
    return float(value)


def rig_from_dict(data: Mapping[str, Any], robot: RobotDescription | None = None, source: str = "<dict>") -> RigConfig:
    """Validate a parsed rig file; the rig's ``regulator_model`` (if given) replaces the robot's."""
    robot = robot or default_robot()
    where = f"{source} [rig]"
    section = data.get("rig") if isinstance(data, Mapping) else None
    if not isinstance(section, Mapping):
        raise ConfigurationError(f"{source}: missing section 'rig:' (name, backend, command_rate_hz, ...).")
    for key in ("name", "backend"):
        if not isinstance(section.get(key), str) or not section.get(key):
            raise ConfigurationError(f"{where}: '{key}' is {section.get(key)!r}; expected a non-empty string.")
    options = section.get("backend_options", {}) or {}
    if not isinstance(options, Mapping):
        raise ConfigurationError(f"{where}: 'backend_options' is {options!r}; expected a mapping of option: value.")
    model = section.get("regulator_model")
    if model is not None:
        if not isinstance(model, str):
            raise ConfigurationError(f"{where}: 'regulator_model' is {model!r}; expected a model name string.")
        robot = _with_regulator(robot, model, where)
    return RigConfig(
        name=section["name"], backend=section["backend"], robot=robot,
        command_rate_hz=_number(section, "command_rate_hz", *COMMAND_RATE_RANGE_HZ, where),
        setpoint_timeout_s=_number(section, "setpoint_timeout_s", *SETPOINT_TIMEOUT_RANGE_S, where),
        backend_options=dict(options), source=source,
    )


def _with_regulator(robot: RobotDescription, model: str, where: str) -> RobotDescription:
    """The robot with another regulator model, re-validated from the robot's own file."""
    if model == robot.regulator.name:
        return robot
    data = read_yaml(robot.source) if Path(robot.source).is_file() else None
    if not isinstance(data, Mapping) or model not in (data.get("regulator_models") or {}):
        known = sorted((data or {}).get("regulator_models") or {}) if isinstance(data, Mapping) else []
        raise ConfigurationError(f"{where}: 'regulator_model' is {model!r}; expected one of {known} "
                                 f"(regulator_models of {robot.source}).")
    data = dict(data)
    data["actuation"] = dict(data["actuation"], regulator_model=model)
    regulator = robot_from_dict(data, source=robot.source).regulator  # validates the model against the file
    # Swap only the regulator: the caller's robot may carry a lowered pressure limit that must survive.
    if regulator.full_scale_pressure_bar < robot.max_pressure_bar:
        raise ConfigurationError(
            f"{where}: 'regulator_model' {model!r} reaches {regulator.full_scale_pressure_bar} bar; "
            f"expected at least max_pressure_bar = {robot.max_pressure_bar} bar.")
    return dataclasses.replace(robot, regulator=regulator)


def load_rig(path: str | Path | None = None, robot: RobotDescription | None = None) -> RigConfig:
    """Load a rig file (default: the mock rig) for ``robot`` (default: the package's robot)."""
    path = Path(path) if path else default_rig_path()
    return rig_from_dict(read_yaml(path), robot, source=str(path))
