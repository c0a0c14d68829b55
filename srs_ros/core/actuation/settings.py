"""The hardware node's settings, without ROS: one schema table, and what a configure makes of their values.

:data:`HARDWARE_SETTINGS` gives each setting's type, range, default and meaning. The node declares them as its
ROS parameters (:data:`srs_ros.nodes.hardware_node.PARAMETERS`, with the shared ``realtime_priority``), so a
value out of range or not among the choices is refused in the schema's one format; ``config/hardware_node.yaml``
is generated from them (``python -m srs_ros.tools.node_config``). :func:`hardware_setup` turns their values
into the rig, the timing and the setpoint shaper at each configure.

Example::

    values = HARDWARE_SETTINGS.read({"max_pressure_bar": 3.0}, "my_params.yaml")  # every other one its default
    hardware_setup(values).rig.robot.max_pressure_bar  # 3.0: the setting lowers the robot's 4 bar
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

from srs_ros.core.actuation.compensation import SetpointShaper, setpoint_shaper
from srs_ros.core.actuation.muscle_calibration import CALIBRATED_MAP, PAPER_MAP
from srs_ros.core.actuation.muscle_model import MUSCLE_OPTIONS
from srs_ros.core.actuation.timing import CommandTiming, command_timing
from srs_ros.core.ramp import DEFAULT_RAMP_TIME_S
from srs_ros.core.rig import RigConfig, load_rig
from srs_ros.core.robot import ABSOLUTE_MAX_PRESSURE_BAR, load_robot
from srs_ros.core.schema import Field, Table

HARDWARE_SETTINGS = Table("hardware_node", (
    Field("rig_file", str, "", description="rig YAML (config/rigs/*.yaml); '' = the mock rig"),
    Field("backend", str, "", description="backend overriding the rig's ('sim', 'mock', 'can', 'daq'); '' = the rig's"),
    Field("robot_description_file", str, "", description="robot YAML; '' = the package's config/robot.yaml"),
    Field("setpoint_timeout_s", float, 0.0, 0.0, 5.0,
          description="setpoints older than this vent to 0 bar (s); 0 = the rig's value"),
    Field("command_rate_hz", float, 0.0, 0.0, 1000.0,
          description="commands sent to the backend per second; 0 = the rig's value"),
    Field("state_publish_rate_hz", float, 50.0, 1.0, 1000.0,
          description="actuator_state messages per second (at most the command rate)"),
    Field("ramp_time_s", float, DEFAULT_RAMP_TIME_S, 0.0, 60.0,
          description="output ramps up from 0 bar over this time whenever it (re)starts (s)"),
    Field("max_pressure_bar", float, ABSOLUTE_MAX_PRESSURE_BAR, 0.1, ABSOLUTE_MAX_PRESSURE_BAR,
          description="pressure limit (bar); only lowers the robot's; read-only: set it at start-up"),
    Field("autostart", bool, False,
          description="configure and activate at start-up (a real rig still waits for ~/arm)"),
    Field("pressure_map", str, PAPER_MAP, choices=(PAPER_MAP, CALIBRATED_MAP),
          description=f"how lengths become pressures: '{PAPER_MAP}' (P = 100 l) or '{CALIBRATED_MAP}' (each "
                      "muscle's characteristic from calibration_file)"),
    Field("calibration_file", str, "", description="the rig's muscle calibration (srs_identify); '' = none"),
    Field("lag_compensation", bool, False,
          description="lead the supply line's delay and invert its lag (live; needs the calibration's dynamics or "
                      "the two compensation_* parameters)"),
    Field("compensation_delay_s", float, 0.0, 0.0, MUSCLE_OPTIONS["transport_delay_s"].maximum,
          description="supply-line delay led by the compensation (s); 0 = the calibration file's"),
    Field("compensation_time_constant_s", float, 0.0, 0.0, MUSCLE_OPTIONS["pressure_time_constant_s"].maximum,
          description="pressure time constant the compensation inverts (s); 0 = the calibration file's"),
), description="the hardware node's settings")

#: Settings read at start-up only (``ros2 param set`` refuses them).
READ_ONLY = frozenset({"max_pressure_bar"})


@dataclasses.dataclass(frozen=True)
class HardwareSetup:
    """What a configure of the hardware node sets up from its settings before it opens the backend.

    ``rig`` carries the robot with its pressure limit lowered to ``max_pressure_bar`` where that is lower;
    ``backend`` is the name of the backend to open (the setting, or the rig's).
    """

    rig: RigConfig
    timing: CommandTiming
    shaper: SetpointShaper
    backend: str
    ramp_time_s: float


def hardware_setup(values: Mapping[str, Any]) -> HardwareSetup:
    """The setup from the value of every setting of :data:`HARDWARE_SETTINGS` (0 or '' = the rig's or a default).

    Reads the robot, rig and calibration files now; raises :class:`~srs_ros.core.errors.ConfigurationError`
    (or the file's own error) with the reason.
    """
    robot = load_robot(values["robot_description_file"] or None)
    limit_bar = min(robot.max_pressure_bar, values["max_pressure_bar"])
    rig = load_rig(values["rig_file"] or None, dataclasses.replace(robot, max_pressure_bar=limit_bar))
    timing = command_timing(rig, values["command_rate_hz"], values["setpoint_timeout_s"],
                            values["state_publish_rate_hz"])
    shaper = setpoint_shaper(rig.robot, values["pressure_map"], values["calibration_file"],
                             values["compensation_delay_s"], values["compensation_time_constant_s"],
                             values["lag_compensation"])
    return HardwareSetup(rig, timing, shaper, values["backend"] or rig.backend, values["ramp_time_s"])
