"""What the hardware node may send, decided without ROS: setpoint checks, staleness and the e-stop latch.

:func:`setpoint_lengths_m` (and :func:`setpoint_velocities_m_per_s`) turn a named setpoint into joint-ordered
lengths (rates) or reject it;
:class:`CommandGate` decides on every command tick between the latest accepted command and 0 bar.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from srs_ros.core.actuation.pressure import pressure_limited_length_m
from srs_ros.core.errors import InvalidInputError
from srs_ros.core.ramp import ramp_fraction
from srs_ros.core.robot import RobotDescription
from srs_ros.core.validation import finite_array


def setpoint_lengths_m(names: Sequence[str], positions: Sequence[float], robot: RobotDescription) -> np.ndarray:
    """Joint-ordered actuator lengths (m) of a setpoint naming every actuator once, in any order.

    Raises :class:`InvalidInputError` for a wrong count, a names/positions size mismatch, unknown
    or duplicate names, or NaN/inf. Finite values outside ``[0, max_extension_m]`` are returned as
    they are (the one pressure clamp limits them; see :func:`clamped_joints`).
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
    return _joint_ordered(names, finite_array("setpoint positions", positions, (count,), "m"), robot)


def setpoint_velocities_m_per_s(names: Sequence[str], velocities: Sequence[float],
                                robot: RobotDescription) -> np.ndarray | None:
    """Joint-ordered length rates (m/s) of a setpoint whose names :func:`setpoint_lengths_m` accepted; None if empty.

    Raises :class:`InvalidInputError` for a names/velocities size mismatch or NaN/inf.
    """
    if len(velocities) == 0:
        return None
    names = list(names)
    if len(velocities) != len(names):
        raise InvalidInputError(f"setpoint: {len(names)} names but {len(velocities)} velocities; expected one length "
                                "rate (m/s) per name, or none.")
    return _joint_ordered(names, finite_array("setpoint velocities", velocities, (robot.joint_count,), "m/s"), robot)


def _joint_ordered(names: list[str], values: np.ndarray, robot: RobotDescription) -> np.ndarray:
    """``values`` given in the order of ``names`` (each joint once), rearranged into joint order."""
    ordered = np.empty(robot.joint_count)
    ordered[[robot.joint_index[name] for name in names]] = values
    return ordered


#: Lengths within this of the clamp's bounds (m) are limited without a warning (0.01 bar with P = 100 l).
CLAMP_SLACK_M = 1e-4


def clamped_joints(lengths_m: np.ndarray, robot: RobotDescription, limited_length_m=None) -> list[str]:
    """Names of the actuators whose length the one clamp changes: below 0, or longer than the pressure limit allows.

    ``limited_length_m`` (m, scalar or per actuator): the longest length the selected pressure map commands
    within the limit (:attr:`srs_ros.core.actuation.muscle_calibration.PressureMap.limited_length_m`); default the
    paper's map: with ``P = 100 l`` and 4 bar that is 0.04 m, although the muscles extend to 0.065 m.
    """
    limit_m = pressure_limited_length_m(robot) if limited_length_m is None else np.asarray(limited_length_m)
    # 0.1 mm (0.01 bar) of slack: a cycle scaled to exactly the limit (0.04 m at 4 bar) comes out of the
    # player's spline a hair above it; that is not a request the operator should be warned about.
    outside = (lengths_m < -CLAMP_SLACK_M) | (lengths_m > limit_m + CLAMP_SLACK_M)
    return [name for name, bad in zip(robot.joint_names, outside) if bad]


class OutputReason(str, enum.Enum):
    """Why the regulators get what they get on a tick."""

    COMMANDING = "commanding"
    RAMPING = "ramping up from 0 bar"
    ESTOP = "e-stop latched"
    INACTIVE = "inactive"
    NOT_ARMED = "waiting for the operator to arm (~/arm)"
    HOLDING = "hardware holding at 0 bar"
    NO_SETPOINT = "no setpoint yet"
    STALE = "setpoints stale"


#: What every tool and node says when a vent fails: the regulators may still hold pressure.
VENT_FAILED = "VENT FAILED: shut off the air supply now"

#: A setpoint stamp this far ahead of the receiver's clock means the two clocks differ (s).
FUTURE_STAMP_TOLERANCE_S = 0.05


