"""The cruise gait's stop, as the controller drives it: when to stop near the goal, where the robot will rest, settling.

:class:`CruiseStopping` is the part of :class:`~srs_ros.core.navigation.controller.NavigationController` that
stops the rolling gait at a stop phase (a quarter cycle apart) where the robot is predicted to rest on or near the
goal, a cycle ahead (``stop_cycle_ahead``), waits for the gait to pass that phase and the robot to rest, learns where
it rested (:class:`~srs_ros.core.navigation.stopping.StopModel`), and then finishes (reached) or drives on (the fine
approach from rest, :mod:`srs_ros.core.navigation.approach`). Why: docs/navigation.md, "Stopping"; what was
measured: docs/studies/navigation.md.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from srs_ros.core.navigation.approach import FINE_MAX_PIVOTS, FINE_YAW_WINDOW_S, rests_near_enough
from srs_ros.core.navigation.commands import NavigationState
from srs_ros.core.navigation.fine import FineApproach
from srs_ros.core.navigation.motion import SETTLE_CYCLES, Pose2D
from srs_ros.core.navigation.settings import DIRECTIONS, STOP_PHASES
from srs_ros.core.navigation.stopping import STOP_WITHIN, StopPlan, crossed_phase, landing_ahead

#: Cycles a direction must have been played before a stop counts on its learned resting point.
STOP_AFTER_CYCLES = 1.0
#: The cycle ahead of a stop moves as the last whole cycle did (True) or by the learned travel and turn (False).
CYCLE_AHEAD_FROM_LAST_CYCLE = True
#: A stop phase passed within this many cycles of the present one, in the same direction, is the one before it
#: (the stop phases are a quarter cycle apart): its predicted resting point and this one's give the next one's.
LAST_STOP_PHASE_CYCLES = 0.6
#: A creep's stop: the robot whose pose moved less than SETTLED_WITHIN_M over the last SETTLED_WINDOW_S (s) is at rest
#: before ``settle_s`` is up, once SETTLED_AFTER_S (s, the gait player's ramp-out) have passed since the stop: a
#: creep's nearly straight body rests within 0.5 s of its stop (under 2.3 mm of motion after it, default physics),
#: where a 4 bar body rolls on for 1.5 s.
SETTLED_WITHIN_M = 0.002
SETTLED_WINDOW_S = 0.3
SETTLED_AFTER_S = 1.0


class CruiseStopping:
    """The cruise gait's stop decisions, mixed into the controller (its models: ``self.stops``, ``self.travel``)."""

    def _crossed_stop_phase(self, now_s: float, crossed: int | None) -> int | None:
        """The stop phase passed since the last pose (``crossed``), once the direction has played long enough."""
        command = self._command
        if not command.moving or now_s - self._direction_since_s < STOP_AFTER_CYCLES / command.frequency_hz:
            return None
        return crossed

    def _passed_stop_phase(self, reverse: bool) -> int | None:
        """The stop phase the gait passed since the last call (None: none, or the phase is not known)."""
        before, self._phase_seen = self._phase_seen, self._phase
        if before is None or self._phase is None:
            return None
        return crossed_phase(before, self._phase, reverse)

    def _predicted_rest(self, pose: Pose2D, phase_index: int) -> tuple[np.ndarray, float]:
        """Where the robot would rest (floor x, y) and its travel heading then (rad), stopped now or a cycle later.

        Stopped at the stop phase just passed, or (``stop_cycle_ahead``) as the gait passes it a cycle later.

        A cycle ahead: the pose then is this one moved by a cycle's learned travel at the level played, along
        the travel heading turned by half the cycle's learned turn; the rest offset is that of the phase, in
        the heading turned by the whole cycle's turn.
        """
        direction, level = self._command.direction, self._level
        heading = self._travel_heading_rad(direction)
        where = np.array([pose.x_m, pose.y_m])
        if self.settings.stop_cycle_ahead:
            index = len(self.travel.levels_rad) // 2 if level is None else level
            turn = math.radians(float(self.turns.rates[direction][index]))
            travel = float(self.travel.travel_m[direction][index])
            step = travel * np.array([math.cos(heading + 0.5 * turn), math.sin(heading + 0.5 * turn)])
            last = self._last_cycle(pose) if CYCLE_AHEAD_FROM_LAST_CYCLE else None
            if last is not None:  # the last cycle seen at this phase, turned by its own turn
                moved, turned = last
                cos, sin = math.cos(turned), math.sin(turned)
                step = np.array([moved[0] * cos - moved[1] * sin, moved[0] * sin + moved[1] * cos])
                turn = turned
            where = where + step
            heading += turn
        return where + self.stops.rest_offset(direction, phase_index, heading, level), heading

    def _last_cycle(self, pose: Pose2D) -> tuple[np.ndarray, float] | None:
        """The move (m) and turn (rad) from the pose a cycle ago (the same gait phase) to ``pose``, or None.

        None unless the gait played one direction all that cycle and a pose was seen then (within a frame).
        """
        period_s = 1.0 / max(self._command.frequency_hz, 1e-3)
        if pose.time_s - self._direction_since_s < period_s * (1.0 + SETTLE_CYCLES):
            return None
        rows = self.history.window(period_s + 0.05)
        if not len(rows):
            return None
        then = rows[int(np.argmin(np.abs(rows[:, 0] - (pose.time_s - period_s))))]
        if abs(then[0] - (pose.time_s - period_s)) > 0.04:
            return None
        now_row = self.history.window(0.0)[-1]
        return now_row[1:3] - then[1:3], float(now_row[3] - then[3])

    def _stop_here(self, pose: Pose2D, phase_index: int) -> bool:
        """True to stop at the phase just passed (or a cycle later).

        The robot would rest within the stop window of the goal or, with the fine approach, on the goal's line
        (across its travel) near the goal, or anywhere near it (the fine approach goes on from rest: a cruise
        gait that waited for the line could circle the goal on its turning circle for a minute). Near it but not
        on it, the stop waits for a later stop phase predicted to rest on it (:func:`landing_ahead`).
        """
        rest, heading = self._predicted_rest(pose, phase_index)
        direction, period_s = self._command.direction, 1.0 / max(self._command.frequency_hz, 1e-3)
        previous, self._last_rest = self._last_rest, (rest, pose.time_s, direction)
        if not rests_near_enough(rest, heading, self.goal, self.settings, self.fine.pivots < FINE_MAX_PIVOTS):
            return False
        # Near the goal: a later stop phase predicted to rest on it is waited for (a stop at the first phase near
        # enough rested 15-20 cm short and crept the rest).
        last_phase = previous is not None and previous[2] == direction and \
            pose.time_s - previous[1] < LAST_STOP_PHASE_CYCLES * period_s
        return not (last_phase and landing_ahead(previous[0], rest, self.goal,
                                                 STOP_WITHIN * self.settings.goal_tolerance_m))

    def _begin_stop(self, pose: Pose2D, phase_index: int) -> None:
        direction, ahead = self._command.direction, self.settings.stop_cycle_ahead
        self.state = NavigationState.STOPPING
        predicted, _ = self._predicted_rest(pose, phase_index)
        self._stop = StopPlan(pose, direction, self._level, phase_index, ahead,
                              (float(predicted[0]), float(predicted[1])),
                              period_s=1.0 / max(self._command.frequency_hz, 1e-3))  # the frequency played
        if ahead:
            self._message = (f"stopping a cycle ahead, {self._distance(pose):.3f} m from the goal, as the gait "
                             f"passes phase {STOP_PHASES[phase_index]:g}; then waiting for the robot to rest")
            self._command = dataclasses.replace(self._stop_command(self._message),
                                                stop_phase=float(STOP_PHASES[phase_index]))
        else:
            self._stop.stopped, self._stop.heading_rad = pose, self._travel_heading_rad(direction)
            self._message = f"stopping at {self._distance(pose):.3f} m from the goal; waiting for the robot to rest"
            self._command = self._stop_command(self._message)
        self._level = None

    def _rested(self, waited_s: float, plan: StopPlan) -> bool:
        """True once the stopped robot has waited ``settle_s``; a creep's, once seen at rest after SETTLED_AFTER_S."""
        if waited_s >= self.settings.settle_s:
            return True
        return plan.fine and waited_s >= SETTLED_AFTER_S and self.history.at_rest(SETTLED_WINDOW_S, SETTLED_WITHIN_M)

    def _settle(self, pose: Pose2D) -> None:
        """Wait for the stop a cycle ahead; after ``settle_s`` at rest learn the resting point, then reached or on."""
        plan = self._stop
        if plan.stopped is None:
            period_s = plan.period_s
            crossed = self._passed_stop_phase(plan.direction == DIRECTIONS[1])
            if crossed == plan.phase_index or pose.time_s - plan.decided.time_s > 1.5 * period_s:
                plan.stopped = pose if crossed == plan.phase_index else None
                plan.heading_rad = (
                    FineApproach.heading_rad(self.history.smoothed_yaw_rad(FINE_YAW_WINDOW_S), plan.direction)
                    if plan.fine else
                    self.history.smoothed_yaw_rad(period_s) + self.travel.offset(plan.direction, plan.level))
                if plan.stopped is None:  # the phase was not seen: no learning from this stop
                    plan.stopped, plan.phase_index = pose, -1
            return
        if not self._rested(pose.time_s - plan.stopped.time_s, plan):
            return
        if plan.phase_index >= 0:
            moved = np.array([pose.x_m - plan.stopped.x_m, pose.y_m - plan.stopped.y_m])
            if plan.fine:
                self.fine.learn(plan.direction, plan.phase_index, plan.heading_rad, moved)
            else:
                self.stops.learn(plan.direction, plan.phase_index, plan.heading_rad, moved, plan.level)
        self.fine.learn_pivot(self.history.smoothed_yaw_rad(FINE_YAW_WINDOW_S))  # after a turn on the spot
        self.shuffle.learn(pose)  # after a move along the body's axis
        distance = self._distance(pose)
        if distance <= self.settings.goal_tolerance_m:
            self._finish(NavigationState.REACHED, f"goal reached: resting {distance:.3f} m from it "
                         f"(tolerance {self.settings.goal_tolerance_m:g} m)")
            return
        self.state = NavigationState.DRIVING
        self._message = f"came to rest {distance:.3f} m from the goal; driving on"
        self._new_three_point_row()
        self.fine.leave()  # creeping again only if the goal is still on the line, from where it rests now
        if self._index == len(self._goals) - 1:
            self._fine_from_rest(pose, distance)
