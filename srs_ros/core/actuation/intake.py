"""One setpoint into the hardware node's gate, without ROS: checked, aged by its stamp, limited, shaped, stored.

:func:`take_setpoint` is the whole intake step: it returns an :class:`IntakeDecision` that says what
happened and what to tell the operator (:meth:`IntakeDecision.notes`, throttled by a :class:`NoteThrottle`);
the node only logs the notes and counts (:meth:`srs_ros.core.actuation.status.HardwareStatus.count_setpoint`).

Example::

    gate = CommandGate(joint_count=9, setpoint_timeout_s=0.2, active=True)
    decision = take_setpoint(Setpoint(names, [0.02] * 9), shaper, gate, now_ns=clock_ns, now_s=time.monotonic())
    decision.accepted  # True: gate.decide(now_s) commands 2 bar on every muscle (P = 100 l)
    for note in throttle.due(decision.notes(), now_s): ...  # what to log (a NoteThrottle per node)
"""

from __future__ import annotations

import enum
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from srs_ros.core.actuation.compensation import SetpointShaper
from srs_ros.core.actuation.safety import (
    CommandGate,
    StampCheck,
    setpoint_age_s,
    setpoint_lengths_m,
    setpoint_velocities_m_per_s,
)
from srs_ros.core.errors import InvalidInputError
from srs_ros.core.robot import RobotDescription


@dataclass(frozen=True)
class Setpoint:
    """One setpoint as it arrives: actuator names, lengths (m), optional length rates (m/s), stamp (ns; 0 = none)."""

    names: Sequence[str]
    positions_m: Sequence[float]
    velocities_m_per_s: Sequence[float] = ()
    stamp_ns: int = 0


class Verdict(str, enum.Enum):
    """What the intake did with a setpoint."""

    ACCEPTED = "accepted"  # stored in the gate (perhaps limited by the clamp)
    INVALID = "invalid"  # wrong names or lengths: not sent, the previous command continues until stale
    STALE = "stale on arrival"  # stamped longer ago than the setpoint timeout: not sent


@dataclass(frozen=True)
class IntakeDecision:
    """What :func:`take_setpoint` did and what to tell the operator (each note '' when there is nothing to say).

    ``clock_offset_s`` (s; None unless the stamp is stale or from the future): this host's clock minus
    the stamp, i.e. how far the sender's clock lags (positive) or runs ahead (negative).
    """

    verdict: Verdict
    rejection: str = ""  # why the setpoint was not sent (INVALID, STALE)
    stamp: StampCheck | None = None  # None when the lengths were invalid (the stamp was not looked at)
    stamp_ns: int = 0
    age_s: float = 0.0  # the age the setpoint counts with at arrival (s)
    clock_offset_s: float | None = None
    velocity_note: str = ""  # the velocities were unusable: the lengths were used alone
    clock_note: str = ""  # stamped in the future: aged from its arrival
    limit_note: str = ""  # the clamp limits some lengths
    compensation_note: str = ""  # the lag compensation's lead was cut at the clamp

    @property
    def accepted(self) -> bool:
        """True when the setpoint's command is now the gate's latest."""
        return self.verdict is Verdict.ACCEPTED

    def notes(self) -> tuple[Note, ...]:
        """What to tell the operator: a refusal is an error, the rest warnings; each kind throttled on its own."""
        kinds = ((self.verdict.name.lower(), "error", self.rejection, NOTE_THROTTLE_S),
                 ("velocity", "warning", self.velocity_note, NOTE_THROTTLE_S),
                 ("clock", "warning", self.clock_note, NOTE_THROTTLE_S),
                 ("limit", "warning", self.limit_note, LIMIT_NOTE_THROTTLE_S),
                 ("compensation", "warning", self.compensation_note, LIMIT_NOTE_THROTTLE_S))
        return tuple(Note(*kind) for kind in kinds if kind[2])


#: Each kind of note is said at most once per this many seconds (a stream of bad setpoints says it once a second).
NOTE_THROTTLE_S = 1.0
#: ... and a limit by the clamp, which a too large gait amplitude hits on every cycle, once per this many seconds.
LIMIT_NOTE_THROTTLE_S = 5.0


@dataclass(frozen=True)
class Note:
    """One thing to say about a setpoint: its kind, ``"error"`` or ``"warning"``, the text, its throttle (s)."""

    kind: str
    severity: str
    text: str
    throttle_s: float


