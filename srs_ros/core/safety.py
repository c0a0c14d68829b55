"""What the hardware node may send, decided without ROS: setpoint checks, staleness and the e-stop latch.

:func:`setpoint_lengths_m` turns a named setpoint into joint-ordered lengths or rejects it;
:class:`CommandGate` decides on every command tick between the latest accepted command and 0 bar.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from srs_ros.core.errors import InvalidInputError
from srs_ros.core.robot import RobotDescription
from srs_ros.core.validation import finite_array


def setpoint_lengths_m(names: Sequence[str], positions: Sequence[float], robot: RobotDescription) -> np.ndarray:
    """Joint-ordered actuator lengths (m) of a setpoint naming every actuator once, in any order.

    Raises :class:`InvalidInputError` for a wrong count, a names/positions size mismatch, unknown
    or duplicate names, or NaN/inf. Finite values outside ``[0, max_extension_m]`` are returned as
    they are (the one pressure clamp limits them; see :func:`out_of_range_joints`).
    """
    names, count = list(names), robot.joint_count
    if len(names) != count:
        raise InvalidInputError(f"setpoint: expected {count} names {list(robot.joint_names)}, got {len(names)}; "
                                "publish every actuator in each message.")
    if len(positions) != len(names):
        raise InvalidInputError(f"setpoint: {len(names)} names but {len(positions)} positions; "
                                "expected one length (m) per name.")
    index = robot.joint_index
    unknown = [name for name in names if name not in index]
    if unknown:
        raise InvalidInputError(f"setpoint: unknown joint names {unknown}; expected {list(robot.joint_names)}.")
    duplicates = sorted({name for name in names if names.count(name) > 1})
    if duplicates:
        raise InvalidInputError(f"setpoint: duplicate joint names {duplicates}; expected each actuator once.")
    values = finite_array("setpoint positions", positions, (count,), "m")
    lengths = np.empty(count)
    lengths[[index[name] for name in names]] = values
    return lengths


def out_of_range_joints(lengths_m: np.ndarray, robot: RobotDescription) -> list[str]:
    """Names of the actuators whose length lies outside ``[0, max_extension_m]``."""
    outside = (lengths_m < 0.0) | (lengths_m > robot.max_extension_m)
    return [name for name, bad in zip(robot.joint_names, outside) if bad]


class OutputReason(str, enum.Enum):
    """Why the regulators get what they get on a tick."""

    COMMANDING = "commanding"
    ESTOP = "e-stop latched"
    INACTIVE = "inactive"
    NO_SETPOINT = "no setpoint yet"
    STALE = "setpoints stale"


@dataclass
class CommandGate:
    """The latest accepted command and when it came, the active flag and the e-stop latch.

    :meth:`decide` returns the command only while active, not e-stopped and no older than
    ``setpoint_timeout_s``; otherwise zeros (vent). Activation, deactivation, the e-stop and its reset
    all forget the stored command, so output resumes only with a setpoint that arrives afterwards.
    """

    joint_count: int
    setpoint_timeout_s: float
    active: bool = False
    estop_latched: bool = False
    _pressure_bar: np.ndarray | None = field(default=None, repr=False)
    _accepted_s: float = math.nan

    def accept(self, pressure_bar: np.ndarray, now_s: float) -> None:
        """Store a validated, clamped command (bar) received at ``now_s`` (s)."""
        self._pressure_bar = np.array(pressure_bar, dtype=np.float64)
        self._accepted_s = now_s

    def set_active(self, active: bool) -> None:
        """Enable or disable output; either way the stored command is forgotten."""
        self.active = active
        self._forget()

    def latch_estop(self) -> None:
        """Vent until :meth:`reset_estop`."""
        self.estop_latched = True
        self._forget()

    def reset_estop(self) -> bool:
        """Release the latch; return whether it was latched."""
        was_latched, self.estop_latched = self.estop_latched, False
        self._forget()
        return was_latched

    def setpoint_age_s(self, now_s: float) -> float:
        """Seconds since the last accepted setpoint (``inf`` if none is stored)."""
        return now_s - self._accepted_s if self._pressure_bar is not None else math.inf

    def decide(self, now_s: float) -> tuple[np.ndarray, OutputReason]:
        """The pressures (bar) to send at ``now_s`` and why."""
        if self.estop_latched:
            reason = OutputReason.ESTOP
        elif not self.active:
            reason = OutputReason.INACTIVE
        elif self._pressure_bar is None:
            reason = OutputReason.NO_SETPOINT
        elif self.setpoint_age_s(now_s) > self.setpoint_timeout_s:
            reason = OutputReason.STALE
        else:
            return self._pressure_bar.copy(), OutputReason.COMMANDING
        return np.zeros(self.joint_count), reason

    def _forget(self) -> None:
        self._pressure_bar, self._accepted_s = None, math.nan
