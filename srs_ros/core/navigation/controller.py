"""The navigator's controller: camera poses in, a rolling direction, its turn level and its frequency out.

The robot rolls roughly across its body axis, inward rolling to one side and outward rolling to the other.
On every pose the controller compares the goal's bearing with both travel directions (the smoothed body yaw
plus the learned offset of each), takes the nearer one (with hysteresis: a goal behind is reached by rolling
the other way, never by turning round) and asks for the turn rate of the arc through the goal (pure
pursuit); the turn level (the gait's ``turn_phase_rad``) whose learned rate is nearest is played. Every
whole cycle played at one level is measured by the camera and corrects that level's turn rate, travel and
travel direction (:mod:`srs_ros.core.navigation.motion`), so the controller needs no exact turn-rate model.
A goal so close to the side that even the tightest turn cannot reach it is first backed away from: the robot
rolls the other way while its body turns toward the goal (a three-point turn). The controller stops where it
predicts the robot comes to rest (the learned stop offset: the body rolls on and straightens), waits for the
robot to rest, and checks: within the tolerance the goal is reached, otherwise it drives on. Near the edge of
the camera's view and moving out, it rolls back in. No pose for ``pose_timeout_s`` stops it; so do a cancel
and a stall.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import replace

import numpy as np

from srs_ros.core.errors import InvalidInputError
from srs_ros.core.navigation.approach import FINE_STOP_NEAR, FineDriving
from srs_ros.core.navigation.area import FloorArea
from srs_ros.core.navigation.commands import GaitCommand, GoalDecision, NavigationProgress, NavigationState
from srs_ros.core.navigation.cruise_stop import CruiseStopping
from srs_ros.core.navigation.edge import EdgeGuard
from srs_ros.core.navigation.fine import FineApproach
from srs_ros.core.navigation.motion import (
    SETTLE_CYCLES,
    Pose2D,
    PoseHistory,
    TravelModel,
    TravelSides,
    TurnModel,
    arc_miss_m,
    measure_cycle,
    wrap_rad,
)
from srs_ros.core.navigation.settings import DIRECTIONS, NavigationSettings, other_direction
from srs_ros.core.navigation.shuffle import AxisShuffle
from srs_ros.core.navigation.stopping import StopModel, StopPlan

#: The same after a start from rest (the soft start and the body's first roll are not the steady gait).
START_SETTLE_CYCLES = 1.5
#: A straight line passing this close to the goal (times the tolerance) needs no three-point turn.
STRAIGHT_WITHIN = 0.7
#: A robot that turns less than this (deg per cycle, the fastest level of either direction in the sense needed)
#: has every goal inside its tightest turn, and backing away does not turn it toward one: on the calibrated physics
#: (at most 7 deg per cycle; the default and anisotropic ones 14-21) it backed away from goals 4-10 deg off its line
#: for the whole minute (docs/studies/navigation.md, "Backing away without a turn"). Such a robot drives on to a goal
#: that its tightest arc toward it passes within BACK_UNLESS_MISS_WITHIN x FINE_STOP_NEAR x fine_distance_m (the fine
#: approach on): the cruise stops near it and the fine approach finishes from rest. Any robot drives on to a goal
#: its straight line passes that close (since stop 45: over DDS a direction that could not turn toward a goal 5-15
#: deg off backed away from it and drove at it by turns for a minute; docs/studies/navigation.md, "A goal nearly
#: ahead").
WEAK_TURN_DEG_PER_CYCLE = 8.0
BACK_UNLESS_MISS_WITHIN = 0.5
#: Three-point turns in a row that each begin with the goal no nearer the bearing (deg) than the one before did,
#: after which the goal is driven at with the tightest turn toward it. A weak turner gains 2-3 deg per turn and
#: reaches side goals by a dozen; over DDS on the anisotropic floor a robot whose map got its turns wrong lost 7-11
#: deg per turn, backed away and drove at the goal by turns for a minute and ended 1 m farther away: a level changed
#: every second or two is never measured (docs/studies/navigation.md, "Three-point turns that turn nothing").
FUTILE_BACK_AWAYS = 2
BACK_AWAY_GAIN_DEG = 1.0
#: The most waypoints a path may have: each is a goal of seconds to a minute; 20000 blocked the navigator for 1.5 s.
MAX_WAYPOINTS = 1000
#: A lost pose's cause when no pose was ignored near the loss.
UNSEEN_CAUSE = "the robot may be out of the camera's view or the tracker silent"


class NavigationController(CruiseStopping, FineDriving, EdgeGuard):
    """Goals and camera poses in, :class:`GaitCommand` out; see the module docstring and docs/navigation.md."""

    def __init__(self, settings: NavigationSettings, area: FloorArea | None = None):
        """``area`` None accepts every finite goal (no camera calibration to check against)."""
        self.settings = settings
        self.area = area
        self.history = PoseHistory()
        self.turns = TurnModel(settings.turning_map, settings.turn_levels_rad, settings.learning_rate)
        self.travel = TravelModel(settings.turn_levels_rad, settings.learning_rate, settings.turning_map)
        self.sides = TravelSides()
        self.stops = self._first_stop_model()
        self.fine = FineApproach(settings.learning_rate)
        self.shuffle = AxisShuffle(settings.learning_rate)
        self.state = NavigationState.IDLE
        self._goals: list[tuple[float, float]] = []
        self._waypoint_count = 0  # the distinct waypoints of the path (fewer than the goals when followed in rounds)
        self._index = 0
        self._message = "no goal yet"
        self._command = self._stop_command("no goal yet")
        self._level: int | None = None
        self._changed_s = self._measured_s = self._started_s = self._last_pose_s = 0.0
        self._pose_ignored = ("", -math.inf)  # why the last pose was ignored (the node says), and when (s)
        self._heading_error_rad = 0.0
        self._backing_from: str | None = None
        # The goal off the line as the last three-point turn began (rad), and how many in a row began no nearer.
        self._futile = (math.inf, 0)
        self._settle_cycles = START_SETTLE_CYCLES
        self._stop: StopPlan | None = None
        self._phase: float | None = None
        self._phase_seen: float | None = None
        self._direction_since_s = self._sides_measured_s = 0.0
        self._clock_s = self._ended_s = 0.0  # the latest time seen (a pose's, a tick's); when the last goal ended
        self._fresh_goal = False
        self._best = (math.inf, 0.0)
        self._edge_until_s = -math.inf
        self._last_rest: tuple[np.ndarray, float, str] | None = None  # the last stop phase's prediction (xy, s, dir)

    # ------------------------------------------------------------------ goals
    @property
    def command(self) -> GaitCommand:
        """The latest command."""
        return self._command

    @property
    def stop_plan(self) -> StopPlan | None:
        """The last stop near a goal: where and how it was decided, where the robot was predicted to rest."""
        return self._stop

    @property
    def goals(self) -> tuple[tuple[float, float], ...]:
        """The goals of the current path (a single goal is a path of one)."""
        return tuple(self._goals)

    @property
    def goals_ahead(self) -> tuple[tuple[float, float], ...]:
        """The goals still to drive to, the current one first (a patrol: its next round's worth); none at rest."""
        if not self.state.active:
            return ()
        return tuple(self._goals[self._index:self._index + max(self._waypoint_count, 1)])

    @property
    def goal(self) -> tuple[float, float] | None:
        """The goal now driven to, None when there is none."""
        return self._goals[self._index] if self._goals else None

    def set_goal(self, x_m: float, y_m: float, now_s: float) -> GoalDecision:
        """Replace the current goal (and path) with one goal; refused (the current one kept) outside the area."""
        return self.set_path([(x_m, y_m)], now_s)

    def set_path(self, waypoints: Iterable[Sequence[float]], now_s: float, rounds: int = 1) -> GoalDecision:
        """Replace the current goal with waypoints followed in order; refused whole if one is outside the area.

        ``rounds`` > 1 follows them that many times over (a patrol); the progress names the waypoint and the round.
        """
        try:
            points = [(float(x), float(y)) for x, y in waypoints]
        except (TypeError, ValueError):
            return self.refuse("a path is a list of waypoints, each (x_m, y_m)")
        if not 1 <= len(points) <= MAX_WAYPOINTS:
            return self.refuse(f"a path of {len(points)} waypoints; expected 1 to {MAX_WAYPOINTS}" + (
                " (split a longer route into paths sent one after the other)" if points else ""))
        for i, (x, y) in enumerate(points):
            reason = self.area.refusal(x, y) if self.area is not None else (
                "" if math.isfinite(x) and math.isfinite(y) else f"goal ({x}, {y}) is not a finite floor position (m)")
            if reason:
                return self.refuse(reason if len(points) == 1 else f"waypoint {i + 1} of {len(points)}: {reason}")
        goals = points * max(1, int(rounds))
        if self.state.active and goals == self._goals and self._waypoint_count == len(points):
            # The same goal again (`ros2 topic pub` re-sends it every second): nothing restarts, the pose and
            # progress timeouts least of all: re-sending kept a robot whose tracker had died driving blind.
            return GoalDecision(True, self._message, unchanged=True)
        resume = not self.state.active
        self._goals, self._index, self._backing_from, self._fresh_goal = goals, 0, None, True
        self._waypoint_count = len(points)
        self._new_three_point_row()
        self._edge_until_s = -math.inf
        self.fine.reset()
        self.shuffle.forget_move()
        self.state, self._started_s = NavigationState.DRIVING, float(now_s)
        self._best = (math.inf, float(now_s))
        if resume:  # a goal from rest gets pose_timeout_s for its first pose; a replaced goal does not extend it
            self._last_pose_s = max(self._last_pose_s, float(now_s))
        self._message = self._driving_message()
        return GoalDecision(True, self._message)

    def waypoint(self) -> tuple[int, int, int]:
        """Where on the path the robot is: (waypoint index from 0, distinct waypoints, round from 1)."""
        count = max(self._waypoint_count, 1)
        return self._index % count, self._waypoint_count, self._index // count + 1

    def _which_goal(self) -> str:
        """'goal 2 of 3', or on a path followed in rounds 'waypoint 2 of 3 (round 4)'."""
        if len(self._goals) <= self._waypoint_count:
            return f"goal {self._index + 1} of {len(self._goals)}"
        index, count, round_ = self.waypoint()
        return f"waypoint {index + 1} of {count} (round {round_})"

    def _driving_message(self) -> str:
        return "driving to {} at ({:.3f}, {:.3f}) m".format(self._which_goal(), *self.goal)

    def refuse(self, reason: str) -> GoalDecision:
        """A goal refused (here, or before it reached the controller: its frame, say); the goal driven to kept."""
        still = self._message.partition("; still ")[2] if self._message.startswith("goal refused: ") else self._message
        self._message = f"goal refused: {reason}" + (f"; still {still}" if self.state.active and still else "")
        return GoalDecision(False, reason)

    def cancel(self, now_s: float, reason: str = "cancelled") -> GaitCommand:
        """Stop; state CANCELLED (a new goal starts again)."""
        if self.state.active:
            self._clock_s = max(self._clock_s, float(now_s))
            self._finish(NavigationState.CANCELLED, reason)
        return self._command

    # ------------------------------------------------------------------ poses and time
    def update_pose(self, pose: Pose2D) -> GaitCommand:
        """Take a camera pose (older than the last one: ignored) and return the command for now."""
        if self.sides.swapped:
            pose = replace(pose, yaw_rad=pose.yaw_rad + self.sides.yaw_offset_rad)
        if not self.history.add(pose):
            return self._command
        self._last_pose_s, self._clock_s = pose.time_s, max(self._clock_s, pose.time_s)
        self._pose_ignored = ("", -math.inf)
        if self.state is NavigationState.DRIVING:
            self._drive(pose)
        elif self.state is NavigationState.STOPPING:
            self._settle(pose)
        return self._command

    def tick(self, now_s: float) -> GaitCommand:
        """Call from a timer: no pose for more than ``pose_timeout_s`` while active stops the robot."""
        silent_s, self._clock_s = float(now_s) - self._last_pose_s, max(self._clock_s, float(now_s))
        if self.state.active and silent_s > self.settings.pose_timeout_s:
            last = self.history.window(0.0)
            where = f" (last seen at {last[-1, 1]:.3f}, {last[-1, 2]:.3f} m)" if len(last) else ""
            self.history.clear()
            ignored, ignored_s = self._pose_ignored  # named if one came within the timeout
            cause = (f"poses came but were ignored: {ignored.rstrip('.')}" if now_s - ignored_s <= self.settings.
                     pose_timeout_s else UNSEEN_CAUSE)
            self._finish(NavigationState.POSE_LOST, f"no pose from the camera for {silent_s:.1f} s{where}: stopped; "
                         f"{cause}; send a new goal once it is tracked again")
        return self._command

    def pose_ignored(self, reason: str, now_s: float) -> None:
        """A pose came at ``now_s`` and was not usable (its frame, a NaN): a loss just after or before names it."""
        self._pose_ignored = (reason, float(now_s))
        if self.state is NavigationState.POSE_LOST and UNSEEN_CAUSE in self._message:  # queued behind a stall
            self._message = self._message.replace(UNSEEN_CAUSE, f"poses came but were ignored: {reason.rstrip('.')}")

    def update_gait_phase(self, phase: float) -> None:
        """The gait player's phase in [0, 1) now (feed it with every pose: the robot is stopped at set phases)."""
        phase = float(phase)
        if not math.isfinite(phase):
            raise InvalidInputError(f"phase: {phase!r}; expected a finite gait phase in [0, 1).")
        self._phase = phase % 1.0

    # ------------------------------------------------------------------ driving
    def _drive(self, pose: Pose2D) -> None:
        distance = self._distance(pose)
        if self._stalled(pose.time_s, distance):
            return
        while distance <= self.settings.waypoint_tolerance_m and self._index < len(self._goals) - 1:
            self._index += 1
            self._best = (math.inf, pose.time_s)
            self._new_three_point_row()
            self._message = f"waypoint reached; driving to {self._which_goal()}"
            distance = self._distance(pose)
        self._learn(pose.time_s)
        passed = self._passed_stop_phase(self._command.reverse)
        if self._index == len(self._goals) - 1 and self._creep(pose, distance, passed):
            return
        errors, distances = self._aims(pose)
        crossed = self._crossed_stop_phase(pose.time_s, passed)
        if self._backing_from is None and self._index == len(self._goals) - 1 and crossed is not None \
                and self._stop_here(pose, crossed):
            self._begin_stop(pose, crossed)
            return
        if self._keep_in_view(pose):  # near the view's edge and moving out: rolling back in
            return
        direction, wanted_deg = self._steer(pose.time_s, errors, distances)
        frequency = (self.settings.approach_frequency_hz if distance < self.settings.approach_distance_m
                     else self.settings.cruise_frequency_hz)
        level = self._choose_level(pose.time_s, direction, wanted_deg)
        self._set_command(pose.time_s, GaitCommand(direction, float(self.settings.turn_levels_rad[level]),
                                                   self.settings.amplitude_bar, frequency, self._message), level)

    def _distance(self, pose: Pose2D) -> float:
        gx, gy = self.goal
        return math.hypot(gx - pose.x_m, gy - pose.y_m)

    def _stalled(self, now_s: float, distance: float) -> bool:
        best, since = self._best
        if distance < best - self.settings.stall_distance_m or not math.isfinite(best):
            self._best = (distance, now_s)
            return False
        if now_s - since > self.settings.stall_timeout_s:
            self._finish(NavigationState.FAILED, f"no progress: {distance:.3f} m to go and not "
                         f"{self.settings.stall_distance_m:g} m closer for {now_s - since:.0f} s; stopped")
            return True
        return False

    def _travel_heading_rad(self, direction: str) -> float:
        """Where the robot travels in ``direction``: the smoothed yaw plus the mean learned offset over the levels."""
        period = 1.0 / max(self._command.frequency_hz, self.settings.cruise_frequency_hz)
        # not the level played's offset: a change of level moved the error it was chosen from (docs/navigation.md)
        return self.history.smoothed_yaw_rad(period) + self.travel.offset(direction, None)

    def _aims(self, pose: Pose2D) -> tuple[dict[str, float], dict[str, float]]:
        """Per direction: heading error (rad) and distance (m) to its aim point.

        The aim point is the goal; for the last goal, the goal less where the robot rolls on after a stop
        (the pose must pass there for the robot to rest on the goal), the mean over the turn levels (aiming with
        the offset of the level played was measured worse: it moves the aim as the level changes).
        """
        errors, distances = {}, {}
        final = self._index == len(self._goals) - 1
        for direction in DIRECTIONS:
            heading = self._travel_heading_rad(direction)
            aim = np.asarray(self.goal) - (self.stops.mean_rest_offset(direction, heading) if final else 0.0)
            dx, dy = aim[0] - pose.x_m, aim[1] - pose.y_m
            errors[direction] = wrap_rad(math.atan2(dy, dx) - heading)
            distances[direction] = math.hypot(dx, dy)
        return errors, distances

    def _hold_s(self, cycles: float) -> float:
        return cycles / max(self._command.frequency_hz, 1e-3)

    def _steer(self, now_s: float, errors: dict[str, float], distances: dict[str, float]) -> tuple[str, float]:
        """The direction to roll and the turn rate to ask (deg per cycle, counter-clockwise positive)."""
        settings, limit = self.settings, self.settings.max_turn_rate_deg_per_cycle
        if self._backing_from is not None:
            toward = self._backing_from
            error, distance_m = errors[toward], distances[toward]
            self._heading_error_rad = error
            held = now_s - self._changed_s >= self._hold_s(settings.min_hold_cycles)
            if (not held or self._out_of_reach(toward, error, distance_m, 1.2)) and \
                    not self._heads_out_of_view(other_direction(toward)):
                return other_direction(toward), math.copysign(limit, error)
            self._backing_from = None
            self._message = self._driving_message()  # the status no longer says it is backing away
        direction = self._choose_direction(now_s, errors, settings.min_hold_cycles)
        error, distance_m = errors[direction], distances[direction]
        self._heading_error_rad = error
        # near the edge (never backed out of view) or after futile turns: driven on instead
        if self._out_of_reach(direction, error, distance_m, 1.0) and not self._heads_out_of_view(
                other_direction(direction)) and self._may_begin_three_point_turn(error):
            self._backing_from = direction
            self._message = "the goal is too close to the side to turn to: backing away while turning"
            return other_direction(direction), math.copysign(limit, error)
        if abs(error) >= 0.5 * math.pi:  # the aim behind (a direction held): pursuit's sin(error) would turn slower
            return direction, math.copysign(limit, error)
        level = self._level if direction == self._command.direction and self._level is not None else None
        travel = self.travel.travel_m[direction][len(self.travel.levels_rad) // 2 if level is None else level]
        arc_deg = math.degrees(2.0 * math.sin(error) * float(travel) / max(distance_m, 1e-3))
        return direction, max(-limit, min(limit, settings.pursuit_gain * arc_deg))

    def _new_three_point_row(self) -> None:
        """Three-point turns judged afresh: a new goal or waypoint, or the robot at rest (a stop breaks the row)."""
        self._futile = (math.inf, 0)

    def _may_begin_three_point_turn(self, error: float) -> bool:
        """Count a three-point turn about to begin; refuse it, saying why, after futile ones.

        Called only as a turn would begin. Refused once :data:`FUTILE_BACK_AWAYS` turns in a row each began with the
        goal no nearer the bearing than the one before.
        """
        last_rad, futile = self._futile
        if futile >= FUTILE_BACK_AWAYS:
            return False
        futile = futile + 1 if abs(error) > last_rad - math.radians(BACK_AWAY_GAIN_DEG) else 0
        self._futile = (abs(error), futile)
        if futile < FUTILE_BACK_AWAYS:
            return True
        self._message = (f"{futile} three-point turns in a row left the goal {math.degrees(abs(error)):.0f} deg off "
                         "the line, no nearer: driving at it with the tightest turn")
        return False

    def _choose_direction(self, now_s: float, errors: dict[str, float], hold_cycles: float) -> str:
        """The direction nearer the goal's bearing; the current one kept unless the other is clearly nearer."""
        best = min(DIRECTIONS, key=lambda d: abs(errors[d]))
        current, fresh, self._fresh_goal = self._command.direction, self._fresh_goal, False
        if current in errors and best != current and not fresh:
            held = now_s - self._changed_s >= self._hold_s(hold_cycles)
            if not held or abs(errors[best]) + self.settings.direction_hysteresis_rad > abs(errors[current]):
                return current
        return best

    def _out_of_reach(self, direction: str, error: float, distance_m: float, margin: float) -> bool:
        """True when the goal lies inside the tightest turn toward it and a straight line would miss it.

        ``margin`` (over 1: the test that ends a backing leg) widens the turn and narrows every way of counting
        the goal in reach (the line's and the tightest arc's miss), so a goal near a threshold does not switch
        the robot between backing and driving (docs/studies/navigation.md, "A backing leg ended by the test that
        began it").
        """
        settings, miss_m = self.settings, distance_m * abs(math.sin(error))
        if abs(error) >= 0.5 * math.pi or miss_m * margin <= STRAIGHT_WITHIN * settings.goal_tolerance_m:
            return False
        sign, reach_m = (1 if error >= 0.0 else -1), BACK_UNLESS_MISS_WITHIN * FINE_STOP_NEAR * settings.fine_distance_m
        if miss_m * margin <= reach_m:  # driven on: the cruise stops near it and the fine approach finishes from rest
            return False
        weak = max(self.turns.fastest_deg(d, sign)[1] * sign for d in DIRECTIONS) < WEAK_TURN_DEG_PER_CYCLE
        index, rate_deg = self.turns.fastest_deg(direction, sign)
        if rate_deg * sign <= 1.0:
            return True
        radius_m = float(self.travel.travel_m[direction][index]) / math.radians(abs(rate_deg))
        if weak and arc_miss_m(radius_m, distance_m, error) * margin <= reach_m:
            return False
        return distance_m < margin * settings.reach_margin * 2.0 * radius_m * abs(math.sin(error))

    def _choose_level(self, now_s: float, direction: str, wanted_deg: float) -> int:
        same = self._command.direction == direction and self._level is not None
        if same and now_s - self._changed_s < self._hold_s(self.settings.min_hold_cycles):
            return self._level
        return self.turns.choose(direction, wanted_deg, self._level if same else None)

    def _set_command(self, now_s: float, command: GaitCommand, level: int | None) -> None:
        old = self._command
        if command.direction != old.direction:
            self._direction_since_s = now_s
        if (command.direction, command.turn_phase_rad, command.amplitude_bar) != \
                (old.direction, old.turn_phase_rad, old.amplitude_bar):
            self._changed_s = self._measured_s = now_s
            self._settle_cycles = START_SETTLE_CYCLES if command.direction != old.direction else SETTLE_CYCLES
        elif command.frequency_hz != old.frequency_hz:
            self._measured_s = now_s
        self._level = level
        self._command = replace(command, ends_swapped=self.sides.swapped) if command.along_axis else command

    def _learn_sides(self, now_s: float) -> None:
        """Every whole cycle in one rolling direction (past the start's settling, whatever the level): which side."""
        command = self._command
        if not command.moving or command.along_axis:
            return
        period = 1.0 / command.frequency_hz
        if now_s - self._direction_since_s < (1.0 + START_SETTLE_CYCLES) * period or \
                now_s - self._sides_measured_s < period:
            return
        cycle = measure_cycle(self.history, period)
        self._sides_measured_s = now_s
        if cycle is not None and self.sides.observe(command.direction, cycle):
            self._swap_ends()

    def _learn(self, now_s: float) -> None:
        """After a whole cycle at one level (past the settling), measure it and correct the models."""
        self._learn_sides(now_s)
        command = self._command
        if not command.moving or self._level is None:
            return
        period = 1.0 / command.frequency_hz
        ready = now_s - self._changed_s >= (1.0 + self._settle_cycles) * period and now_s - self._measured_s >= period
        if not ready:
            return
        cycle = measure_cycle(self.history, period)
        self._measured_s = now_s
        if cycle is None or abs(command.frequency_hz - self.settings.cruise_frequency_hz) > 1e-9 or \
                command.amplitude_bar != self.settings.amplitude_bar:
            return                       # the map and the estimates are per cycle at the cruise frequency
        self.turns.learn(command.direction, self._level, cycle.turn_deg)
        self.travel.learn(command.direction, self._level, cycle)

    def _first_stop_model(self) -> StopModel:
        """Where the robot rests after a stop, as the turn map first guesses it."""
        return StopModel(self.settings.turning_map, self.settings.learning_rate, self.settings.turn_levels_rad)

    def _swap_ends(self) -> None:
        """The sides just swapped (:class:`TravelSides`): turn the kept poses, forget what was learned in the old frame.

        Rests after a stop are learned relative to the travel heading, which was pi off; so was the three-point turns'
        bearing. Turn rates and travel directions are kept: the first are the world's, the second were never
        learned from cycles on the other side.
        """
        self.history.turn_yaws(math.pi)
        self.stops = self._first_stop_model()
        self.fine.forget_rests()
        self._new_three_point_row()
        ends = ("the other side than the model's: driving with the body's ends swapped" if self.sides.swapped else
                "as the model's robot: driving with the body's ends as the camera sees them")
        self._message = (f"inward rolling travels to the {self.sides.inward_side} of the camera's tail -> head "
                         f"heading, {ends}; {self._driving_message()}")

    def _finish(self, state: NavigationState, message: str) -> None:
        self.state, self._message, self._ended_s = state, message, self._clock_s
        self.fine.leave()
        self.shuffle.forget_move()
        self._command = self._stop_command(message)
        self._level = None
        self._backing_from = None

    def _stop_command(self, reason: str) -> GaitCommand:
        return GaitCommand(None, 0.0, self.settings.amplitude_bar, self.settings.cruise_frequency_hz, reason)

    # ------------------------------------------------------------------ progress
    def progress(self, now_s: float) -> NavigationProgress:
        """The progress now (distance from the last pose)."""
        last = self.history.window(0.0)
        goal = self.goal
        distance = math.nan
        if goal is not None and len(last):
            distance = math.hypot(goal[0] - last[-1, 1], goal[1] - last[-1, 2])
        return NavigationProgress(self.state, goal, self._index, len(self._goals), distance,
                                  self._heading_error_rad if self.state.active else 0.0,
                                  self._command.direction or "", self._command.turn_phase_rad,
                                  ((float(now_s) if self.state.active else self._ended_s) - self._started_s
                                   if self._goals else math.nan), self._message,
                                  self.sides.inward_side,
                                  self.fine.amplitude_bar(self.settings),
                                  {d: [round(float(r), 2) for r in self.turns.rates[d]] for d in DIRECTIONS})