@dataclass
class NoteThrottle:
    """Lets each kind of :class:`Note` through at most once per its ``throttle_s`` (the first one at once)."""

    said_s: dict[str, float] = field(default_factory=dict)  # kind -> when it was last let through (s, steady)

    def due(self, notes: Sequence[Note], now_s: float) -> list[Note]:
        """The notes to say at ``now_s`` (s, steady clock); the others are dropped."""
        due = [note for note in notes if now_s >= self.said_s.get(note.kind, -math.inf) + note.throttle_s]
        self.said_s.update((note.kind, now_s) for note in due)
        return due


def take_setpoint(setpoint: Setpoint, shaper: SetpointShaper, gate: CommandGate, now_ns: int,
                  now_s: float) -> IntakeDecision:
    """Check ``setpoint``, age it by its stamp and store its command in ``gate`` unless invalid or stale.

    ``now_ns`` (ns) is the receiver's clock the stamp is compared with; ``now_s`` (s) the gate's steady
    clock the command is stored at. The lengths become pressures through ``shaper`` (the selected map,
    the lag compensation) and the one clamp; lengths the clamp limits are accepted and noted, never rejected.
    """
    robot = shaper.map.robot
    try:
        lengths_m = setpoint_lengths_m(setpoint.names, setpoint.positions_m, robot)
    except InvalidInputError as exc:
        return IntakeDecision(Verdict.INVALID, f"rejected setpoint, not sent (the previous command continues "
                                               f"until stale): {exc}")
    velocities_m_per_s, velocity_note = _velocities(setpoint, robot)
    timeout_s = gate.setpoint_timeout_s
    age_s, stamp = setpoint_age_s(setpoint.stamp_ns, now_ns, timeout_s)
    offset_s = (now_ns - setpoint.stamp_ns) * 1e-9 if stamp in (StampCheck.STALE, StampCheck.FUTURE) else None
    common = {"stamp": stamp, "stamp_ns": setpoint.stamp_ns, "age_s": age_s, "clock_offset_s": offset_s,
              "velocity_note": velocity_note}
    if stamp is StampCheck.STALE:
        return IntakeDecision(Verdict.STALE, f"rejected setpoint, not sent: its stamp is {age_s:.3f} s old, more "
                              f"than setpoint_timeout_s {timeout_s:g} s (a stall, or the sender's clock lags this "
                              "host's: sync the clocks)", **common)
    cut_before = shaper.compensation_clamped
    gate.accept(shaper.pressures_bar(lengths_m, velocities_m_per_s, now_s), now_s, age_s)
    return IntakeDecision(
        Verdict.ACCEPTED, **common, limit_note=limit_note(lengths_m, shaper),
        clock_note=(f"setpoint stamped {-offset_s:.3f} s in the future: the sender's clock runs ahead of this "
                    "host's (sync the clocks); aged from arrival") if stamp is StampCheck.FUTURE else "",
        compensation_note=(f"lag compensation: the lead asked for more than [0, {robot.max_pressure_bar:g}] bar (or "
                           "a muscle's saturation); cut at the clamp, never exceeded (compensation_clamped on "
                           "/diagnostics)") if shaper.compensation_clamped > cut_before else "")


def _velocities(setpoint: Setpoint, robot: RobotDescription) -> tuple[np.ndarray | None, str]:
    """The setpoint's joint-ordered rates (m/s, None if it has none) and why they were dropped ('' if not).

    Velocities are a hint for the lag compensation only: the lengths are the command. Unusable ones are
    dropped (the compensation then differences successive setpoints), said and counted.
    """
    try:
        return setpoint_velocities_m_per_s(setpoint.names, setpoint.velocities_m_per_s, robot), ""
    except InvalidInputError as exc:
        return None, f"setpoint velocities ignored (the lengths are used): {exc}"


def limit_note(lengths_m: np.ndarray, shaper: SetpointShaper) -> str:
    """What to say when the clamp changes joint-ordered ``lengths_m`` (m): outside [0, the map's limited length].

    '' when every length is within (see :meth:`SetpointShaper.limited_joints`).
    """
    names = shaper.limited_joints(lengths_m)
    if not names:
        return ""
    robot = shaper.map.robot
    indices = [robot.joint_index[name] for name in names]
    asked = [round(float(lengths_m[i]), 4) for i in indices]
    limits = [round(float(shaper.map.limited_length_m[i]), 4) for i in indices]
    return (f"setpoint limited by the clamp: {names} ask {asked} m; they are commanded within [0, {limits}] m, "
            f"i.e. [0, {robot.max_pressure_bar:g}] bar with {shaper.map.describe()} (the muscles' largest "
            f"extension is {robot.max_extension_m:g} m); lower the gait amplitude to avoid it")
