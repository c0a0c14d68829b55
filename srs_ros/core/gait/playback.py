"""Phase-based playback of a periodic joint-space cycle: the logic of the gait_player, without ROS.

A :class:`GaitPlayback` turns a sampled cycle (lengths in metres, shape ``(N, D)``, sample ``i`` at
phase ``i / N``) into a stream of setpoints, one per :meth:`GaitPlayback.step`. Every output is

    positions_m = gain * cycle(phase),   phase += frequency_hz * dt_s

so that nothing the caller changes makes a setpoint jump:

- the phase is integrated, so a frequency change alters the speed, never the position on the cycle;
- ``gain`` (0 when idle, ``amplitude_scale`` while playing) and ``frequency_hz`` each move to a new
  target along a raised-cosine ramp (zero slope at both ends) of ``ramp_time_s``, from where they are:
  one ramp for the soft start, the soft stop and every amplitude change, so a stop only ever lowers the
  gain and a start or a change moves it straight to its new level (two ramps multiplied, a start
  envelope and an amplitude, overshot: a stop 0.3 s after a raise first rose by half, and a start during
  a stop after ``amplitude_scale`` 0 rose to a fifth of the gait);
- a new cycle takes over by cross-fading from the old one over ``blend_time_s`` at the same phase.

Scaling lengths toward zero scales pressures toward zero (P = k * l), so a gain of 0 is the vented
robot and a ramp of the gain is a ramp of every pressure.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

import numpy as np

from srs_ros.core.errors import InvalidInputError
from srs_ros.core.gait.interpolation import PeriodicTrajectory
from srs_ros.core.ramp import DEFAULT_RAMP_TIME_S, smoothstep
from srs_ros.core.robot import CYCLE_FREQUENCY_RANGE_HZ


class SmoothTransition:
    """A scalar that moves to each new target along a raised cosine lasting ``duration_s``.

    A new target set mid-way starts a fresh transition from the current value, so the value itself
    never jumps.

    >>> gain = SmoothTransition(0.0)
    >>> gain.set_target(1.0, duration_s=2.0)
    >>> round(gain.step(1.0), 3), round(gain.step(1.0), 3)
    (0.5, 1.0)
    """

    def __init__(self, value: float):
        self.value = float(value)
        self._start = self.value
        self.target = self.value
        self._duration_s = 0.0
        self._elapsed_s = 0.0

    @property
    def settled(self) -> bool:
        """True once the value has reached its target."""
        return self.value == self.target

    def set_target(self, target: float, duration_s: float) -> None:
        """Start moving from the current value to ``target`` over ``duration_s`` (0 = at once)."""
        target = float(target)
        if target == self.target:
            return
        self._start, self.target = self.value, target
        self._duration_s, self._elapsed_s = max(float(duration_s), 0.0), 0.0
        if self._duration_s == 0.0:
            self.value = target

    def finish(self) -> None:
        """Reach the target at once."""
        self.value = self._start = self.target

    def step(self, dt_s: float) -> float:
        """Advance by ``dt_s`` seconds; return the new value."""
        if not self.settled:
            self._elapsed_s += dt_s
            progress = self._elapsed_s / self._duration_s if self._duration_s > 0 else 1.0
            self.value = self.target if progress >= 1.0 else (
                self._start + (self.target - self._start) * smoothstep(progress))
        return self.value


class _Mix:
    """A fixed mixture ``(1 - w) * old + w * new`` of two cycles (an interrupted cross-fade, frozen)."""

    def __init__(self, old, new, weight: float):
        self.old, self.new, self.weight = old, new, weight

    def values(self, phase) -> np.ndarray:
        return (1.0 - self.weight) * self.old.values(phase) + self.weight * self.new.values(phase)

    def derivatives(self, phase) -> np.ndarray:
        return (1.0 - self.weight) * self.old.derivatives(phase) + self.weight * self.new.derivatives(phase)


class PlaybackState(enum.Enum):
    """Where the playback is: IDLE outputs zeros; the others move along the cycle."""

    IDLE = "idle"
    STARTING = "starting"
    RUNNING = "running"
    STOPPING = "stopping"


@dataclass(frozen=True)
class Setpoint:
    """One output of :meth:`GaitPlayback.step`."""

    positions_m: np.ndarray
    velocities_m_per_s: np.ndarray
    phase: float
    cycles_done: float
    gain: float
    frequency_hz: float
    state: PlaybackState


class GaitPlayback:
    """Plays a periodic cycle with soft start/stop, live amplitude/frequency and jump-free takeover.

    >>> import numpy as np
    >>> player = GaitPlayback(ramp_time_s=0.5)
    >>> player.load(0.03 * (1 + np.sin(2 * np.pi * np.arange(32) / 32))[:, None], frequency_hz=1.0)
    >>> player.start()
    >>> [player.step(0.01).state.value for _ in range(2)][-1]
    'starting'
    """

    def __init__(self, ramp_time_s: float = DEFAULT_RAMP_TIME_S, blend_time_s: float = 0.5,
                 max_length_m: float = math.inf):
        self.max_length_m = self._positive("max_length_m", max_length_m) if math.isfinite(max_length_m) else math.inf
        self.ramp_time_s = self._positive("ramp_time_s", ramp_time_s, allow_zero=True)
        self.blend_time_s = self._positive("blend_time_s", blend_time_s, allow_zero=True)
        self._cycle = None
        self._old_cycle = None
        self._blend = SmoothTransition(1.0)
        self._gain_ramp = SmoothTransition(0.0)
        self._scale = 1.0  # amplitude_scale: the gain's level while playing
        self._frequency = SmoothTransition(0.0)
        self._trajectory_frequency_hz = 0.0
        self._frequency_override_hz = 0.0
        self._direction = 1.0
        self._phase = 0.0
        self._cycles_done = 0.0
        self._stop_after_cycles: float | None = None
        self._stop_at_phase: float | None = None
        self.state = PlaybackState.IDLE

    # ---------------------------------------------------------------- inputs
    @staticmethod
    def _positive(name: str, value: float, allow_zero: bool = False) -> float:
        value = float(value)
        if not math.isfinite(value) or value < 0.0 or (value == 0.0 and not allow_zero):
            bound = ">= 0" if allow_zero else "> 0"
            raise InvalidInputError(f"{name}: expected a finite number {bound}, got {value!r}.")
        return value

    @property
    def has_cycle(self) -> bool:
        """True once a cycle has been loaded."""
        return self._cycle is not None

    @property
    def dimension(self) -> int | None:
        """Number of joints of the loaded cycle (None before the first one)."""
        return None if self._cycle is None else self._cycle.values(0.0).shape[-1]

    def load(self, samples_m, frequency_hz: float) -> None:
        """Take a new cycle ``(N, D)`` at ``frequency_hz``; while playing, cross-fade to it at the same phase."""
        cycle = PeriodicTrajectory(samples_m)
        frequency_hz = self._positive("frequency_hz", frequency_hz)
        if self.dimension is not None and cycle.samples.shape[1] != self.dimension:
            raise InvalidInputError(
                f"samples_m: the new cycle has {cycle.samples.shape[1]} joints, the playing one {self.dimension}; "
                "a takeover must keep the joint count.")
        playing = self.state is not PlaybackState.IDLE and self._cycle is not None
        if playing and self.blend_time_s > 0.0:
            current = self._cycle if self._old_cycle is None else _Mix(self._old_cycle, self._cycle, self._blend.value)
            self._old_cycle = current
            self._blend = SmoothTransition(0.0)
            self._blend.set_target(1.0, self.blend_time_s)
        else:
            self._old_cycle = None
            self._blend = SmoothTransition(1.0)
        self._cycle = cycle
        self._trajectory_frequency_hz = frequency_hz
        self._retarget_frequency(self.blend_time_s if playing else 0.0)

    def start(self, cycles: int = 0, phase: float = 0.0) -> None:
        """Ramp in (from ``phase`` of the cycle, 0 by default, if idle); ``cycles`` > 0 ramps out after that many.

        ``phase`` in [0, 1): where an idle playback begins (``benchmarks/bench_creep_restart.py`` starts a resting
        rolling body where its last ramp-out ended, :attr:`phase`, to study the first stroke from rest).
        """
        if self._cycle is None:
            raise InvalidInputError("start: no cycle loaded yet; load a trajectory first.")
        if cycles < 0:
            raise InvalidInputError(f"cycles: expected an integer >= 0 (0 = forever), got {cycles}.")
        phase = float(phase)
        if not 0.0 <= phase < 1.0:
            raise InvalidInputError(f"phase: expected a phase in [0, 1), got {phase!r}.")
        if self.state is PlaybackState.IDLE:
            self._phase, self._cycles_done = phase, 0.0
            self._stop_at_phase = None
            self._retarget_frequency(0.0)
        self._stop_after_cycles = self._cycles_done + cycles if cycles > 0 else None
        if self.state is not PlaybackState.RUNNING:
            self.state = PlaybackState.STARTING
            self._aim_gain()

    def stop(self) -> None:
        """Ramp out to zero over ``ramp_time_s`` (the cycle keeps moving meanwhile), then go idle."""
        if self.state in (PlaybackState.STARTING, PlaybackState.RUNNING):
            self.state = PlaybackState.STOPPING
            self._aim_gain()
        self._stop_after_cycles = None
        self._stop_at_phase = None

    def stop_at_phase(self, phase: float | None) -> None:
        """Ramp out (as :meth:`stop`) when the played phase next passes ``phase`` in [0, 1); None: no such stop.

        A robot stopped at the same phase of its gait comes to rest at the same place relative to where it
        was at that phase, so a caller that decides late (a camera frame's age, a message's latency) still
        stops the robot exactly: up to one cycle ahead. Played backward, the phase passes ``phase`` going down.
        A later :meth:`stop` stops at once; a :meth:`start` while playing keeps the pending stop.
        """
        if phase is not None:
            phase = float(phase)
            if not (0.0 <= phase < 1.0):
                raise InvalidInputError(f"stop phase: expected a phase in [0, 1) or None, got {phase!r}.")
        self._stop_at_phase = phase

    @property
    def pending_stop_phase(self) -> float | None:
        """The phase at which the playback will ramp out (:meth:`stop_at_phase`), None when none is pending."""
        return self._stop_at_phase

    def set_amplitude_scale(self, scale: float) -> None:
        """Scale every length by ``scale`` in [0, 1], reached smoothly over ``ramp_time_s``.

        Idle or stopping, it is where the next start ramps to; a stop under way goes on to 0.
        """
        scale = float(scale)
        if not (0.0 <= scale <= 1.0):
            raise InvalidInputError(f"amplitude_scale: expected a value in [0, 1], got {scale!r}.")
        self._scale = scale
        self._aim_gain()

    def _aim_gain(self) -> None:
        """Ramp the gain from where it is to the scale while playing, to 0 otherwise."""
        playing = self.state in (PlaybackState.STARTING, PlaybackState.RUNNING)
        self._gain_ramp.set_target(self._scale if playing else 0.0, self.ramp_time_s)

    def set_frequency_override(self, frequency_hz: float) -> None:
        """Play at ``frequency_hz`` instead of the cycle's own (0 = the cycle's), reached over ``ramp_time_s``."""
        frequency_hz = self._positive("frequency_hz", frequency_hz, allow_zero=True)
        if 0.0 < frequency_hz < CYCLE_FREQUENCY_RANGE_HZ[0]:
            raise InvalidInputError(frequency_refusal(frequency_hz))
        self._frequency_override_hz = frequency_hz
        self._retarget_frequency(self.ramp_time_s)

    def set_reverse(self, reverse: bool) -> None:
        """Play the cycle backward in time (True) or forward; the signed frequency passes smoothly through 0.

        Reversed, a rolling cycle is the opposite rolling gait (outward rolling is inward rolling reversed
        in time), so this turns the robot's travel round without a jump of any setpoint.
        """
        direction = -1.0 if reverse else 1.0
        if direction != self._direction:
            self._direction = direction
            self._retarget_frequency(self.ramp_time_s)

    @property
    def reverse(self) -> bool:
        """True while the cycle is played (or ramping to being played) backward."""
        return self._direction < 0.0

    def set_ramp_time(self, ramp_time_s: float) -> None:
        """Duration of the soft start/stop and of amplitude/frequency changes (takes effect at the next change)."""
        self.ramp_time_s = self._positive("ramp_time_s", ramp_time_s, allow_zero=True)

    def set_blend_time(self, blend_time_s: float) -> None:
        """Duration of the cross-fade when a new cycle takes over."""
        self.blend_time_s = self._positive("blend_time_s", blend_time_s, allow_zero=True)

    def _retarget_frequency(self, duration_s: float) -> None:
        target = self._direction * (self._frequency_override_hz or self._trajectory_frequency_hz)
        if self.state is PlaybackState.IDLE:
            duration_s = 0.0
        self._frequency.set_target(target, duration_s)

    # ---------------------------------------------------------------- output
    @property
    def phase(self) -> float:
        """Current phase in [0, 1)."""
        return self._phase

    @property
    def cycles_done(self) -> float:
        """Cycles played since the last start (the whole part counts cycles, the fraction is the phase)."""
        return self._cycles_done

    @property
    def frequency_hz(self) -> float:
        """Frequency currently played (moving to its target after a change; negative while reversed)."""
        return self._frequency.value

    @property
    def target_frequency_hz(self) -> float:
        """The frequency :attr:`frequency_hz` is moving to (itself once settled; negative when reversed)."""
        return self._frequency.target

    def _shape(self, phase: float) -> tuple[np.ndarray, np.ndarray]:
        """Blended cycle values and d/dphase at ``phase``."""
        values, slopes = self._cycle.values(phase), self._cycle.derivatives(phase)
        if self._old_cycle is not None:
            w = self._blend.value
            values = (1.0 - w) * self._old_cycle.values(phase) + w * values
            slopes = (1.0 - w) * self._old_cycle.derivatives(phase) + w * slopes
        return values, slopes

    def _gain(self) -> float:
        return self._gain_ramp.value

    def step(self, dt_s: float) -> Setpoint:
        """Advance the playback by ``dt_s`` seconds and return the setpoint for the new instant."""
        dt_s = self._positive("dt_s", dt_s, allow_zero=True)
        if self._cycle is None:
            raise InvalidInputError("step: no cycle loaded yet; load a trajectory first.")
        if self.state is PlaybackState.IDLE:
            zeros = np.zeros(self.dimension)
            return Setpoint(zeros, zeros.copy(), self._phase, self._cycles_done, 0.0, 0.0, self.state)

        gain_before, blend_before, old_cycle = self._gain(), self._blend.value, self._old_cycle
        frequency_hz = self._frequency.step(dt_s)
        advance = frequency_hz * dt_s
        passed = self._passes_stop_phase(advance)
        self._phase = (self._phase + advance) % 1.0
        self._cycles_done += abs(advance)
        self._gain_ramp.step(dt_s)
        self._blend.step(dt_s)
        if self._old_cycle is not None and self._blend.settled:
            self._old_cycle = None
        self._advance_state(passed)

        gain = self._gain()
        values, slopes = self._shape(self._phase)
        velocities = gain * slopes * frequency_hz
        if dt_s > 0.0:
            velocities = velocities + (gain - gain_before) / dt_s * values
            if old_cycle is not None:
                fade_rate = (self._blend.value - blend_before) / dt_s
                velocities = velocities + gain * fade_rate * (
                    self._cycle.values(self._phase) - old_cycle.values(self._phase))
        # Extending muscles within their stroke: the spline's overshoot near a kink of the cycle (below 0,
        # above the largest extension) is not a command.
        positions = np.clip(gain * values, 0.0, self.max_length_m)
        return Setpoint(positions, velocities, self._phase, self._cycles_done, gain, frequency_hz, self.state)

    def _passes_stop_phase(self, advance: float) -> bool:
        """True when advancing the phase by ``advance`` (signed) reaches or passes the pending stop phase."""
        if self._stop_at_phase is None or advance == 0.0 or abs(advance) >= 1.0:
            return self._stop_at_phase is not None and abs(advance) >= 1.0
        ahead = self._stop_at_phase - self._phase
        to_stop = ahead % 1.0 if advance > 0 else (-ahead) % 1.0
        return 0.0 < to_stop <= abs(advance)

    def _advance_state(self, passed_stop_phase: bool = False) -> None:
        if passed_stop_phase and self.state in (PlaybackState.STARTING, PlaybackState.RUNNING):
            self.stop()
        if self._stop_after_cycles is not None and self._cycles_done >= self._stop_after_cycles:
            self.stop()
        if self.state is PlaybackState.STARTING and self._gain_ramp.settled:
            self.state = PlaybackState.RUNNING
        elif self.state is PlaybackState.STOPPING and self._gain_ramp.settled:
            self.state = PlaybackState.IDLE
            self._old_cycle = None
            self._blend = SmoothTransition(1.0)


#: The most trajectory points the player takes (the trajectory_server sends at most 1025); a larger
#: message is refused instead of stalling the real-time stream while it is loaded.
MAX_TRAJECTORY_POINTS = 2049


def cycle_from_points(joint_names, times_s, positions_m, expected_names, max_length_m: float,
                      tolerance_m: float = 1e-6) -> tuple[np.ndarray, float]:
    """One period of trajectory points -> ``(samples (N, D) in expected_names order, frequency_hz)``.

    The points must start at time 0, strictly increase and be equally spaced in time, hold one finite
    length per joint within ``[0, max_length_m]``, and last a period whose frequency lies in
    :data:`~srs_ros.core.robot.CYCLE_FREQUENCY_RANGE_HZ`. If the last point repeats the first (within
    ``tolerance_m``), it closes the cycle and its time is the period (what the trajectory_server
    publishes); otherwise the period is one step longer than the last time. Raises
    :class:`InvalidInputError` saying what is wrong with the message.
    """
    names = list(joint_names)
    missing = [n for n in expected_names if n not in names]
    unknown = [n for n in names if n not in expected_names]
    if missing or unknown or len(set(names)) != len(names):
        raise InvalidInputError(
            f"joint_names: expected each of {list(expected_names)} once, got {names} "
            f"(missing {missing}, unknown {unknown}).")
    count = len(times_s)
    if not (5 <= count <= MAX_TRAJECTORY_POINTS) or len(positions_m) != count:
        raise InvalidInputError(f"points: expected 5 to {MAX_TRAJECTORY_POINTS} points over one period, "
                                f"got {len(positions_m)} (with {count} times).")
    ragged = next((i for i, row in enumerate(positions_m) if len(row) != len(names)), None)
    if ragged is not None:
        raise InvalidInputError(f"points: point {ragged} has {len(positions_m[ragged])} positions; expected "
                                f"{len(names)}, one per joint name.")
    times = np.asarray(times_s, dtype=np.float64)
    points = np.asarray(positions_m, dtype=np.float64)
    if not (np.all(np.isfinite(times)) and np.all(np.isfinite(points))):
        raise InvalidInputError("points: every time_from_start and position must be finite.")
    steps = np.diff(times)
    if np.any(steps <= 0.0):
        i = int(np.argmax(steps <= 0.0))
        raise InvalidInputError(f"time_from_start: expected strictly increasing times; point {i + 1} is at "
                                f"{times[i + 1]:.6f} s after point {i} at {times[i]:.6f} s.")
    step = float(np.mean(steps))
    if abs(times[0]) > 1e-6 or np.max(np.abs(steps - step)) > 0.01 * step:
        raise InvalidInputError(
            "time_from_start: expected equally spaced times from 0 over one period, "
            f"got {times[0]:.6f} .. {times[-1]:.6f} s with steps {steps.min():.6f} .. {steps.max():.6f} s.")
    low, high = float(points.min()), float(points.max())
    if low < 0.0 or high > max_length_m:
        raise InvalidInputError(
            f"positions: lengths must lie in [0, {max_length_m}] m (extending muscles, at most their largest "
            f"extension), got {low:.4f} .. {high:.4f} m.")
    ordered = points[:, [names.index(n) for n in expected_names]]
    if np.all(np.abs(ordered[-1] - ordered[0]) <= tolerance_m):
        samples, period_s = ordered[:-1], float(times[-1])
    else:
        samples, period_s = ordered, float(times[-1] + step)
    low_hz, high_hz = CYCLE_FREQUENCY_RANGE_HZ
    if not (low_hz <= 1.0 / period_s <= high_hz):
        raise InvalidInputError(f"time_from_start: the period is {period_s:.6g} s ({1.0 / period_s:.6g} Hz); "
                                f"expected a cycle frequency in [{low_hz:g}, {high_hz:g}] Hz.")
    return samples, 1.0 / period_s


def frequency_refusal(frequency_hz: float) -> str:
    """Why a playback frequency between 0 and the slowest cycle's is refused (it would hold a posture for minutes)."""
    low_hz, high_hz = CYCLE_FREQUENCY_RANGE_HZ
    return (f"frequency_hz {frequency_hz:g}: expected 0 (the trajectory's own) or a frequency in [{low_hz:g}, "
            f"{high_hz:g}] Hz; below {low_hz:g} Hz a cycle holds a posture at pressure for minutes.")


def describe_frequency(played_hz: float, target_hz: float) -> str:
    """A played frequency as a status line shows it, from signed values as :attr:`GaitPlayback.frequency_hz`.

    ``1 Hz`` once settled, ``0.37 Hz, ramping to 1 Hz`` after a change, ``0.37 Hz, reversing (then 1 Hz)`` while a
    reversal ramps the signed frequency through 0 (the robot slows, stops and rolls back the other way).
    """
    if played_hz == target_hz:
        return f"{abs(played_hz):.3g} Hz"
    if played_hz * target_hz < 0.0:
        return f"{abs(played_hz):.3g} Hz, reversing (then {abs(target_hz):.3g} Hz)"
    return f"{abs(played_hz):.3g} Hz, ramping to {abs(target_hz):.3g} Hz"
