"""The fine approach: the last centimetres to a goal, crept just above the muscles' deadzone.

At 4 bar the rolling body lies as a C (about 200 deg of bend) and the tracked point (the midpoint of the end
markers) sits in the C's mouth; when the gait stops the body straightens and that point moves 10-35 cm. At an
amplitude a little above the deadzone (``fine_amplitude_bar``, 1.5 bar) the body bends little: it still rolls
about a skin circumference per cycle (12-18 cm) but, slowly (``fine_frequency_hz``, 0.25 Hz), it comes to rest
about 4 cm along its travel either way and under 0.2 cm across it, repeatably at one gait phase (at 2 bar: -2 to
+7 cm along, under 1 cm across; measured on the default, anisotropic and calibrated physics:
docs/studies/navigation.md, "A creep just above the deadzone").
It hardly turns (under 1 deg per cycle) and it rolls both ways, so near the goal the robot moves on a line,
square to its body: at rest near the goal it creeps along that line toward the goal, inward or outward rolling
(back and forth with a run-up if it went past), and stops at a stop phase about a second ahead
(:data:`FINE_STOP_LEAD_S`) when it is predicted to rest on the goal. A goal
that lies off the line (farther across it than :data:`FINE_LINE_WITHIN` x the tolerance) is turned to on the spot
first, or driven round to with the cruise gait (:mod:`srs_ros.core.navigation.approach` decides).
:class:`FineApproach` holds that state and the resting points it learns.
"""

from __future__ import annotations

import math

import numpy as np

from srs_ros.core.navigation.motion import Pose2D, PoseHistory, wrap_rad
from srs_ros.core.navigation.settings import DIRECTIONS, STOP_PHASES, NavigationSettings, square_rad
from srs_ros.core.navigation.stopping import STOP_WITHIN, rotate

#: A goal farther across the creeping line than this (times goal_tolerance_m) is not crept to. A line that passes
#: the goal this close still ends within the tolerance; beyond it the robot turns on the spot, whose 4 bar strokes a
#: rolling body does not repeat closely (docs/studies/navigation.md, "The goal a little off the creeping line").
FINE_LINE_WITHIN = 0.85
#: Seconds after the fine gait starts (a cross-fade from the cruise gait, a start from rest or a reversal)
#: before the line and the speed are taken from the camera: the body straightens and settles meanwhile.
FINE_SETTLE_S = 2.0
#: The same after a reversal while creeping: the signed frequency ramps through 0 (gait_player's 1 s ramp).
FINE_REVERSE_SETTLE_S = 1.0
#: The speed along the line is measured over this long (s).
FINE_SPEED_WINDOW_S = 0.5
#: The creeping line is taken from the robot's motion once it moved this far within FINE_SPEED_WINDOW_S (m).
FINE_MIN_MOVE_M = 0.01
#: ... and only when that motion lies within this angle (rad) of square to the body in the gait's direction: a
#: nearly straight body creeps up to 10 deg off square; a motion farther off is not the creep (the body still
#: rolling on from the gait before, or pushed), and taken as the line it once taught the skew 180 deg and sent every
#: later creep the wrong way (docs/studies/navigation.md, "A skew learned backwards").
FINE_MAX_SKEW_RAD = math.radians(30.0)
#: First guess of where the robot rests after a stop at each stop phase: (along, across) its travel (m);
#: measured at 1.5 bar 0.25 Hz: +3.6 cm along on average (a 6 cm range over the stop phases), under 0.2 cm across
#: (2 bar: -4 .. +10 cm along, under 1 cm across); learned at every stop.
FINE_REST_GUESS_M = (0.02, 0.0)
#: A reversal needs the goal at least this far behind (times goal_tolerance_m), and the run-up a stop needs.
FINE_REVERSE_BEYOND = 0.3
#: A creep that moves the robot less than this along its line, either way, in a whole cycle (m) is too weak for this
#: body (the model's bodies creep 11-13 cm a cycle at 1.5 bar 0.25 Hz; a body whose muscles cannot bend it much near
#: the deadzone, the held spin of config/sim_held_spin.yaml, 2 cm): its amplitude is then raised by
#: FINE_AMPLITUDE_STEP_BAR for the rest of the run (docs/studies/navigation.md, "A creep too weak for its body"). A
#: creep moving the robot the wrong way is left to the sides' and the skew's learning.
FINE_MIN_STEP_M = 0.04
#: How much a too weak creep's amplitude is raised at a time (bar) ...
FINE_AMPLITUDE_STEP_BAR = 0.5
#: ... and at most in all, above fine_amplitude_bar (and never above amplitude_bar): a creep that stood still for
#: another reason (an e-stop, a hand on the robot) must not leave the fine approach at the cruise gait's amplitude.
FINE_MAX_RAISE_BAR = 1.0
#: A creep stop is set this long (s) before the gait reaches its phase, at least a quarter cycle and at most a whole
#: one (:func:`stop_quarters_ahead`): a pose or a command that comes late by less still stops the gait at the phase
#: the prediction was made for (at 0.25 Hz the next stop phase; at 1 Hz the same phase a cycle later).
FINE_STOP_LEAD_S = 1.0