class StampCheck(str, enum.Enum):
    """What a setpoint's stamp says about its age (see :func:`setpoint_age_s`)."""

    OK = "ok"
    UNSTAMPED = "unstamped"
    FUTURE = "stamped in the future"
    STALE = "stale on arrival"


def setpoint_age_s(stamp_ns: int, now_ns: int, timeout_s: float) -> tuple[float, StampCheck]:
    """The age (s) a setpoint counts with at arrival, from its stamp and the receiver's clock (ns).

    An unstamped setpoint (stamp 0) is aged from its arrival (age 0). A stamp from the future by more
    than :data:`FUTURE_STAMP_TOLERANCE_S` means the sender's clock is ahead: the setpoint is aged from
    its arrival too, and the caller reports the clock offset. A stamp older than ``timeout_s`` is
    stale on arrival (a stall, or a sender's clock that lags): the caller rejects and reports it.
    """
    if stamp_ns == 0:
        return 0.0, StampCheck.UNSTAMPED
    age_s = (now_ns - stamp_ns) * 1e-9
    if age_s < -FUTURE_STAMP_TOLERANCE_S:
        return 0.0, StampCheck.FUTURE
    if age_s > timeout_s:
        return age_s, StampCheck.STALE
    return max(age_s, 0.0), StampCheck.OK


def min_setpoint_rate_hz(setpoint_timeout_s: float) -> float:
    """The slowest setpoint or command rate (Hz) that keeps a ``setpoint_timeout_s`` watchdog fed: two per timeout."""
    return 2.0 / setpoint_timeout_s


