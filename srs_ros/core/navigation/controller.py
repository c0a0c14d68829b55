"""The navigator's controller: camera poses in, a rolling gait, its turn level and its frequency out.

The robot rolls roughly across its body axis, inward rolling to one side and outward rolling to the other.
On every pose the controller compares the goal's bearing with both travel directions (body yaw + the
learned offset of each), takes the nearer one (with hysteresis: a goal behind is reached by rolling the
other way, never by turning round), and asks for a turn rate proportional to the heading error; the turn
level (the gait's ``turn_phase_rad``) whose learned rate is nearest is played. Every whole cycle played at
one level is measured by the camera and corrects that level's rate (:mod:`srs_ros.core.navigation.motion`),
so the controller needs no exact turn-rate model. Near the goal it slows down; it stops where it predicts
the robot will come to rest within the tolerance, waits for the robot to rest, and checks: within the
tolerance the goal is reached, otherwise it drives on. No pose for ``pose_timeout_s`` stops it.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from srs_ros.core.navigation.area import FloorArea
from srs_ros.core.navigation.motion import Pose2D, PoseHistory, TravelModel, TurnModel, measure_cycle, wrap_rad
from srs_ros.core.navigation.settings import DIRECTIONS, NavigationSettings

#: The gait whose cycle the navigator plays (forward: inward rolling, backward: outward rolling).
GAIT = "inward_rolling"
#: Cycles after a gait change before the camera's cycle measurements count (the cross-fade and the body settle).
SETTLE_CYCLES = 0.5
#: The same after a start from rest (the soft start and the body's first roll are not the steady gait).
START_SETTLE_CYCLES = 1.5


class NavigationState(enum.Enum):
    """Where the navigator is. REACHED, CANCELLED, POSE_LOST and FAILED are stopped until a new goal."""

    IDLE = "idle"
    DRIVING = "driving"
    STOPPING = "stopping"
    REACHED = "reached"
    CANCELLED = "cancelled"
    POSE_LOST = "pose_lost"
    FAILED = "failed"

    @property
    def active(self) -> bool:
        """True while the navigator is working toward a goal."""
        return self in (NavigationState.DRIVING, NavigationState.STOPPING)


@dataclass(frozen=True)
class GaitCommand:
    """What the gait should do now. ``direction`` None: stop (ramp out, all pressures to 0 bar).

    ``direction`` is ``inward_rolling`` or ``outward_rolling``. Both are played as the one cycle of :data:`GAIT`
    (its ``turn_phase_rad`` set), outward rolling by playing it backward in time (:attr:`reverse`): outward
    rolling is inward rolling reversed in time, and a reversal then ramps the signed frequency through 0
    instead of cross-fading two different shapes (which makes the body flop over).
    """

    direction: str | None
    turn_phase_rad: float
    amplitude_bar: float
    frequency_hz: float
    reason: str = ""

    @property
    def moving(self) -> bool:
        """True when a gait is to be played."""
        return self.direction is not None

    @property
    def gait(self) -> str:
        """The gait whose cycle is played (the trajectory_server's ``gait``)."""
        return GAIT

    @property
    def reverse(self) -> bool:
        """True when the cycle is played backward (outward rolling)."""
        return self.direction == "outward_rolling"

    @property
    def cycle_key(self) -> tuple[str, float, float]:
        """What needs a new cycle when it changes: ``(gait, amplitude_bar, turn_phase_rad)``."""
        return (GAIT, self.amplitude_bar, self.turn_phase_rad)


@dataclass(frozen=True)
class GoalDecision:
    """The answer to a goal: accepted, or refused with the reason."""

    accepted: bool
    reason: str


@dataclass(frozen=True)
class NavigationProgress:
    """The navigator's progress, for a topic and ``/diagnostics``."""

    state: NavigationState
    goal_xy_m: tuple[float, float] | None
    goal_index: int
    goal_count: int
    distance_to_go_m: float
    heading_error_rad: float
    direction: str
    turn_phase_rad: float
    elapsed_s: float
    message: str

    @property
    def level(self) -> str:
        """``OK``, ``WARN`` (failed, cancelled) or ``ERROR`` (pose lost) for ``/diagnostics``."""
        if self.state is NavigationState.POSE_LOST:
            return "ERROR"
        return "WARN" if self.state in (NavigationState.FAILED, NavigationState.CANCELLED) else "OK"

    def values(self) -> dict[str, str]:
        """Key/values of a ``/diagnostics`` status (all text)."""
        goal = "none" if self.goal_xy_m is None else f"{self.goal_xy_m[0]:.3f}, {self.goal_xy_m[1]:.3f}"
        return {"state": self.state.value, "goal_m": goal, "goal": f"{self.goal_index + 1} of {self.goal_count}",
                "distance_to_go_m": f"{self.distance_to_go_m:.3f}",
                "heading_error_deg": f"{math.degrees(self.heading_error_rad):.1f}", "direction": self.direction,
                "turn_phase_rad": f"{self.turn_phase_rad:.3f}", "elapsed_s": f"{self.elapsed_s:.1f}"}


class NavigationController:
    """Goals and camera poses in, :class:`GaitCommand` out; see the module docstring and docs/navigation.md."""

    def __init__(self, settings: NavigationSettings, area: FloorArea | None = None):
        """``area`` None accepts every finite goal (no camera calibration to check against)."""
        self.settings = settings
        self.area = area
        self.history = PoseHistory()
        self.turns = TurnModel(settings.turning_map, settings.turn_levels_rad, settings.learning_rate)
        self.travel = TravelModel(settings.turn_levels_rad, settings.learning_rate)
        self.stop_lead_m = settings.stop_lead_m
        self.state = NavigationState.IDLE
        self._goals: list[tuple[float, float]] = []
        self._index = 0
        self._message = "no goal yet"
        self._command = self._stop_command("no goal yet")
        self._level: int | None = None
        self._changed_s = self._measured_s = self._started_s = self._last_pose_s = 0.0
        self._heading_error_rad = 0.0
        self._pivot_sign = 0
        self._settle_cycles = START_SETTLE_CYCLES
        self._stop_pose: Pose2D | None = None
        self._stop_direction = ""
        self._best = (math.inf, 0.0)

    # ------------------------------------------------------------------ goals
    @property
    def command(self) -> GaitCommand:
        """The latest command."""
        return self._command

    @property
    def goals(self) -> tuple[tuple[float, float], ...]:
        """The goals of the current path (a single goal is a path of one)."""
        return tuple(self._goals)

    def set_goal(self, x_m: float, y_m: float, now_s: float) -> GoalDecision:
        """Replace the current goal (and path) with one goal; refused (the current one kept) outside the area."""
        return self.set_path([(x_m, y_m)], now_s)

    def set_path(self, waypoints: Iterable[Sequence[float]], now_s: float) -> GoalDecision:
        """Replace the current goal with waypoints followed in order; refused whole if one is outside the area."""
        points = [tuple(float(v) for v in point) for point in waypoints]
        if not points or any(len(p) != 2 for p in points):
            return self._refuse("a path needs at least one waypoint, each (x_m, y_m)")
        for i, (x, y) in enumerate(points):
            reason = self.area.refusal(x, y) if self.area is not None else (
                "" if math.isfinite(x) and math.isfinite(y) else f"goal ({x}, {y}) is not a finite floor position")
            if reason:
                return self._refuse(reason if len(points) == 1 else f"waypoint {i + 1} of {len(points)}: {reason}")
        self._goals, self._index, self._pivot_sign = points, 0, 0
        self.state, self._started_s = NavigationState.DRIVING, float(now_s)
        self._best = (math.inf, float(now_s))
        self._last_pose_s = max(self._last_pose_s, float(now_s))
        self._message = f"driving to goal 1 of {len(points)} at ({points[0][0]:.3f}, {points[0][1]:.3f}) m"
        return GoalDecision(True, self._message)

    def _refuse(self, reason: str) -> GoalDecision:
        self._message = f"goal refused: {reason}" + (f"; still {self._message}" if self.state.active else "")
        return GoalDecision(False, reason)

    def cancel(self, now_s: float, reason: str = "cancelled") -> GaitCommand:
        """Stop; state CANCELLED (a new goal starts again)."""
        if self.state.active:
            self._finish(NavigationState.CANCELLED, reason)
        return self._command

    # ------------------------------------------------------------------ poses and time
    def update_pose(self, pose: Pose2D) -> GaitCommand:
        """Take a camera pose (older than the last one: ignored) and return the command for now."""
        if not self.history.add(pose):
            return self._command
        self._last_pose_s = pose.time_s
        if self.state is NavigationState.DRIVING:
            self._drive(pose)
        elif self.state is NavigationState.STOPPING:
            self._settle(pose)
        return self._command

    def tick(self, now_s: float) -> GaitCommand:
        """Call from a timer: no pose for more than ``pose_timeout_s`` while active stops the robot."""
        silent_s = float(now_s) - self._last_pose_s
        if self.state.active and silent_s > self.settings.pose_timeout_s:
            last = self.history.window(0.0)
            where = f" (last seen at {last[-1, 1]:.3f}, {last[-1, 2]:.3f} m)" if len(last) else ""
            self.history.clear()
            self._finish(NavigationState.POSE_LOST,
                         f"no pose from the camera for {silent_s:.1f} s{where}: stopped; the robot may be out of "
                         "the camera's view or the tracker silent; send a new goal once it is tracked again")
        return self._command

    # ------------------------------------------------------------------ driving
    @property
    def goal(self) -> tuple[float, float] | None:
        """The goal now driven to, None when there is none."""
        return self._goals[self._index] if self._goals else None

    def _drive(self, pose: Pose2D) -> None:
        distance = self._distance(pose)
        if self._stalled(pose.time_s, distance):
            return
        while distance <= self.settings.goal_tolerance_m and self._index < len(self._goals) - 1:
            self._index += 1
            self._best = (math.inf, pose.time_s)
            self._message = f"waypoint reached; driving to goal {self._index + 1} of {len(self._goals)}"
            distance = self._distance(pose)
        self._learn(pose.time_s)
        errors = self._errors(pose)
        best = min(DIRECTIONS, key=lambda d: abs(errors[d]))
        if self._index == len(self._goals) - 1 and self._should_stop(pose, best, distance):
            self._begin_stop(pose, best)
            return
        direction, wanted_deg = self._steer(pose.time_s, errors, best)
        frequency = (self.settings.approach_frequency_hz if distance < self.settings.approach_distance_m
                     else self.settings.cruise_frequency_hz)
        level = self._choose_level(pose.time_s, direction, wanted_deg)
        self._set_command(pose.time_s, GaitCommand(direction, float(self.settings.turn_levels_rad[level]),
                                                   self.settings.amplitude_bar, frequency, self._message), level)

    def _steer(self, now_s: float, errors: dict[str, float], best: str) -> tuple[str, float]:
        """The direction to roll and the turn rate to ask (deg per cycle, counter-clockwise positive).

        A goal far off both travel directions (along the body axis) is turned to in place: strokes of the two
        directions alternate, each turning the same way (a pivot), until one direction faces the goal.
        """
        settings, current = self.settings, self._command.direction
        limit = settings.max_turn_rate_deg_per_cycle
        self._heading_error_rad = errors[best]
        if self._pivot_sign and abs(errors[best]) < settings.pivot_exit_rad:
            self._pivot_sign = 0
        elif not self._pivot_sign and abs(errors[best]) > settings.pivot_enter_rad:
            self._pivot_sign = 1 if errors[best] > 0 else -1
        if self._pivot_sign:
            direction = best if current not in DIRECTIONS else current
            if current in DIRECTIONS and now_s - self._changed_s >= self._hold_s(settings.pivot_stroke_cycles):
                direction = DIRECTIONS[1 - DIRECTIONS.index(current)]
            return direction, self._pivot_sign * limit
        direction = best
        if current in errors and best != current:
            held = now_s - self._changed_s >= self._hold_s(settings.min_hold_cycles)
            if not held or abs(errors[best]) + settings.direction_hysteresis_rad > abs(errors[current]):
                direction = current
        self._heading_error_rad = errors[direction]
        return direction, max(-limit, min(limit, settings.heading_gain * math.degrees(errors[direction])))

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
        period = 1.0 / max(self._command.frequency_hz, self.settings.cruise_frequency_hz)
        level = self._level if direction == self._command.direction else None
        return self.history.smoothed_yaw_rad(period) + self.travel.offset(direction, level)

    def _errors(self, pose: Pose2D) -> dict[str, float]:
        gx, gy = self.goal
        bearing = math.atan2(gy - pose.y_m, gx - pose.x_m)
        return {d: wrap_rad(bearing - self._travel_heading_rad(d)) for d in DIRECTIONS}

    def _hold_s(self, cycles: float) -> float:
        return cycles / max(self._command.frequency_hz, 1e-3)

    def _choose_level(self, now_s: float, direction: str, wanted_deg: float) -> int:
        same = self._command.direction == direction and self._level is not None
        if same and now_s - self._changed_s < self._hold_s(self.settings.min_hold_cycles):
            return self._level
        return self.turns.choose(direction, wanted_deg, self._level if same else None)

    def _set_command(self, now_s: float, command: GaitCommand, level: int | None) -> None:
        old = self._command
        if (command.direction, command.turn_phase_rad) != (old.direction, old.turn_phase_rad):
            self._changed_s = self._measured_s = now_s
            self._settle_cycles = START_SETTLE_CYCLES if not old.moving else SETTLE_CYCLES
        elif command.frequency_hz != old.frequency_hz:
            self._measured_s = now_s
        self._level = level
        self._command = command

    def _learn(self, now_s: float) -> None:
        """After a whole cycle at one level (past the settling), measure it and correct the models."""
        command = self._command
        if not command.moving or self._level is None:
            return
        period = 1.0 / command.frequency_hz
        ready = now_s - self._changed_s >= (1.0 + self._settle_cycles) * period and now_s - self._measured_s >= period
        if not ready:
            return
        cycle = measure_cycle(self.history, period)
        self._measured_s = now_s
        if cycle is None:
            return
        scale = command.frequency_hz / self.settings.cruise_frequency_hz
        if abs(scale - 1.0) < 1e-9:   # the map and the levels' estimates are for the cruise frequency
            self.turns.learn(command.direction, self._level, cycle.turn_deg)
        self.travel.learn(command.direction, self._level, cycle)

    # ------------------------------------------------------------------ stopping
    def _should_stop(self, pose: Pose2D, direction: str, distance: float) -> bool:
        """Stop where the robot will rest within the tolerance, or at the closest pass inside it."""
        tolerance = self.settings.goal_tolerance_m
        heading = self._travel_heading_rad(direction)
        gx, gy = self.goal
        rest_x = pose.x_m + self.stop_lead_m * math.cos(heading)
        rest_y = pose.y_m + self.stop_lead_m * math.sin(heading)
        if math.hypot(gx - rest_x, gy - rest_y) <= 0.6 * tolerance:
            return True
        ahead = (gx - pose.x_m) * math.cos(heading) + (gy - pose.y_m) * math.sin(heading)
        return distance <= tolerance and ahead <= self.stop_lead_m

    def _begin_stop(self, pose: Pose2D, direction: str) -> None:
        self.state = NavigationState.STOPPING
        self._stop_pose, self._stop_direction = pose, direction
        self._message = f"stopping at {self._distance(pose):.3f} m from the goal; waiting for the robot to rest"
        self._command = self._stop_command(self._message)
        self._changed_s = pose.time_s
        self._level = None

    def _settle(self, pose: Pose2D) -> None:
        start = self._stop_pose
        if pose.time_s - start.time_s < self.settings.settle_s:
            return
        heading = self._travel_heading_rad(self._stop_direction)
        coast = (pose.x_m - start.x_m) * math.cos(heading) + (pose.y_m - start.y_m) * math.sin(heading)
        rate = self.settings.learning_rate
        self.stop_lead_m = max(0.0, (1.0 - rate) * self.stop_lead_m + rate * coast)
        distance = self._distance(pose)
        if distance <= self.settings.goal_tolerance_m:
            self._finish(NavigationState.REACHED, f"goal reached: resting {distance:.3f} m from it "
                         f"(tolerance {self.settings.goal_tolerance_m:g} m)")
            return
        self.state = NavigationState.DRIVING
        self._message = f"came to rest {distance:.3f} m from the goal; driving on"

    def _finish(self, state: NavigationState, message: str) -> None:
        self.state, self._message = state, message
        self._command = self._stop_command(message)
        self._level = None

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
                                  self._heading_error_rad if self.state.active else 0.0, self._command.direction or "",
                                  self._command.turn_phase_rad, float(now_s) - self._started_s, self._message)
