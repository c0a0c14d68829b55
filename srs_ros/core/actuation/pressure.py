"""Length -> pressure -> regulator command, through the one safety clamp (paper Sec. IV-B).

Every path that ends at hardware calls :func:`clamp_pressures_bar`: it rejects NaN/inf and wrong
sizes and limits every value to ``[0, max_pressure_bar]`` (at most 4 bar). Nothing else clamps.
"""

from __future__ import annotations

import numpy as np

from srs_ros.core.errors import InvalidInputError
from srs_ros.core.robot import ABSOLUTE_MAX_PRESSURE_BAR, RobotDescription, amplitude_field, default_robot
from srs_ros.core.validation import finite_array


def clamp_pressures_bar(pressure_bar, robot: RobotDescription | None = None) -> np.ndarray:
    """The one clamp: ``(..., 9)`` pressures in bar -> finite values in ``[0, max_pressure_bar]``.

    Raises :class:`InvalidInputError` for a wrong size or any NaN/inf (the caller must then keep
    the robot safe, e.g. vent); values outside the range are limited, never passed on.
    """
    robot = robot or default_robot()
    pressure = finite_array("pressure_bar", pressure_bar, (robot.joint_count,), "bar")
    return np.clip(pressure, 0.0, pressure_limit_bar(robot))


def lengths_to_pressures_bar(lengths_m, robot: RobotDescription | None = None) -> np.ndarray:
    """Commanded pressures (bar) for actuator length changes ``(..., 9)`` (m), clamped.

    ``P = gain * l`` (the paper's ``P = 100 l``), plus the optional deadzone offset on every
    actuator that is asked to extend (a zero length stays at 0 bar, so venting still vents).
    """
    robot = robot or default_robot()
    lengths = finite_array("lengths_m", lengths_m, (robot.joint_count,), "m")
    # Limit the length first: a huge finite length (±1e307 m) must not overflow the map to ±inf.
    pressure = robot.pressure_per_length_bar_per_m * np.clip(lengths, 0.0, pressure_limited_length_m(robot))
    if robot.deadzone_offset_bar > 0.0:
        pressure = np.where(lengths > 0.0, pressure + robot.deadzone_offset_bar, pressure)
    return clamp_pressures_bar(pressure, robot)


def pressure_limit_bar(robot: RobotDescription | None = None) -> float:
    """The pressure limit every command is clamped to (bar): the robot's, never above 4 bar."""
    robot = robot or default_robot()
    return min(robot.max_pressure_bar, ABSOLUTE_MAX_PRESSURE_BAR)


def pressure_limited_length_m(robot: RobotDescription | None = None) -> float:
    """The longest length the pressure map can command within the limit (m): 0.04 m at 4 bar with P = 100 l.

    Longer setpoints (up to the muscles' ``max_extension_m``, 0.065 m) are limited to the pressure limit.
    """
    robot = robot or default_robot()
    return max(pressure_limit_bar(robot) - robot.deadzone_offset_bar, 0.0) / robot.pressure_per_length_bar_per_m


def pressures_to_lengths_m(pressure_bar, robot: RobotDescription | None = None) -> np.ndarray:
    """Inverse of the pressure map for planning and display: ``l = (P - offset) / gain``, at least 0."""
    robot = robot or default_robot()
    pressure = finite_array("pressure_bar", pressure_bar, (robot.joint_count,), "bar")
    offset = np.where(pressure > 0.0, robot.deadzone_offset_bar, 0.0)
    return np.maximum(pressure - offset, 0.0) / robot.pressure_per_length_bar_per_m


def pressures_to_command_v(pressure_bar, robot: RobotDescription | None = None) -> np.ndarray:
    """Regulator input voltages (V) for pressures (bar): ``V = V_fs * P / P_fs``, after the clamp.

    ITV3050 (9 bar full scale): 4 bar -> 4.444 V.
    """
    robot = robot or default_robot()
    pressure = clamp_pressures_bar(pressure_bar, robot)
    reg = robot.regulator
    return pressure * (reg.command_full_scale_v / reg.full_scale_pressure_bar)


def command_v_to_pressures_bar(command_v, robot: RobotDescription | None = None) -> np.ndarray:
    """Pressure (bar) that a regulator sets for input voltages (V); for monitor read-back and tests."""
    robot = robot or default_robot()
    volts = finite_array("command_v", command_v, (robot.joint_count,), "V")
    reg = robot.regulator
    return volts * (reg.full_scale_pressure_bar / reg.command_full_scale_v)


def pressure_amplitude_scale(lengths_m, amplitude_bar: float, robot: RobotDescription | None = None) -> float:
    """Factor ``k`` such that the cycle ``k * lengths_m`` peaks at ``amplitude_bar`` after the pressure map.

    ``gain * k * max(l) + deadzone_offset = amplitude_bar``; the amplitude must not exceed the limit.
    """
    robot = robot or default_robot()
    lengths = finite_array("lengths_m", lengths_m, (robot.joint_count,), "m")
    amplitude_bar = amplitude_field(robot).check(amplitude_bar, "pressure_amplitude_scale", error=InvalidInputError)
    peak_m = float(lengths.max())
    if peak_m <= 0.0:
        raise InvalidInputError("lengths_m: the cycle never extends an actuator; it cannot be scaled to an amplitude.")
    return (amplitude_bar - robot.deadzone_offset_bar) / (robot.pressure_per_length_bar_per_m * peak_m)