class FineApproach:
    """Whether the robot creeps, on which line, and where it rests after a stop per direction and stop phase."""

    def __init__(self, learning_rate: float):
        self.learning_rate = float(learning_rate)
        #: The creep's raises so far (:meth:`raise_amplitude`), counted from the fine_amplitude_bar they were made at;
        #: why the last one was made (one line for the status, '' before any).
        self._raises, self._raised_from_bar, self.raise_note = 0, math.nan, ""
        #: The creep now played (direction, amplitude, frequency) and since when (s): a whole cycle of it is judged.
        self._playing: tuple | None = None
        self._playing_since_s = 0.0
        self.active = False
        self.since_s = 0.0
        self.pivot_sense, self.pivot_since_s, self.pivots = 0, 0.0, 0
        self._strokes: list[tuple[str, int]] = []
        self.forget_rests()
        #: Per direction, the angle from the body's yaw (a 1 s fit while creeping, used from rest) to the yaw whose
        #: square the robot creeps on (rad): a nearly straight body still creeps up to 10 deg off square, the same
        #: way every time (measured).
        self.skew_rad = {d: 0.0 for d in DIRECTIONS}
        self._skew_measured = {d: 0 for d in DIRECTIONS}
        self._skew_episode: tuple[float, float] | None = None
        #: Per turn on the spot, (its first stroke's direction, its nominal sense: +1 the strokes that turn the
        #: body counter-clockwise by the learned rates), how far it was seen to turn the resting body (rad). Strokes
        #: from rest are not the steady gait: a start can kick the body round more than the cycles turn it, even the
        #: other way round, and which way depends on the direction of the first stroke (the calibrated physics).
        self.pivot_turn_rad: dict[tuple[str, int], float] = {}
        self._pivot_from: tuple[tuple[str, int], float] | None = None  # (its key, the resting yaw) under way

    def forget_rests(self) -> None:
        """Back to the first guess of where a creep rests after a stop (the learned ones were in the wrong frame)."""
        self.offset_m = {d: np.tile(np.asarray(FINE_REST_GUESS_M, dtype=np.float64), (len(STOP_PHASES), 1))
                         for d in DIRECTIONS}
        self.measured = {d: np.zeros(len(STOP_PHASES), dtype=int) for d in DIRECTIONS}

    def start(self, now_s: float) -> None:
        """Begin creeping (from rest: the controller starts it after a stop near the goal, on the goal's line)."""
        self.active, self.since_s = True, float(now_s)

    def leave(self) -> None:
        """Stop creeping or turning on the spot (the goal off the line, a cancel, a stop)."""
        self.active = False
        self.pivot_sense = 0

    def reset(self) -> None:
        """A new goal: neither creeping nor turning, no turn on the spot done yet (what was learned is kept)."""
        self.leave()
        self.pivots = 0
        self._pivot_from = None

    def pivot_choice(self, sign: int, keys: list[tuple[str, int]]) -> tuple[str, int] | None:
        """The turn on the spot to play for ``sign`` (+1 counter-clockwise), or None.

        Of ``keys`` (first stroke's direction, nominal sense), in order of preference: the first seen to turn the
        resting body that way, else the first not yet seen (tried), else None (each was seen to turn the other way).
        """
        seen = self.pivot_turn_rad
        for key in keys:
            if key in seen and seen[key] * sign > 0.0:
                return key
        return next((key for key in keys if key not in seen), None)

    def learn_pivot(self, resting_yaw_rad: float) -> None:
        """The body rests after a turn on the spot: take how far it turned into that turn's estimate."""
        if self._pivot_from is None:
            return
        key, before = self._pivot_from
        self._pivot_from = None
        turned = wrap_rad(resting_yaw_rad - before)
        known = self.pivot_turn_rad.get(key)
        self.pivot_turn_rad[key] = turned if known is None else known + self.learning_rate * (turned - known)

    def start_pivot(self, now_s: float, sense: int, strokes: list[tuple[str, int]], nominal: int | None = None,
                    resting_yaw_rad: float | None = None) -> None:
        """Turn on the spot, ``sense`` +1 counter-clockwise: ``strokes`` (direction, turn level index), a cycle each.

        ``nominal``: the sense whose strokes these are (default ``sense``); with ``resting_yaw_rad`` the turn is
        measured once the body rests again (:meth:`learn_pivot`), under the key (first direction, nominal).
        """
        self.pivot_sense, self.pivot_since_s, self._strokes = int(sense), float(now_s), list(strokes)
        self.pivots += 1
        key = (strokes[0][0], int(sense) if nominal is None else int(nominal))
        self._pivot_from = None if resting_yaw_rad is None else (key, float(resting_yaw_rad))

    def pivot_stroke(self, now_s: float, period_s: float) -> tuple[str, int] | None:
        """The stroke to play now (a cycle each), None once both are played."""
        index = int((now_s - self.pivot_since_s) // period_s)
        return self._strokes[index] if index < len(self._strokes) else None

    def settled(self, now_s: float, changed_s: float) -> bool:
        """True once the fine gait has played long enough to measure its line and speed.

        :data:`FINE_SETTLE_S` since it started (from rest or from the cruise gait) and
        :data:`FINE_REVERSE_SETTLE_S` since its direction last changed (``changed_s``).
        """
        return now_s - self.since_s >= FINE_SETTLE_S and now_s - changed_s >= FINE_REVERSE_SETTLE_S

    def amplitude_bar(self, settings: NavigationSettings) -> float:
        """The creep's amplitude now (bar): ``fine_amplitude_bar``, raised as the creep was seen too weak.

        Read from the settings each time (a node changes them live): raises made from another fine_amplitude_bar
        are void; never above :data:`FINE_MAX_RAISE_BAR` over it, nor above ``amplitude_bar``.
        """
        fine_bar = settings.fine_amplitude_bar
        if self._raised_from_bar != fine_bar:
            self._raises, self._raised_from_bar, self.raise_note = 0, fine_bar, ""
        raised = fine_bar + min(self._raises * FINE_AMPLITUDE_STEP_BAR, FINE_MAX_RAISE_BAR)
        return min(raised, max(settings.amplitude_bar, fine_bar))

    def playing(self, key: tuple, now_s: float) -> float:
        """Note the creep played now (``key``: direction, amplitude, frequency); returns since when it has played."""
        if key != self._playing:
            self._playing, self._playing_since_s = key, float(now_s)
        return max(self._playing_since_s, self.since_s)

    def weak_cycle(self, history: PoseHistory, heading_rad: float, period_s: float, playing_since_s: float
                   ) -> float | None:
        """The move (m) along ``heading_rad`` over the last whole cycle, when it is within :data:`FINE_MIN_STEP_M`.

        None while the creep has not played a whole cycle past :data:`FINE_SETTLE_S` since ``playing_since_s`` (its
        start, or its last change of direction, amplitude or frequency), and when it moved the robot that far or
        farther either way.
        """
        now_s = float(history.window(0.0)[-1, 0]) if len(history) else -math.inf
        if now_s - playing_since_s < FINE_SETTLE_S + period_s:
            return None
        rows = history.window(period_s)
        if len(rows) < 3 or rows[-1, 0] - rows[0, 0] < 0.9 * period_s:
            return None
        moved = rows[-1, 1:3] - rows[0, 1:3]
        along = float(moved[0] * math.cos(heading_rad) + moved[1] * math.sin(heading_rad))
        return along if abs(along) < FINE_MIN_STEP_M else None

    def raise_amplitude(self, settings: NavigationSettings, now_s: float, why: str) -> float | None:
        """Creep :data:`FINE_AMPLITUDE_STEP_BAR` harder from now on (``why``: for the status); the new amplitude (bar).

        None if it cannot be raised further. The rests learned at the old amplitude are forgotten and the creep
        settles again from ``now_s``.
        """
        before = self.amplitude_bar(settings)
        self._raises += 1
        after = self.amplitude_bar(settings)
        if after <= before:
            self._raises -= 1
            return None
        self.raise_note = f"{why}: creeping at {after:g} bar from now on"
        self.forget_rests()
        self.start(now_s)
        return after

    @staticmethod
    def heading_rad(yaw_rad: float, direction: str) -> float:
        """The travel heading of a nearly straight body: square to its axis, to the left rolling inward."""
        return yaw_rad + square_rad(direction)

    @staticmethod
    def line(pose: Pose2D, goal: tuple[float, float], yaw_rad: float) -> tuple[float, float]:
        """The goal from the pose (m): along the inward-rolling travel, and across it (left positive)."""
        heading = yaw_rad + math.pi / 2
        dx, dy = goal[0] - pose.x_m, goal[1] - pose.y_m
        return (dx * math.cos(heading) + dy * math.sin(heading), -dx * math.sin(heading) + dy * math.cos(heading))

    @staticmethod
    def rests_on_goal(rest_xy_m, goal: tuple[float, float], yaw_rad: float, tolerance_m: float) -> bool:
        """True when a creep stop predicted to rest at ``rest_xy_m`` is worth making.

        The line passes the goal ``across`` away, so a rest on it ends within the tolerance only within
        ``sqrt(tolerance^2 - across^2)`` along it; the stop is made within :data:`STOP_WITHIN` of that (on the line
        itself: within STOP_WITHIN x the tolerance, as every other stop). A rule on the distance alone could never
        stop on a line passing the goal farther than STOP_WITHIN x the tolerance, however close along it came.
        """
        along, across = FineApproach.line(Pose2D(float(rest_xy_m[0]), float(rest_xy_m[1]), 0.0, 0.0), goal, yaw_rad)
        return abs(along) <= STOP_WITHIN * math.sqrt(max(tolerance_m ** 2 - across ** 2, 0.0))

    @staticmethod
    def direction(along_m: float, current: str | None, runup_m: float) -> str:
        """Inward rolling when the goal lies ahead along the line, outward when behind.

        The current direction is kept until the goal lies ``runup_m`` behind (a stop needs that run-up: the next
        stop phase and the roll-on).
        """
        if current in DIRECTIONS:
            ahead = along_m if current == DIRECTIONS[0] else -along_m
            if ahead > -runup_m:
                return current
        return DIRECTIONS[0] if along_m >= 0.0 else DIRECTIONS[1]

    def runup_m(self, direction: str, speed_m_s: float, frequency_hz: float, tolerance_m: float) -> float:
        """How far before the goal a stop must be decided (m).

        The creep to the stop phase it is set for (:func:`stop_lead_s`), the learned roll-on and the stop window.
        """
        lead = max(speed_m_s, 0.0) * stop_lead_s(frequency_hz)
        return max(FINE_REVERSE_BEYOND * tolerance_m,
                   lead + float(np.max(self.offset_m[direction][:, 0])) + tolerance_m)

    @staticmethod
    def line_yaw_rad(history: PoseHistory, direction: str, body_yaw_rad: float) -> float | None:
        """The body yaw whose square is the way the robot was seen to creep.

        Over the last :data:`FINE_SPEED_WINDOW_S`; None when it moved less than :data:`FINE_MIN_MOVE_M`, or more
        than :data:`FINE_MAX_SKEW_RAD` off square to the body (``body_yaw_rad``) in ``direction``.
        """
        rows = history.window(FINE_SPEED_WINDOW_S)
        if len(rows) < 3 or float(np.linalg.norm(rows[-1, 1:3] - rows[0, 1:3])) < FINE_MIN_MOVE_M:
            return None
        dx, dy = rows[-1, 1:3] - rows[0, 1:3]
        line_yaw = math.atan2(dy, dx) - square_rad(direction)
        return line_yaw if abs(wrap_rad(line_yaw - body_yaw_rad)) <= FINE_MAX_SKEW_RAD else None

    @staticmethod
    def speed_m_s(history: PoseHistory, heading_rad: float) -> float | None:
        """Speed along ``heading_rad`` over the last :data:`FINE_SPEED_WINDOW_S` (None: too few poses)."""
        rows = history.window(FINE_SPEED_WINDOW_S)
        if len(rows) < 3 or rows[-1, 0] - rows[0, 0] < 0.5 * FINE_SPEED_WINDOW_S:
            return None
        moved = rows[-1, 1:3] - rows[0, 1:3]
        along = moved[0] * math.cos(heading_rad) + moved[1] * math.sin(heading_rad)
        return float(along / (rows[-1, 0] - rows[0, 0]))

    def predicted_rest(self, pose: Pose2D, direction: str, heading_rad: float, speed_m_s: float, ahead_s: float,
                       phase_index: int) -> np.ndarray:
        """Where the robot rests (floor x, y) if it stops as the gait reaches stop phase ``phase_index``.

        That is ``ahead_s`` from now; it rolls on at ``speed_m_s`` along ``heading_rad`` until then.
        """
        where = np.array([pose.x_m, pose.y_m]) + max(speed_m_s, 0.0) * ahead_s * np.array(
            [math.cos(heading_rad), math.sin(heading_rad)])
        return where + rotate(self.offset_m[direction][phase_index], heading_rad)

    def line_yaw_at_rest(self, body_yaw_rad: float, direction: str) -> float:
        """The yaw whose square the robot will creep on in ``direction``, from the resting body's yaw."""
        return body_yaw_rad + self.skew_rad[direction]

    def learn_skew(self, direction: str, line_yaw_rad: float, body_yaw_rad: float,
                   episode: tuple[float, float]) -> None:
        """Take the creeping line seen (``line_yaw_rad``) against the body's yaw into the skew, once per ``episode``.

        ``episode`` names one creep (its start and its last direction change): the first measurement of a direction
        is taken whole, later ones at the learning rate.
        """
        if episode == self._skew_episode:
            return
        self._skew_episode = episode
        measured = wrap_rad(line_yaw_rad - body_yaw_rad)
        rate = 1.0 if self._skew_measured[direction] == 0 else self.learning_rate
        self.skew_rad[direction] += rate * wrap_rad(measured - self.skew_rad[direction])
        self._skew_measured[direction] += 1

    def learn(self, direction: str, phase_index: int, heading_rad: float, moved_m: np.ndarray) -> None:
        """Take a measured move from the stop to the rest (floor frame) into that phase's estimate."""
        measured = rotate(moved_m, -heading_rad)  # (along, across) the travel
        offsets = self.offset_m[direction]
        rate = 1.0 if self.measured[direction][phase_index] == 0 and self.learning_rate > 0.0 else self.learning_rate
        offsets[phase_index] += rate * (measured - offsets[phase_index])
        self.measured[direction][phase_index] += 1


def next_stop_phase(phase_index: int, reverse: bool, quarters: int = 1) -> int:
    """The stop phase the gait reaches ``quarters`` stop phases after ``phase_index`` (backward when ``reverse``)."""
    return (phase_index + (-quarters if reverse else quarters)) % len(STOP_PHASES)


def stop_quarters_ahead(frequency_hz: float) -> int:
    """How many stop phases (quarter cycles) ahead a creep stop is set: :data:`FINE_STOP_LEAD_S`, 1 to 4."""
    quarters = math.ceil(FINE_STOP_LEAD_S * len(STOP_PHASES) * max(frequency_hz, 1e-3) - 1e-9)
    return min(len(STOP_PHASES), max(1, quarters))


def stop_lead_s(frequency_hz: float) -> float:
    """The time (s) from a creep stop's decision to the stop phase it is set for, at ``frequency_hz``."""
    return stop_quarters_ahead(frequency_hz) / (len(STOP_PHASES) * max(frequency_hz, 1e-3))