@dataclass
class CommandGate:
    """The latest accepted command and how old it is, the active flag, the operator's arm and the e-stop latch.

    :meth:`decide` returns the command only while active, armed (where the rig needs an operator's
    arm), not e-stopped and no older than ``setpoint_timeout_s``; otherwise zeros (vent). Whenever
    output (re)starts (at activation, after the arm, after an e-stop reset, after a vent for stale
    setpoints) the command ramps up from 0 bar over ``ramp_time_s``. Activation, deactivation, the
    e-stop and its reset forget the stored command, so output resumes only with a setpoint that
    arrives afterwards; deactivation and the e-stop also disarm.

    The operator's go (:attr:`has_go`) is the arm on a rig that needs one (``requires_arm``); a rig
    that needs none (mock, sim) has it from the start. :meth:`disarm` withdraws it on every rig:
    0 bar until :meth:`arm`, whatever else happens meanwhile (deactivation, reconfiguration).

    A gap between two decisions longer than ``max_gap_s`` (the caller itself stalled: frozen, starved
    of CPU) also restarts the ramp: no watchdog ran meanwhile, and hardware that vents by itself
    when the host falls silent (a CAN board, an NI watchdog) has vented; jumping back to the command
    would step the pressure. Such gaps are counted in ``stalls``.
    """

    joint_count: int
    setpoint_timeout_s: float
    ramp_time_s: float = 0.0
    requires_arm: bool = False
    active: bool = False
    armed: bool = False
    disarmed: bool = False  # the operator's ~/disarm, on any rig: 0 bar until arm()
    estop_latched: bool = False
    max_gap_s: float = math.inf
    stalls: int = 0
    _last_decision_s: float | None = None
    _pressure_bar: np.ndarray | None = field(default=None, repr=False)
    _fresh_s: float = math.nan  # when the stored command was fresh (its arrival less its age at arrival)
    _output_since_s: float | None = None  # when output last went from 0 bar to commanding

    def configure(self, joint_count: int, setpoint_timeout_s: float, ramp_time_s: float, requires_arm: bool,
                  max_gap_s: float = math.inf) -> None:
        """Set up for a (re)configured rig; the e-stop latch, the operator's disarm and the stall count stay."""
        self.joint_count, self.setpoint_timeout_s, self.ramp_time_s = joint_count, setpoint_timeout_s, ramp_time_s
        self.requires_arm, self.max_gap_s = requires_arm, max_gap_s
        self.restart_stall_watch()

    def accept(self, pressure_bar: np.ndarray, now_s: float, age_s: float = 0.0) -> None:
        """Store a validated, clamped command (bar) that arrives at ``now_s`` (s) already ``age_s`` old (s)."""
        self._pressure_bar = np.array(pressure_bar, dtype=np.float64)
        self._fresh_s = now_s - max(float(age_s), 0.0)

    def set_active(self, active: bool) -> None:
        """Enable or disable output; either way the stored command is forgotten; disabling disarms."""
        self.active = active
        if not active:
            self.armed = False
        self._forget()

    def arm(self) -> str:
        """The operator's go: '' when armed, else why not (what to do)."""
        if self.estop_latched:
            return "e-stop latched: call ~/reset first, then ~/arm"
        if not self.active:
            return "not active: configure and activate the hardware node first, then ~/arm"
        self.armed, self.disarmed = True, False
        return ""

    def disarm(self) -> bool:
        """Withdraw the operator's go on any rig (0 bar until :meth:`arm`); return whether there was one."""
        had_go = self.has_go
        self.armed, self.disarmed = False, True
        self._forget()
        return had_go

    def latch_estop(self) -> None:
        """Vent until :meth:`reset_estop`; disarms."""
        self.estop_latched = True
        self.armed = False
        self._forget()

    def reset_estop(self) -> bool:
        """Release the latch; return whether it was latched (a rig that needs an arm stays disarmed)."""
        was_latched, self.estop_latched = self.estop_latched, False
        self._forget()
        return was_latched

    @property
    def has_go(self) -> bool:
        """The operator's go: armed, or on a rig that needs no arm, not disarmed since the last arm."""
        return self.armed or not (self.requires_arm or self.disarmed)

    @property
    def may_command(self) -> bool:
        """True while a fresh setpoint would reach the valves (active, the operator's go, no e-stop)."""
        return self.active and not self.estop_latched and self.has_go

    def setpoint_age_s(self, now_s: float) -> float:
        """Seconds since the stored setpoint was fresh (``inf`` if none is stored)."""
        return now_s - self._fresh_s if self._pressure_bar is not None else math.inf

    def restart_stall_watch(self) -> None:
        """Forget the previous decision (at configure: a pause while unconfigured is no stall)."""
        self._last_decision_s = None

    def decide(self, now_s: float, holding: str = "") -> tuple[np.ndarray, OutputReason]:
        """The pressures (bar) to send at ``now_s`` and why.

        ``holding`` non-empty: the hardware cannot follow right now (a paused simulator,
        :meth:`~srs_ros.backends.base.ActuatorBackend.holding_reason`): 0 bar, the stored setpoint kept, and
        output ramps back in when the hold clears.
        """
        if self._last_decision_s is not None and now_s - self._last_decision_s > self.max_gap_s:
            self.stalls += 1
            self._output_since_s = None
        self._last_decision_s = now_s
        if self.estop_latched:
            reason = OutputReason.ESTOP
        elif not self.active:
            reason = OutputReason.INACTIVE
        elif not self.has_go:
            reason = OutputReason.NOT_ARMED
        elif holding:
            reason = OutputReason.HOLDING
        elif self._pressure_bar is None:
            reason = OutputReason.NO_SETPOINT
        elif self.setpoint_age_s(now_s) > self.setpoint_timeout_s:
            reason = OutputReason.STALE
        else:
            if self._output_since_s is None:
                self._output_since_s = now_s
            fraction = ramp_fraction(now_s - self._output_since_s, self.ramp_time_s)
            reason = OutputReason.COMMANDING if fraction >= 1.0 else OutputReason.RAMPING
            return self._pressure_bar * fraction, reason
        self._output_since_s = None
        return np.zeros(self.joint_count), reason

    def withdraw_if_late(self, decision: tuple[np.ndarray, OutputReason], decided_s: float,
                         now_s: float) -> tuple[np.ndarray, OutputReason]:
        """A decision (:meth:`decide` at ``decided_s``, s), or 0 bar (STALE) if sent more than ``max_gap_s`` later.

        The caller frozen between deciding and sending (SIGSTOP, a stall of a busy machine) would otherwise send,
        once, a command the hardware may have vented meanwhile. Counted in ``stalls``; output restarts with a ramp.
        Checked just before the write, it narrows the window to the write itself.
        """
        if now_s - decided_s <= self.max_gap_s:
            return decision
        self.stalls += 1
        self._output_since_s = None
        self._last_decision_s = now_s  # the stall is counted once: the next decision ramps from here
        return np.zeros_like(decision[0]), OutputReason.STALE

    def _forget(self) -> None:
        self._pressure_bar, self._fresh_s = None, math.nan
        self._output_since_s = None
