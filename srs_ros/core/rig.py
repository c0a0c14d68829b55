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

from srs_ros.core.robot import RobotDescription, config_dir, default_robot, read_yaml, robot_from_dict
from srs_ros.core.schema import Field, Table, document, refusal

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


#: The rig a whole system starts on by default (``srs_bringup``, ``launch/srs.launch.py``): the simulated robot.
#: A hardware node started alone takes the mock rig (:func:`default_rig_path`).
SYSTEM_RIG = "sim"
#: The camera_tracker colour preset for the simulated robot's camera (sim_world's images): its head and tail
#: bands. ``srs_bringup`` gives it to the tracker on the simulated rig, and it is the launch file's default.
SIM_COLOR_PRESET = "sim_bands"
#: The colour presets camera_tracker knows ('' = none: its own detector, marker ids and HSV bounds).
COLOR_PRESETS = ("", SIM_COLOR_PRESET)


def rig_path(name: str) -> Path:
    """The rig file ``name`` shipped with the package (``config/rigs/<name>.yaml``)."""
    return config_dir() / "rigs" / f"{name}.yaml"


def default_rig_path() -> Path:
    """The mock rig shipped with the package."""
    return rig_path("mock")


#: The ``rig:`` section of a rig file.
RIG_TABLE = Table("rig", (
    Field("name", str, nonempty=True, description="name of the rig"),
    Field("backend", str, nonempty=True, description="the backend that drives it: mock, sim, can or daq"),
    Field("regulator_model", str, default=None, description="replaces the robot's regulator model (optional)"),
    Field("command_rate_hz", float, minimum=COMMAND_RATE_RANGE_HZ[0], maximum=COMMAND_RATE_RANGE_HZ[1], unit="Hz",
          description="commands sent to the regulators per second"),
    Field("setpoint_timeout_s", float, minimum=SETPOINT_TIMEOUT_RANGE_S[0], maximum=SETPOINT_TIMEOUT_RANGE_S[1],
          unit="s", description="setpoints older than this vent to 0 bar"),
    Field("backend_options", dict, default=None, description="the backend's own options (validated by it)"),
), description="a mapping of name, backend, command_rate_hz, setpoint_timeout_s, backend_options")


def rig_from_dict(data: Mapping[str, Any], robot: RobotDescription | None = None, source: str = "<dict>") -> RigConfig:
    """Validate a parsed rig file; the rig's ``regulator_model`` (if given) replaces the robot's."""
    robot = robot or default_robot()
    rig = RIG_TABLE.read(document(data, "rig", source, what=RIG_TABLE.description, sections=RIG_TABLE.names), source)
    if rig["regulator_model"] is not None:
        robot = _with_regulator(robot, rig["regulator_model"], source)
    return RigConfig(name=rig["name"], backend=rig["backend"], robot=robot, command_rate_hz=rig["command_rate_hz"],
                     setpoint_timeout_s=rig["setpoint_timeout_s"], backend_options=rig["backend_options"] or {},
                     source=source)


def _with_regulator(robot: RobotDescription, model: str, where: str) -> RobotDescription:
    """The robot with another regulator model, re-validated from the robot's own file."""
    if model == robot.regulator.name:
        return robot
    key = RIG_TABLE.key("regulator_model")
    data = read_yaml(robot.source) if Path(robot.source).is_file() else None
    if not isinstance(data, Mapping) or model not in (data.get("regulator_models") or {}):
        known = sorted((data or {}).get("regulator_models") or {}) if isinstance(data, Mapping) else []
        raise refusal(where, key, model, f"one of {known} (regulator_models of {robot.source})")
    data = dict(data)
    data["actuation"] = dict(data["actuation"], regulator_model=model)
    regulator = robot_from_dict(data, source=robot.source).regulator  # validates the model against the file
    # Swap only the regulator: the caller's robot may carry a lowered pressure limit that must survive.
    if regulator.full_scale_pressure_bar < robot.max_pressure_bar:
        raise refusal(where, key, model, f"a model reaching max_pressure_bar = {robot.max_pressure_bar:g} bar "
                                         f"(it reaches {regulator.full_scale_pressure_bar:g} bar)")
    return dataclasses.replace(robot, regulator=regulator)


def load_rig(path: str | Path | None = None, robot: RobotDescription | None = None) -> RigConfig:
    """Load a rig file (default: the mock rig) for ``robot`` (default: the package's robot)."""
    path = Path(path) if path else default_rig_path()
    return rig_from_dict(read_yaml(path), robot, source=str(path))
