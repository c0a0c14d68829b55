"""What the simulated robot needs beyond its physics to stand in for a rig: pacing to a clock and a board's watchdog.

No ROS: the ``sim_world`` node wires these to its stepping thread.

- :class:`RealTimePacer` says how far the world may step at each wake-up of a real-time loop: the wall time
  that passed, but never more than ``max_step_s`` at once (bounded catch-up). After a stall of the process
  (CPU load, a SIGSTOP) the world *slips*: it resumes where it stopped and runs late by the stall instead of
  racing through it, so the muscles never see a burst of simulated time without commands. The slip is counted
  (``slipped_s``); with ``use_sim_time`` every node follows the world's own time on ``/clock`` and the slip costs
  nothing but wall time.
- :class:`SimulatedBoard` is the regulators' DAC board: it applies every command at the world time it arrived
  (so the loop need not wake up for each one) and vents by itself when commands stop for ``command_timeout_s``
  of *world* time, as docs/can.md demands of a real board (a world that is itself paused does not count its
  own pause as silence). A real board reads its input at once; the simulated one hears of a command only when
  the caller's receiving thread runs, so while that thread is behind (:meth:`SimulatedBoard.receiver_behind`)
  silence is not counted: a stall of the simulator's own process is not the sender's silence.
- :class:`ReceiverWatch` is that rule's clock, for both ends of the simulated rig: when the thread that receives
  the peer's messages last ran, whether it is behind or stuck, and how much of the peer's silence it was there
  to hear. sim_world watches its executor (the board hears commands through it), the ``sim`` backend its bus
  thread (it hears sim_world's read-back).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np

#: The largest slice of world time one wake-up of a real-time loop may step (s): about 8 ms of CPU at 13x real time.
MAX_CATCH_UP_S = 0.1
#: Commands the board holds between two wake-ups; beyond it the oldest are dropped (a newer one replaces them).
MAX_PENDING_COMMANDS = 256
#: The receiving thread is *behind* when it last ran longer ago than this (s): a command may wait unread. A
#: healthy executor runs every few tens of ms; a Python process on a busy 2-core machine stalls 0.2-0.4 s.
RECEIVER_BEHIND_S = 0.25
#: ... and *stuck* beyond this (s): the board counts silence again and vents, as for a dead sender.
RECEIVER_STUCK_S = 5.0


@dataclass
class RealTimePacer:
    """World time to step per wake-up: the wall time elapsed, at most ``max_step_s`` (the rest slips)."""

    max_step_s: float = MAX_CATCH_UP_S
    slipped_s: float = 0.0  # wall time the world did not follow (stalls longer than max_step_s), s
    slips: int = 0  # wake-ups that came too late to follow the wall clock
    _last_wall_s: float | None = None

    def step_s(self, wall_s: float) -> float:
        """World seconds to advance at wall time ``wall_s`` (s, monotonic); 0 at the first call."""
        last, self._last_wall_s = self._last_wall_s, wall_s
        if last is None:
            return 0.0
        elapsed_s = max(0.0, wall_s - last)
        if elapsed_s > self.max_step_s:
            self.slipped_s += elapsed_s - self.max_step_s
            self.slips += 1
            return self.max_step_s
        return elapsed_s

    def restart(self) -> None:
        """Forget the last wake-up (after a reset: the next call steps nothing)."""
        self._last_wall_s = None


@dataclass
class ReceiverWatch:
    """When a receiving thread last ran (steady clock, s): behind, stuck, and the silence it was there to hear.

    Call :meth:`ran` at every run of the thread (under the caller's lock if other threads read it). It is *behind*
    while it last ran more than RECEIVER_BEHIND_S ago but less than ``stuck_s`` (starved of CPU, held up: a message
    may wait unread), and a run after such a gap *resumes* it: a silence of the peer before that moment was not
    heard, so :meth:`heard_silence_s` counts only from it.
    """

    stuck_s: float = RECEIVER_STUCK_S
    ran_s: float = math.inf  # the last run (inf: not yet)
    resumed_s: float = -math.inf  # the last run after being behind
    stalls: int = 0  # times it ran again after being behind

    def start(self, now_s: float) -> None:
        """The thread starts listening at ``now_s``: nothing before it was heard."""
        self.ran_s = self.resumed_s = now_s

    def ran(self, now_s: float) -> None:
        """The thread ran at ``now_s``."""
        if now_s - self.ran_s > RECEIVER_BEHIND_S:
            self.resumed_s = now_s
            self.stalls += 1
        self.ran_s = now_s

    def behind(self, now_s: float) -> bool:
        """True while the thread last ran more than RECEIVER_BEHIND_S and less than ``stuck_s`` ago."""
        return RECEIVER_BEHIND_S < now_s - self.ran_s < self.stuck_s

    def deaf_s(self, now_s: float) -> float:
        """How long the thread has not run (s)."""
        return now_s - self.ran_s

    def heard_silence_s(self, last_heard_s: float) -> float:
        """Of the silence since ``last_heard_s`` (s), the part the thread listened to (from its last resumption)."""
        return self.ran_s - max(last_heard_s, self.resumed_s)


@dataclass
class SimulatedBoard:
    """The simulated regulators' board: each command at the world time it arrived; a vent when commands stop.

    The caller hands in commands as they arrive (:meth:`receive`), each with the world time it arrived at
    (the caller's estimate from the wall clock), and asks, at each wake-up with the world's time, what to
    apply (:meth:`take`): every command received since, in order, each at its own time (never before the
    previous one nor after the wake-up), or zeros once when the last one is older than ``command_timeout_s``
    of world time. A command dated between two wake-ups is exact in the muscles as long as their supply line's
    delay is longer than the time between wake-ups: it reaches them only after the delay.
    """

    joint_count: int
    command_timeout_s: float
    silence_vents: int = 0  # times the board vented by itself
    vented_by_silence: bool = False  # True while it holds 0 bar because commands stopped (until the next one)
    _pending: deque = field(default_factory=lambda: deque(maxlen=MAX_PENDING_COMMANDS), repr=False)
    _last_command_world_s: float = -math.inf
    _vented: bool = True  # starts vented: nothing to time out before the first command
    _silence_from_world_s: float = -math.inf  # the last world time the receiver was behind: silence counts after it

    def receive(self, pressure_bar: np.ndarray, world_s: float | None = None) -> None:
        """A command arrived (already checked and clamped by the caller) at world time ``world_s`` (None: now)."""
        self._pending.append((world_s, np.asarray(pressure_bar, dtype=np.float64)))

    def take(self, world_s: float) -> list[tuple[float, np.ndarray]]:
        """What to command by world time ``world_s`` (s): ``[(time s, bar), ...]``, a vent of zeros, or nothing."""
        taken = []
        while self._pending:
            arrived_s, pressure = self._pending.popleft()
            when_s = world_s if arrived_s is None else min(max(arrived_s, self._last_command_world_s), world_s)
            self._last_command_world_s = when_s
            taken.append((when_s, pressure))
        if taken:
            self._vented = self.vented_by_silence = False
            return taken
        silent_since_s = max(self._last_command_world_s, self._silence_from_world_s)
        if not self._vented and world_s - silent_since_s > self.command_timeout_s:
            self._vented = self.vented_by_silence = True
            self.silence_vents += 1
            self._last_command_world_s = world_s  # a command dated before the vent comes after it
            return [(world_s, np.zeros(self.joint_count))]
        return []

    def receiver_behind(self, world_s: float) -> None:
        """The caller's receiving thread is behind at world time ``world_s`` (s): commands may be waiting unread.

        Silence counts only from here, so the sender gets a whole ``command_timeout_s`` once the receiver runs again.
        """
        self._silence_from_world_s = max(self._silence_from_world_s, world_s)

    def reset(self) -> None:
        """Forget every command (the world was reset, vented)."""
        self._pending.clear()
        self._last_command_world_s = self._silence_from_world_s = -math.inf
        self._vented, self.vented_by_silence = True, False
