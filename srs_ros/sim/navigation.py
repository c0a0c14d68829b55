"""Closed-loop navigation on the simulated robot, offline and without ROS: the navigator's own controller.

:func:`run_navigation` puts :class:`~srs_ros.core.navigation.NavigationController` in the loop of a fresh
:class:`~srs_ros.sim.world.SimWorld`, as the ROS nodes would: the controller's :class:`GaitCommand` becomes a
rolling cycle (:func:`~srs_ros.core.gait.trajectory.generate_cycle`, the trajectory_server's fit) played by
:class:`~srs_ros.core.gait.playback.GaitPlayback` (the gait_player's logic: soft start and stop, cross-fade,
live frequency) at the rig's command rate; lengths become pressures through the one clamp. The pose comes
from the simulator's reference point (what the tracker reports) or, with ``camera=True``, from the simulated
overhead camera's image through the real tracker (:class:`~srs_ros.core.vision.tracking.Tracker`).
Goals are driven one after the other, each to a stop; a path (``as_path=True``) is followed as waypoints.
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from srs_ros.core.actuation.pressure import lengths_to_pressures_bar
from srs_ros.core.errors import InvalidInputError
from srs_ros.core.gait.playback import GaitPlayback, PlaybackState
from srs_ros.core.gait.request import SAMPLES_FIELD
from srs_ros.core.gait.trajectory import GaitCycle, generate_cycle
from srs_ros.core.navigation.area import FloorArea
from srs_ros.core.navigation.commands import GaitCommand, NavigationState
from srs_ros.core.navigation.controller import NavigationController
from srs_ros.core.navigation.motion import Pose2D
from srs_ros.core.navigation.settings import NavigationSettings, load_navigation_settings
from srs_ros.core.rig import load_rig
from srs_ros.core.robot import RobotDescription, default_robot
from srs_ros.sim.camera import OverheadCamera, band_tracker_config
from srs_ros.sim.config import SimConfig, load_sim_config
from srs_ros.sim.world import SimState, SimWorld

#: Camera frame rate of the loop (Hz), as the simulated overhead camera's.
CAMERA_RATE_HZ = 30.0
#: Longest a goal may take before the run gives it up (s, simulated).
DEFAULT_GOAL_TIMEOUT_S = 90.0
#: The path length is summed over the reference point sampled this often (s): the rolling body's reference
#: point wobbles within a cycle, which is not distance travelled.
PATH_SAMPLE_S = 0.5
#: Seconds the controller's clock skips between two fresh worlds (its pose history does not mix them).
FRESH_WORLD_GAP_S = 20.0
#: Columns of :attr:`NavigationResult.rows`.
COLUMNS = ("time_s", "x_m", "y_m", "yaw_rad", "seen_x_m", "seen_y_m", "seen_yaw_rad", "goal_index", "state",
           "direction", "turn_phase_rad", "frequency_hz", "distance_to_go_m", "heading_error_rad")
#: Codes of the ``state`` and ``direction`` columns.
STATE_CODES = {state: i for i, state in enumerate(NavigationState)}
DIRECTION_CODES = {None: 0, "inward_rolling": 1, "outward_rolling": -1, "serpentine_forward": 2,
                   "serpentine_backward": -2}


@dataclass(frozen=True)
class Latency:
    """The delays of the ROS system, offline: what the navigator node meets over DDS on a loaded machine.

    Each camera pose reaches the controller ``pose_s`` after its frame (stamped with the frame's time and the
    gait's phase then, as the node does), each command reaches the gait player ``command_s`` after the
    controller gave it, and now and then (on average every ``stall_every_s``, 0 = never) the navigator stalls
    for ``stall_s``: no pose taken, no command given meanwhile (a Python process on a busy 2-core machine stalls
    0.2-0.4 s now and then). Seeded: the same run every time.
    """

    pose_s: float = 0.0
    command_s: float = 0.0
    stall_every_s: float = 0.0
    stall_s: float = 0.0
    seed: int = 0

    def check(self) -> Latency:
        """``self`` when every delay is finite and >= 0, else :class:`InvalidInputError`."""
        for name in ("pose_s", "command_s", "stall_every_s", "stall_s"):
            value = getattr(self, name)
            if not math.isfinite(value) or value < 0.0:
                raise InvalidInputError(f"latency {name}: {value!r}; expected a finite number of seconds >= 0.")
        return self


@dataclass(frozen=True)
class GoalOutcome:
    """How one goal went: reached or not, when, how far from it the robot rested, how long its path was."""

    goal_xy_m: tuple[float, float]
    start_xy_m: tuple[float, float]
    state: NavigationState
    message: str
    time_s: float
    final_error_m: float
    path_length_m: float

    @property
    def reached(self) -> bool:
        """True when the controller reported the goal reached."""
        return self.state is NavigationState.REACHED

    @property
    def straight_m(self) -> float:
        """Straight-line distance from where the goal was given to the goal."""
        return math.dist(self.goal_xy_m, self.start_xy_m)

    def summary(self) -> str:
        """One line for people."""
        return (f"goal ({self.goal_xy_m[0]:+.3f}, {self.goal_xy_m[1]:+.3f}) m: {self.state.value} after "
                f"{self.time_s:.1f} s, resting {100 * self.final_error_m:.1f} cm from it, path "
                f"{self.path_length_m:.2f} m for {self.straight_m:.2f} m straight; {self.message}")


@dataclass(frozen=True)
class NavigationResult:
    """A run: one row per camera frame (:data:`COLUMNS`), the outcome of each goal, the run's wall time."""

    rows: np.ndarray
    outcomes: tuple[GoalOutcome, ...]
    wall_time_s: float
    camera: bool


class GaitDriver:
    """What the trajectory_server and the gait_player do with a :class:`GaitCommand`, offline."""

    def __init__(self, robot: RobotDescription, samples: int = SAMPLES_FIELD.default):
        self.robot, self.samples = robot, samples
        self.playback = GaitPlayback(max_length_m=robot.max_extension_m)
        self._key: tuple | None = None
        self._frequency_hz = 0.0

    def apply(self, command: GaitCommand) -> None:
        """New cycle when the gait or turn level changes (cross-faded), live frequency, start, stop (at a phase)."""
        if not command.moving:
            playing = self.playback.state in (PlaybackState.STARTING, PlaybackState.RUNNING)
            if command.stop_phase is None or not playing:
                self.playback.stop()
            elif self.playback.pending_stop_phase != command.stop_phase:
                self.playback.stop_at_phase(command.stop_phase)
            return
        self.playback.stop_at_phase(None)
        if command.cycle_key != self._key:
            cycle = _cycle(command.gait, command.amplitude_bar, tuple(command.gait_parameters.items()), self.samples,
                           self.robot)
            self.playback.load(cycle.lengths_m, cycle.frequency_hz)
            self._key = command.cycle_key
        if command.frequency_hz != self._frequency_hz:
            self.playback.set_frequency_override(command.frequency_hz)
            self._frequency_hz = command.frequency_hz
        self.playback.set_reverse(command.reverse)
        if self.playback.state in (PlaybackState.IDLE, PlaybackState.STOPPING):
            self.playback.start()

    def pressures_bar(self, dt_s: float) -> np.ndarray:
        """Advance the playback by ``dt_s`` and return the commanded pressures (bar, through the clamp)."""
        if not self.playback.has_cycle:
            return np.zeros(self.robot.joint_count)
        return lengths_to_pressures_bar(self.playback.step(dt_s).positions_m, self.robot)


@lru_cache(maxsize=64)
def _cycle(gait: str, amplitude_bar: float, parameters: tuple[tuple[str, float], ...], samples: int,
           robot: RobotDescription) -> GaitCycle:
    return generate_cycle(gait, amplitude_bar, 1.0, samples, robot, dict(parameters))


class _Eyes:
    """The pose source: the simulator's reference point, or the camera image through the tracker."""

    def __init__(self, config: SimConfig, use_camera: bool, render: bool):
        from srs_ros.core.vision.tracking import Tracker

        self.use_camera = use_camera
        self.camera = OverheadCamera(config) if (use_camera or render) else None
        self.tracker = None
        if use_camera:
            band_plane = self.camera.calibration_at_height(config.body.skin_radius_m)
            self.tracker = Tracker(band_plane, band_tracker_config(config.camera))
        self.frame: np.ndarray | None = None

    def see(self, state: SimState, now_s: float) -> Pose2D | None:
        """The pose at ``now_s`` (the controller's clock), None when the camera does not see the robot."""
        self.frame = self.camera.render(state.nodes_m) if self.camera is not None else None
        if not self.use_camera:
            x, y, yaw = state.pose
            return Pose2D(float(x), float(y), float(yaw), now_s)
        result = self.tracker.process(self.frame, now_s)
        if result.pose is None:
            return None
        return Pose2D(float(result.pose[0]), float(result.pose[1]), float(result.pose[2]), now_s)


def default_area(config: SimConfig, settings: NavigationSettings) -> FloorArea:
    """The simulated camera's calibrated floor area with the settings' margin."""
    return FloorArea.from_calibration(OverheadCamera(config).calibration, settings.view_margin_m)


def run_navigation(goals: Sequence[Sequence[float]], config: SimConfig | None = None,
                   settings: NavigationSettings | None = None, robot: RobotDescription | None = None,
                   camera: bool = False, as_path: bool = False, goal_timeout_s: float = DEFAULT_GOAL_TIMEOUT_S,
                   on_frame: Callable[[SimState, np.ndarray | None, NavigationController], None] | None = None,
                   render: bool = False, progress: Callable[[str], None] | None = None,
                   events: Callable[[float, NavigationController], None] | None = None,
                   from_start: bool = False, controller: NavigationController | None = None,
                   latency: Latency | None = None, rounds: int = 1) -> NavigationResult:
    """Drive the simulated robot to ``goals`` [(x_m, y_m), ...] with the navigation controller; see the module doc.

    ``on_frame(state, image, controller)`` at every camera frame (``image`` when ``camera`` or ``render``);
    ``events(time_s, controller)`` before the controller sees each frame (a test replaces a goal or cancels
    there); ``progress(line)`` once per goal. A goal the controller refuses is recorded as refused and skipped.
    ``from_start``: every goal from the start on a fresh world (the controller, and what it learned, is kept,
    as a running navigator keeps it); ``controller``: one to use (and keep learning) instead of a new one;
    ``latency``: the delays of a ROS system (:class:`Latency`; None: none); ``rounds`` (with ``as_path``): the path
    followed that many times over, as the navigator patrols (``loop_path``), one outcome for all.
    Raises :class:`InvalidInputError` for bad arguments, :class:`~srs_ros.core.errors.SimulationError` if the
    physics diverges.
    """
    try:  # a flat (x, y) was a TypeError, rounds NaN a ValueError, and a goal timeout was not checked at all
        goals = [tuple(float(v) for v in g) for g in goals]
        whole = float(rounds).is_integer() and rounds >= 1
    except (TypeError, ValueError):
        goals, whole = [], False
    if not goals or any(len(g) != 2 for g in goals):
        raise InvalidInputError("goals: expected one or more (x_m, y_m) pairs of numbers.")
    if not whole:
        raise InvalidInputError(f"rounds: expected a whole number of rounds >= 1, got {rounds!r}.")
    if not (math.isfinite(goal_timeout_s) and goal_timeout_s > 0.0):
        raise InvalidInputError(f"goal_timeout_s: expected simulated seconds > 0, got {goal_timeout_s!r}.")
    rounds = int(rounds) if as_path else 1
    robot = robot or default_robot()
    config = config or load_sim_config(robot=robot)
    settings = settings or load_navigation_settings()
    controller = controller or NavigationController(settings, default_area(config, settings))
    rate_hz = load_rig(robot=robot).command_rate_hz
    eyes = _Eyes(config, camera, render)
    latency = (latency or Latency()).check()
    loop = _Loop(SimWorld(config, robot), GaitDriver(robot), eyes, controller, rate_hz, latency=latency)
    started = time.perf_counter()
    outcomes, rows = [], []
    batches = [goals] if as_path else [[g] for g in goals]
    for i, batch in enumerate(batches):
        if from_start and i > 0:
            rows += loop.rows
            clock_s = loop.clock_offset_s + loop.world.time_s + FRESH_WORLD_GAP_S
            loop = _Loop(SimWorld(config, robot), GaitDriver(robot), eyes, controller, rate_hz, clock_s, latency)
        outcome = loop.drive(batch, goal_timeout_s * len(batch) * rounds, on_frame, events, rounds)
        outcomes.append(outcome)
        if progress is not None:
            progress(outcome.summary())
    return NavigationResult(np.array(rows + loop.rows), tuple(outcomes), time.perf_counter() - started, camera)


class _Loop:
    """The world, the driver, the pose source and the controller, stepped together."""

    def __init__(self, world: SimWorld, driver: GaitDriver, eyes: _Eyes, controller: NavigationController,
                 command_rate_hz: float, clock_offset_s: float = 0.0, latency: Latency = Latency()):
        """``clock_offset_s``: the controller's clock at the world's time 0 (a fresh world for a kept controller)."""
        self.world, self.driver, self.eyes, self.controller = world, driver, eyes, controller
        self.clock_offset_s = clock_offset_s
        self.latency = latency
        self._rng = np.random.default_rng(latency.seed)
        self._poses: deque[tuple[float, Pose2D | None, float]] = deque()  # (due s, pose, phase at its frame)
        self._commands: deque[tuple[float, GaitCommand]] = deque()  # (due s, command)
        self._stalled_until_s = -math.inf
        self.command_dt_s = 1.0 / command_rate_hz
        self.rows: list[list[float]] = []
        self._next_command_s = 0.0
        self._next_frame_s = 0.0

    def drive(self, goals, timeout_s, on_frame, events, rounds: int = 1) -> GoalOutcome:
        """Drive along ``goals``, ``rounds`` times over, until the controller stops and the gait ramped out.

        A controller still driving when ``timeout_s`` is up is cancelled.
        """
        start = self.world.state(with_contacts=False)
        start_xy, t0 = (float(start.reference_xy_m[0]), float(start.reference_xy_m[1])), self._clock(start)
        decision = self.controller.set_path(goals, t0, rounds)
        if not decision.accepted:
            return GoalOutcome(goals[-1], start_xy, NavigationState.IDLE, f"refused: {decision.reason}", 0.0,
                               math.nan, 0.0)
        length, last_xy, next_sample_s = 0.0, np.array(start_xy), t0 + PATH_SAMPLE_S
        nav = self.controller
        while True:
            state = self._frame(on_frame, events)
            now = self._clock(state)
            if now >= next_sample_s:
                length += float(np.linalg.norm(state.reference_xy_m - last_xy))
                last_xy, next_sample_s = state.reference_xy_m.copy(), next_sample_s + PATH_SAMPLE_S
            if not nav.state.active and self.driver.playback.state is PlaybackState.IDLE:
                break
            if now - t0 > timeout_s and nav.state.active:
                nav.cancel(now, f"gave up after {timeout_s:g} s (simulated)")
        length += float(np.linalg.norm(state.reference_xy_m - last_xy))
        error = float(math.dist(goals[-1], state.reference_xy_m))
        return GoalOutcome(goals[-1], start_xy, nav.state, nav.progress(now).message, now - t0, error, length)

    def _clock(self, state: SimState) -> float:
        return state.time_s + self.clock_offset_s

    def _frame(self, on_frame, events) -> SimState:
        """Run the commands up to the next camera frame, then let the controller see it."""
        frame_s = self._next_frame_s
        while self._next_command_s <= frame_s + 1e-12:
            self.world.advance_to(self._next_command_s)
            self.world.command_pressures(self.driver.pressures_bar(self.command_dt_s))
            self._next_command_s += self.command_dt_s
        self.world.advance_to(frame_s)
        self._next_frame_s += 1.0 / CAMERA_RATE_HZ
        state = self.world.state(with_contacts=False)
        now, nav = self._clock(state), self.controller
        if events is not None:
            events(now, nav)
        pose = self.eyes.see(state, now)
        self._poses.append((now + self.latency.pose_s, pose, self.driver.playback.phase))
        if self._running(now):
            while self._poses and self._poses[0][0] <= now + 1e-9:
                _, seen, phase = self._poses.popleft()
                nav.update_gait_phase(phase)
                if seen is not None:
                    nav.update_pose(seen)
            self._commands.append((now + self.latency.command_s, nav.tick(now)))
        while self._commands and self._commands[0][0] <= now + 1e-9:
            self.driver.apply(self._commands.popleft()[1])
        self._record(state, pose, now)
        if on_frame is not None:
            on_frame(state, self.eyes.frame, nav)
        return state

    def _running(self, now_s: float) -> bool:
        """False while the navigator stalls (:class:`Latency`); a stall starts at random, seeded."""
        latency = self.latency
        if now_s < self._stalled_until_s:
            return False
        if latency.stall_every_s > 0.0 and self._rng.random() < 1.0 / (CAMERA_RATE_HZ * latency.stall_every_s):
            self._stalled_until_s = now_s + latency.stall_s
            return False
        return True

    def _record(self, state: SimState, pose: Pose2D | None, now_s: float) -> None:
        nav = self.controller
        progress = nav.progress(now_s)
        seen = (pose.x_m, pose.y_m, pose.yaw_rad) if pose is not None else (math.nan,) * 3
        command = nav.command
        self.rows.append([now_s, *state.pose, *seen, progress.goal_index, STATE_CODES[nav.state],
                          DIRECTION_CODES[command.direction], command.turn_phase_rad,
                          command.frequency_hz if command.moving else 0.0, progress.distance_to_go_m,
                          progress.heading_error_rad])


def random_goals(rng: np.random.Generator, count: int, config: SimConfig, settings: NavigationSettings,
                 min_m: float = 0.4, max_m: float = 1.0) -> list[tuple[float, float]]:
    """``count`` goals at a uniform random distance ``min_m``-``max_m`` and bearing from the start.

    Each lies inside the camera's floor area with the settings' margin (the issue's test of the navigator).
    """
    area = default_area(config, settings)
    start = np.array([config.start.x_m, config.start.y_m])
    goals: list[tuple[float, float]] = []
    while len(goals) < count:
        distance, bearing = rng.uniform(min_m, max_m), rng.uniform(-math.pi, math.pi)
        x, y = start + distance * np.array([math.cos(bearing), math.sin(bearing)])
        if not area.refusal(float(x), float(y)):
            goals.append((float(x), float(y)))
    return goals
