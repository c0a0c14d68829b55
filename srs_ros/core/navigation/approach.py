"""The fine approach as the controller drives it: creep along the goal's line, turn on the spot toward it.

:class:`FineDriving` is the part of :class:`~srs_ros.core.navigation.controller.NavigationController` that
plays :mod:`srs_ros.core.navigation.fine` (why: there and docs/navigation.md; measured: docs/studies/navigation.md).
At rest near the last goal (after a stop, or given the goal at rest) the robot creeps at ``fine_amplitude_bar`` and
``fine_frequency_hz`` when the goal lies on the line square to its body, else it moves along its own axis onto
that line where the floor lets it (:mod:`srs_ros.core.navigation.shuffle`) or turns on the spot (an inward and an
outward stroke of the cruise gait at the turn levels that turn fastest the same way), and looks again; while
creeping it stops at the next stop phase where it is predicted to rest on the goal, reverses with a run-up when
it went past, and stops when the goal drifts off the line.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from srs_ros.core.navigation.commands import AXIS_DIRECTIONS, GaitCommand, NavigationState
from srs_ros.core.navigation.fine import (
    FINE_LINE_WITHIN,
    FINE_MIN_STEP_M,
    FineApproach,
    next_stop_phase,
    stop_lead_s,
    stop_quarters_ahead,
)
from srs_ros.core.navigation.motion import Pose2D
from srs_ros.core.navigation.settings import DIRECTIONS, STOP_PHASES, other_direction
from srs_ros.core.navigation.stopping import STOP_WITHIN, StopPlan

#: The fine approach takes the body's yaw from a line fit over this long (s): a nearly straight body hardly wobbles.
FINE_YAW_WINDOW_S = 1.0
#: With the fine approach the cruise gait also stops where the robot is predicted to rest on the goal's line:
#: the goal this close across its travel (times goal_tolerance_m) and this close along it (times fine_distance_m).
FINE_STOP_ACROSS = 0.5
FINE_STOP_ALONG = 0.6
#: ... or where it is predicted to rest this close to the goal (times fine_distance_m), on the line or not.
FINE_STOP_NEAR = 0.6
#: The fine approach turns on the spot toward the goal's line at most this many times per goal, each time only
#: when the line needs at most this much turn (rad); otherwise the cruise gait drives round.
FINE_MAX_PIVOTS = 6
FINE_PIVOT_MAX_RAD = math.radians(60.0)
#: ... except a goal this near (times goal_tolerance_m), which the cruise gait cannot land on (it rests 5-27 cm past
#: a stop): any turn the line needs (at most 90 deg). Near the body's axis the unit tests' stand-in cruised on
#: instead, switching direction every half cycle for a minute 4-7 cm from the goal, spinning the body round without
#: a stop (docs/studies/navigation.md, "A goal beside the resting robot").
FINE_PIVOT_ANY_WITHIN = 2.0
#: A robot whose pose moved less than 5 mm over this long (s) is at rest (a goal given at rest).
FINE_REST_WINDOW_S = 0.5


def rests_near_enough(rest_xy_m, heading_rad: float, goal: tuple[float, float], settings,
                      near_off_line: bool = True) -> bool:
    """True when a stop that rests at ``rest_xy_m`` (travelling along ``heading_rad``) is worth making.

    It rests within the stop window of the goal or, with the fine approach on, near the goal: on the goal's line
    (within FINE_STOP_ACROSS x the tolerance across the travel and FINE_STOP_ALONG x ``fine_distance_m`` along
    it), or anywhere within FINE_STOP_NEAR x ``fine_distance_m`` (the fine approach goes on from rest; a cruise
    gait that waited for the line circled some goals on its turning circle for a minute); ``near_off_line``
    False (no turn on the spot left for this goal) leaves that last case out, so the robot does not stop and
    start again near a goal it can no longer turn to.
    """
    tolerance, fine_m = settings.goal_tolerance_m, settings.fine_distance_m
    distance = math.dist(rest_xy_m, goal)
    if distance <= STOP_WITHIN * tolerance:
        return True
    along, across = FineApproach.line(Pose2D(float(rest_xy_m[0]), float(rest_xy_m[1]), 0.0, 0.0), goal,
                                      heading_rad - math.pi / 2)
    return fine_m > 0.0 and ((near_off_line and distance <= FINE_STOP_NEAR * fine_m) or (
        abs(across) <= FINE_STOP_ACROSS * tolerance and abs(along) <= FINE_STOP_ALONG * fine_m))


class FineDriving:
    """The fine approach's decisions, mixed into the controller (its state: ``self.fine``)."""

    def _creep(self, pose: Pose2D, distance: float, passed: int | None) -> bool:
        """The fine approach (:mod:`srs_ros.core.navigation.fine`): True when it gave the command for this pose."""
        settings, fine = self.settings, self.fine
        if fine.pivot_sense:
            self._pivot(pose)
            return True
        if not fine.active and not self._command.moving and distance < settings.fine_distance_m:
            if self.history.window(FINE_REST_WINDOW_S)[0, 0] > pose.time_s - 0.8 * FINE_REST_WINDOW_S:
                self._message = "a goal near the robot: watching whether it is at rest"
                return True  # too few poses yet to tell (a new goal given while the robot rests)
            if self.history.at_rest(FINE_REST_WINDOW_S) and self._fine_from_rest(pose, distance):
                if not self.state.active:  # reached where it lay
                    return True
                if fine.pivot_sense:
                    self._pivot(pose)
                    return True
        if not fine.active or settings.fine_distance_m <= 0.0:
            fine.leave()
            return False
        now_s, command = pose.time_s, self._command
        creeping = command.moving and command.creep
        if not creeping:
            fine.start(now_s)  # the body straightens from the cruise gait's C, or starts from rest
        settled = creeping and fine.settled(now_s, self._changed_s)
        body_yaw = self.history.smoothed_yaw_rad(FINE_YAW_WINDOW_S)
        if settled:  # the line the robot is seen to creep on (a nearly straight body still skews by up to 10 deg)
            seen = FineApproach.line_yaw_rad(self.history, command.direction, body_yaw)
            if seen is not None:
                fine.learn_skew(command.direction, seen, body_yaw, (fine.since_s, self._changed_s))
            yaw = body_yaw if seen is None else seen
        else:
            yaw = self._resting_line(pose)[3] if not creeping else fine.line_yaw_at_rest(body_yaw, command.direction)
        along, across = FineApproach.line(pose, self.goal, yaw)
        if settled and abs(across) > FINE_LINE_WITHIN * settings.goal_tolerance_m:
            fine.leave()
            self._message = f"the goal lies {100 * abs(across):.1f} cm off the line the robot creeps on: stopping"
            self.state = NavigationState.STOPPING  # at rest, it turns on the spot toward the goal or drives round
            self._stop = StopPlan(pose, command.direction, None, -1, False, (pose.x_m, pose.y_m), stopped=pose,
                                  fine=True)
            self._command = self._stop_command(self._message)
            return True
        direction = command.direction
        speed = FineApproach.speed_m_s(self.history, FineApproach.heading_rad(yaw, direction)) if settled else None
        if speed is not None or not creeping:
            runup = fine.runup_m(direction, speed or 0.0, settings.fine_frequency_hz, settings.goal_tolerance_m) \
                if creeping else 0.0
            direction = FineApproach.direction(along, direction if creeping else None, runup)
        heading = FineApproach.heading_rad(yaw, direction)
        self._heading_error_rad = math.atan2(across, along if direction == DIRECTIONS[0] else -along)
        if speed is not None and passed is not None and direction == command.direction:
            target = next_stop_phase(passed, command.reverse, stop_quarters_ahead(command.frequency_hz))
            rest = fine.predicted_rest(pose, direction, heading, speed, stop_lead_s(command.frequency_hz), target)
            if FineApproach.rests_on_goal(rest, self.goal, yaw, settings.goal_tolerance_m):
                self._begin_fine_stop(pose, direction, target, rest)
                return True
        self._message = f"creeping to the goal ({distance:.3f} m to go, {100 * abs(across):.1f} cm off the line)"
        if creeping and direction == command.direction:
            self._strengthen_weak_creep(now_s, heading, command)
        if fine.raise_note:
            self._message += f"; {fine.raise_note}"
        self._set_command(now_s, GaitCommand(direction, 0.0, fine.amplitude_bar(settings), settings.fine_frequency_hz,
                                             "creeping to the goal (fine approach)", creep=True), None)
        return True

    def _strengthen_weak_creep(self, now_s: float, heading_rad: float, command: GaitCommand) -> None:
        """A creep that moved the robot under FINE_MIN_STEP_M in its last whole cycle goes on at a higher amplitude."""
        fine, settings = self.fine, self.settings
        since_s = fine.playing((command.direction, command.amplitude_bar, command.frequency_hz), now_s)
        moved = fine.weak_cycle(self.history, heading_rad, 1.0 / command.frequency_hz, since_s)
        if moved is None:
            return
        fine.raise_amplitude(settings, now_s, f"the creep moved the robot {100 * abs(moved):.1f} cm in a cycle at "
                                              f"{command.amplitude_bar:g} bar (under {100 * FINE_MIN_STEP_M:g} cm)")

    def _begin_fine_stop(self, pose: Pose2D, direction: str, phase_index: int, rest: np.ndarray) -> None:
        self.state = NavigationState.STOPPING
        self._stop = StopPlan(pose, direction, None, phase_index, True, (float(rest[0]), float(rest[1])),
                              fine=True, period_s=1.0 / self._command.frequency_hz)
        self._message = (f"creeping: stopping {self._distance(pose):.3f} m from the goal as the gait reaches phase "
                         f"{STOP_PHASES[phase_index]:g}; then waiting for the robot to rest")
        self._command = dataclasses.replace(self._stop_command(self._message),
                                            stop_phase=float(STOP_PHASES[phase_index]))
        self._level = None

    def _fine_from_rest(self, pose: Pose2D, distance: float) -> bool:
        """At rest near the last goal: creep when it lies on the line, else move onto the line along the body's axis.

        The move along the axis where the floor lets it, else a turn on the spot toward the line if it can. A goal
        given within ``goal_tolerance_m`` of the resting robot is reached where it lies: creeping to it moved the
        robot off it (a helper's review).
        """
        if distance <= self.settings.goal_tolerance_m:
            self._finish(NavigationState.REACHED, f"goal reached: resting {distance:.3f} m from it (tolerance "
                         f"{self.settings.goal_tolerance_m:g} m), where the robot already lay")
        elif self._on_the_line(pose, distance):
            self.fine.start(pose.time_s)
            self._message = f"at rest {distance:.3f} m from the goal, on its line: creeping to it"
        elif self._move_along_axis(pose, distance):
            pass
        elif self._pivot_toward(pose, distance):
            self._message = (f"at rest {distance:.3f} m from the goal, off its line: turning on the spot "
                             f"({'counter-' if self.fine.pivot_sense > 0 else ''}clockwise) to put it on the line")
        else:
            return False
        return True

    def _move_along_axis(self, pose: Pose2D, distance: float) -> bool:
        """Near the goal but off its line: move the body along its own axis onto the line; False when it cannot.

        The straight serpentine (:mod:`srs_ros.core.navigation.shuffle`); not where the floor was seen not to let
        it move the body, nor farther than the move's reach. Counted with the turns on the spot (at most
        FINE_MAX_PIVOTS moves from rest per goal).
        """
        settings, fine = self.settings, self.fine
        if settings.fine_distance_m <= 0.0 or distance >= settings.fine_distance_m or \
                fine.pivots >= FINE_MAX_PIVOTS:
            return False
        _, _, across, line_yaw = self._resting_line(pose)
        body_yaw = self.history.smoothed_yaw_rad(FINE_YAW_WINDOW_S)
        # The goal lies ``across`` to the left of inward rolling, i.e. toward line_yaw + pi: moving the body by m
        # along its yaw moves the goal across the line by m cos(skew).
        plan = self.shuffle.plan(-across / max(math.cos(line_yaw - body_yaw), 0.5), settings.axis_move_max_cycles)
        if plan is None:
            return False
        direction, cycles = plan
        self.shuffle.start(pose, body_yaw, direction, cycles)
        fine.start_pivot(pose.time_s, 1 if direction == AXIS_DIRECTIONS[0] else -1, [(direction, None)] * cycles)
        forward = (direction == AXIS_DIRECTIONS[0]) != self.sides.swapped  # toward the head the camera sees
        self._message = (f"at rest {distance:.3f} m from the goal, {100 * abs(across):.1f} cm off its line: moving "
                         f"{cycles} cycle(s) {'forward' if forward else 'backward'} along the body's axis onto it"
                         + (" (the body's ends swapped)" if self.sides.swapped else ""))
        return True

    def _pivot_toward(self, pose: Pose2D, distance: float) -> bool:
        """Near the goal but off its line: start a turn on the spot; False when it cannot or should not.

        The turn on the spot is an inward and an outward stroke turning the same way; it is started when the line
        needs at most FINE_PIVOT_MAX_RAD of turn, at most FINE_MAX_PIVOTS times per goal. The stroke played last
        is the direction that rolls on less after a stop (:meth:`StopModel.steadiest_direction`: at 4 bar 1 Hz
        outward rolling rests within about 5 cm of where it stopped, inward rolling 14-27 cm ahead), so the turn
        leaves the robot where it was. Each turn on the spot is measured from rest to rest: strokes seen to turn
        the body the other way (a start from rest can kick it round more than the cycles turn it) are not played
        for that sense again; the other order of the strokes, or the other sense's levels, are tried instead
        (:meth:`FineApproach.pivot_choice`).
        """
        settings, fine = self.settings, self.fine
        if settings.fine_distance_m <= 0.0 or distance >= settings.fine_distance_m or \
                fine.pivots >= FINE_MAX_PIVOTS:
            return False
        _, along, across, _ = self._resting_line(pose)
        turn_rad = math.atan2(across, along) if along >= 0.0 else math.atan2(-across, -along)
        if abs(turn_rad) > FINE_PIVOT_MAX_RAD and distance > FINE_PIVOT_ANY_WITHIN * settings.goal_tolerance_m:
            return False
        steadiest = self.stops.steadiest_direction()  # the stroke before the stop: the shorter roll-on
        sign = 1 if turn_rad > 0.0 else -1
        keys = [(first, nominal) for nominal in (sign, -sign) for first in (other_direction(steadiest), steadiest)
                if any(self.turns.fastest_deg(d, nominal)[1] * nominal > 1.0 for d in DIRECTIONS)]
        key = fine.pivot_choice(sign, keys)  # the strokes seen (else not yet seen) to turn the resting body that way
        if key is None:
            return False
        first, nominal = key
        levels = {d: self.turns.fastest_deg(d, nominal)[0] for d in DIRECTIONS}
        second = other_direction(first)
        fine.start_pivot(pose.time_s, sign, [(first, levels[first]), (second, levels[second])], nominal,
                         self.history.smoothed_yaw_rad(FINE_YAW_WINDOW_S))
        return True

    def _resting_line(self, pose: Pose2D) -> tuple[str, float, float, float]:
        """The direction that faces the goal from rest, the goal along and across its creeping line (m), its yaw.

        Each direction creeps square to the body turned by its learned skew; the goal lies ahead of inward rolling
        (along >= 0) or behind, where outward rolling goes; on the body's axis, the nearer line is taken.
        """
        body_yaw = self.history.smoothed_yaw_rad(FINE_YAW_WINDOW_S)
        yaws = {d: self.fine.line_yaw_at_rest(body_yaw, d) for d in DIRECTIONS}
        lines = {d: (*FineApproach.line(pose, self.goal, yaws[d]), yaws[d]) for d in DIRECTIONS}
        ahead, behind = lines[DIRECTIONS[0]][0] >= 0.0, lines[DIRECTIONS[1]][0] < 0.0
        if ahead == behind:  # the two lines disagree: the goal lies near the body's axis
            direction = min(DIRECTIONS, key=lambda d: abs(lines[d][1]))
        else:
            direction = DIRECTIONS[0] if ahead else DIRECTIONS[1]
        return (direction, *lines[direction])

    def _pivot(self, pose: Pose2D) -> None:
        """Play the turn on the spot (or the move along the axis): a cycle a stroke, then stop, rest, look again."""
        stroke = self.fine.pivot_stroke(pose.time_s, 1.0 / self.settings.cruise_frequency_hz)
        if stroke is None:
            self.fine.pivot_sense = 0
            self.state = NavigationState.STOPPING
            self._stop = StopPlan(pose, self._command.direction or DIRECTIONS[0], None, -1, False,
                                  (pose.x_m, pose.y_m), stopped=pose)
            self._command = self._stop_command("moved along the body's axis; waiting for the robot to rest"
                                               if self._command.along_axis else
                                               "turned on the spot; waiting for the robot to rest")
            self._level = None
            return
        direction, level = stroke  # level None: a move along the body's axis (no turn level, nothing learned)
        turn = 0.0 if level is None else float(self.settings.turn_levels_rad[level])
        reason = "turning on the spot toward the goal's line" if level is not None else \
            "moving along the body's axis onto the goal's line"
        self._set_command(pose.time_s, GaitCommand(direction, turn, self.settings.amplitude_bar,
                                                   self.settings.cruise_frequency_hz, reason), level)

    def _on_the_line(self, pose: Pose2D, distance: float) -> bool:
        """True when the resting robot can creep to the goal: near it, the goal on the line square to its body."""
        settings = self.settings
        if settings.fine_distance_m <= 0.0 or distance >= settings.fine_distance_m:
            return False
        return abs(self._resting_line(pose)[2]) <= FINE_LINE_WITHIN * settings.goal_tolerance_m
