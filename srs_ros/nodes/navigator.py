"""navigator: sends the robot where it is told, closing the loop through the overhead camera.

Interface (relative names)::

    subscribes  goal_pose            geometry_msgs/PoseStamped  frame 'floor' (RViz's "2D Goal Pose"), orientation
                                                                ignored
                goal_path            nav_msgs/Path              waypoints followed in order
                robot_pose           geometry_msgs/PoseStamped  camera_tracker's pose (never the simulator's truth)
                gait_phase           sensor_msgs/JointState     gait_player's phase (the robot stops at set phases)
    publishes   navigation_progress  std_msgs/String (JSON)     reliable + transient_local, every update period
                navigation_markers   visualization_msgs/MarkerArray  frame 'floor', for RViz: the goal's tolerance
                                                                disc coloured by state, the waypoints ahead, the
                                                                track driven, the state as text (reliable +
                                                                transient_local; srs_ros.ros.navigation_markers)
                /diagnostics         diagnostic_msgs/DiagnosticArray  "navigator: navigation"
    services    ~/cancel             std_srvs/Trigger           stop (ramp out, vent); state cancelled
    calls       trajectory_server/set_parameters_atomically, trajectory_server/regenerate,
                gait_player/set_parameters, gait_player/start, gait_player/stop  (srs_ros.ros.gait_driver)
    parameters  every navigation setting (srs_ros.core.navigation.NAVIGATION_TABLE: goal_tolerance_m 0.05 m,
                pose_timeout_s 1 s, ...), loop_path, calibration_file, calibration_preset, trajectory_server,
                gait_player, gait_keepalive_s, update_rate_hz, diagnostics_period_s

The controller (:class:`~srs_ros.core.navigation.NavigationController`, the same code the offline
``srs_navigate`` runs) decides; this node only feeds it goals, camera poses and time, and plays its gait
commands through the gait nodes' own parameters and services (so the ramps, the cross-fade, the one
pressure clamp and the stale-setpoint vent all stay in place; the navigator never arms anything). A goal
outside the camera's calibrated floor area is refused with the reason (log, progress, diagnostics) and the
current goal goes on; a new goal replaces the current one; no pose for ``pose_timeout_s`` (robot out of
view, tracker silent) stops the gait, state ``pose_lost``; arrival stops the gait (gait_player ramps every
length to 0: the muscles vent), state ``reached``. A navigator that dies or hangs stops renewing gait_player's
run (``gait_keepalive_s``, a dead man's handle): the gait ramps out by itself. States: idle, driving,
stopping, reached, cancelled, pose_lost, failed (docs/navigation.md).
"""

from __future__ import annotations

import dataclasses
import enum
import math
import time
from collections import deque
from typing import Any

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Path
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from srs_ros.core.errors import ConfigurationError, SrsError
from srs_ros.core.navigation import (
    NAVIGATION_TABLE,
    FloorArea,
    NavigationController,
    NavigationState,
    Pose2D,
    load_navigation_settings,
)
from srs_ros.core.vision.camera_calibration import load_calibration
from srs_ros.ros.gait_driver import GaitDriver
from srs_ros.ros.interfaces import (
    DIAGNOSTICS_TOPIC,
    FLOOR_FRAME,
    GAIT_PHASE_JOINT,
    GAIT_PHASE_TOPIC,
    GOAL_PATH_TOPIC,
    GOAL_POSE_TOPIC,
    NAVIGATION_MARKERS_TOPIC,
    NAVIGATION_PROGRESS_TOPIC,
    POSE_TOPIC,
    diagnostic_array,
    diagnostic_status,
    latched_qos,
    progress_message,
    setpoint_qos,
    stamp_to_seconds,
)
from srs_ros.ros.navigation_markers import MARKERS_PERIOD_S, Track, navigation_markers
from srs_ros.ros.parameters import SIM_CONFIG_FILE, ParameterSpec, check_parameters, declare_parameters
from srs_ros.ros.process import run_node, steady_timer

NODE_NAME = "navigator"
#: The navigator's status on /diagnostics is named "<node name>: navigation".
STATUS_NAME_SUFFIX = "navigation"

#: Settings the controller reads once, when it is made: read-only parameters.
STARTUP_SETTINGS = frozenset({"turn_levels_rad", "learning_rate", "turning_map_file"})
#: Rounds of a looped path given to the controller at once (it drives through them without stopping).
LOOP_ROUNDS = 100
#: The gait's phase is extrapolated from a gait_phase message at most this far (s): farther, it is not known.
PHASE_MAX_AGE_S = 0.25


def _setting_parameter(field) -> ParameterSpec:
    spec = ParameterSpec.from_field(field, read_only=field.name in STARTUP_SETTINGS)
    return dataclasses.replace(spec, default=list(spec.default)) if isinstance(spec.default, tuple) else spec


#: The navigation settings as parameters (one schema: srs_ros.core.navigation.NAVIGATION_TABLE); live but for
#: STARTUP_SETTINGS.
SETTING_PARAMETERS = tuple(_setting_parameter(field) for field in NAVIGATION_TABLE)
NODE_PARAMETERS = (
    ParameterSpec("loop_path", False, "a goal_path of two or more waypoints is patrolled: after its last waypoint "
                  "the robot goes on to the first, without stopping (read when a goal_path arrives)"),
    ParameterSpec("calibration_file", "", "the camera's floor calibration, whose area goals must lie in; '' = "
                  "config/camera_calibration.yaml (or the preset's)", read_only=True),
    ParameterSpec("calibration_preset", "", "'' or 'sim_bands': with no calibration_file, the simulated camera's "
                  "calibration, as camera_tracker's color_preset sim_bands uses", read_only=True,
                  choices=("", "sim_bands")),
    SIM_CONFIG_FILE,
    ParameterSpec("trajectory_server", "trajectory_server", "name of the trajectory server node (relative: in the "
                  "navigator's namespace)", read_only=True),
    ParameterSpec("gait_player", "gait_player", "name of the gait player node (relative: in the navigator's "
                  "namespace)", read_only=True),
    ParameterSpec("gait_keepalive_s", 2.0, "dead man's handle: gait_player's cycles are set so that it plays this "
                  "long after each ~/start, which the navigator repeats every quarter of it while driving; a navigator "
                  "that dies or hangs lets the gait ramp out by itself after at most this plus two cycles; 0 = off "
                  "(the gait plays until stopped)", 0.0, 60.0, read_only=True),
    ParameterSpec("update_rate_hz", 10.0, "rate of the lost-pose check, the gait calls and navigation_progress, Hz",
                  1.0, 100.0, read_only=True),
    ParameterSpec("diagnostics_period_s", 1.0, "period of the /diagnostics report, s (and at every state change)",
                  0.05, 60.0, read_only=True),
)
PARAMETERS = (*SETTING_PARAMETERS, *NODE_PARAMETERS)


class StampClock:
    """Message stamps on the steady clock: stamp + the low delay of the last ``window`` messages, along its drift.

    The controller measures motion over the camera's own frame times (no delivery jitter) and checks for a
    lost pose against the steady clock; a stamp clock that jumps (a restarted simulation, a looped video) is
    re-based at once. "Low" is the smallest tenth: one stamp from the future (0.7 s ahead) set the delay of
    every later pose 0.7 s short, which dropped them as not newer and ended a healthy run in a false pose_lost
    (a helper's review); a time is never later than its own arrival. The delay drifts when the stamps run on
    a simulated clock that is behind (or ahead of) real time: at 0.6x it grows 0.4 s a second, and a plain
    low delay dated every pose up to 1 s early, a false pose loss after one stall (a helper's review). The
    drift is the change of the low delay from the window's older half to its newer half.
    """

    LOW_SHARE = 0.1  # the share of the delays left out below "low"
    MIN_DRIFT_SAMPLES = 20  # fewer messages since the last jump: no drift is estimated

    def __init__(self, window: int = 100, jump_s: float = 1.0):
        self._samples: deque[tuple[float, float]] = deque(maxlen=window)  # (stamp s, delay s)
        self._jump_s = jump_s
        self._last_stamp_s = -math.inf

    def repeats(self, stamp_s: float) -> bool:
        """True for a stamp not newer than the last one taken, unless it went back a jump (a restarted clock).

        A frozen camera driver re-sends its last frame with its stamp: re-based as a jump, each copy was dated at
        its arrival, taken as a fresh pose and reset the lost-pose check (a helper's review: no pose_lost in 15 s
        of one frame repeated, at pose_timeout_s 3).
        """
        return 0.0 < stamp_s <= self._last_stamp_s and self._last_stamp_s - stamp_s <= self._jump_s

    def steady_s(self, stamp_s: float, arrival_s: float) -> float:
        """The steady-clock time of a message stamped ``stamp_s`` (0 = unstamped: its arrival)."""
        if stamp_s <= 0.0:
            return arrival_s
        self._last_stamp_s = stamp_s
        delay = arrival_s - stamp_s
        if self._samples and abs(delay - self._low_delay_s(stamp_s)) > self._jump_s:
            self._samples.clear()
        self._samples.append((stamp_s, delay))
        return stamp_s + min(self._low_delay_s(stamp_s), delay)

    def _low_delay_s(self, stamp_s: float) -> float:
        """The low delay of the window, carried to ``stamp_s`` along its drift (s of delay per s of stamp)."""
        stamps, delays = np.array(self._samples).T
        drift = 0.0
        half = len(stamps) // 2
        if len(stamps) >= self.MIN_DRIFT_SAMPLES:
            span_s = np.median(stamps[half:]) - np.median(stamps[:half])
            if span_s > 0.0:
                drift = (self._low(delays[half:]) - self._low(delays[:half])) / span_s
        return self._low(delays - drift * (stamps - stamps[-1])) + drift * (stamp_s - stamps[-1])

    @classmethod
    def _low(cls, values: np.ndarray) -> float:
        return float(np.partition(values, int(len(values) * cls.LOW_SHARE))[int(len(values) * cls.LOW_SHARE)])


def yaw_from_quaternion(z: float, w: float, x: float = 0.0, y: float = 0.0) -> float:
    """The yaw (rad) of a quaternion (rotation about the floor's normal)."""
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def progress_fields(progress, **extra: Any) -> dict[str, Any]:
    """A NavigationProgress as plain JSON-able fields (enums by value), plus ``extra``."""
    fields = {key: (value.value if isinstance(value, enum.Enum) else value)
              for key, value in dataclasses.asdict(progress).items()}
    fields["goal_xy_m"] = list(progress.goal_xy_m) if progress.goal_xy_m is not None else None
    fields["heading_error_deg"] = math.degrees(progress.heading_error_rad)
    return {**fields, **extra}


class Navigator(Node):
    """ROS wiring of a :class:`NavigationController` and a :class:`GaitDriver`."""

    def __init__(self, **kwargs):
        super().__init__(NODE_NAME, **kwargs)
        self._specs = declare_parameters(self, PARAMETERS)
        self._nav = NavigationController(self._settings(), self._floor_area())
        self._driver = GaitDriver(self, self._param("trajectory_server"), self._param("gait_player"),
                                  self._param("gait_keepalive_s"))
        self._stamps = StampClock()
        self._phases: deque[tuple[float, float, float]] = deque(maxlen=100)  # (stamp s, phase, signed Hz)
        self._path: list[tuple[float, float]] = []  # the goal or path as sent
        self._loop = False  # the path is patrolled
        self._refusal = ""  # the last refused goal's reason, until a goal is accepted
        self._last_state = None
        self._last_pose_s = math.nan
        self._track = Track()  # the tracked places since the last goal accepted
        self._markers_due_s = 0.0
        self.add_on_set_parameters_callback(self._check_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        self._progress_pub = self.create_publisher(String, NAVIGATION_PROGRESS_TOPIC, latched_qos())
        self._diag_pub = self.create_publisher(DiagnosticArray, DIAGNOSTICS_TOPIC, 10)
        self._markers_pub = self.create_publisher(MarkerArray, NAVIGATION_MARKERS_TOPIC, latched_qos())
        self.create_subscription(PoseStamped, GOAL_POSE_TOPIC, self._on_goal_pose, 10)
        self.create_subscription(Path, GOAL_PATH_TOPIC, self._on_goal_path, 10)
        self.create_subscription(PoseStamped, POSE_TOPIC, self._on_pose, 10)
        self.create_subscription(JointState, GAIT_PHASE_TOPIC, self._on_gait_phase, setpoint_qos())
        self.create_service(Trigger, "~/cancel", self._on_cancel)
        self.status_name = f"{self.get_name()}: {STATUS_NAME_SUFFIX}"
        steady_timer(self, 1.0 / self._param("update_rate_hz"), self._on_tick)
        steady_timer(self, self._param("diagnostics_period_s"), self._publish_diagnostics)
        self._publish_progress()
        self.get_logger().info(
            f"waiting for goals on {self.resolve_topic_name(GOAL_POSE_TOPIC)} and "
            f"{self.resolve_topic_name(GOAL_PATH_TOPIC)} "
            f"(frame '{FLOOR_FRAME}', inside {self._nav.area.extent_text} less {self._nav.area.margin_m:g} m, from "
            f"{self._nav.area.source}); pose from {self.resolve_topic_name(POSE_TOPIC)}; gait through "
            + ", ".join(self._driver.services()))

    def _param(self, name: str) -> Any:
        return self.get_parameter(name).value

    # ------------------------------------------------------------- set-up and parameters
    def _settings(self, changed: dict[str, Any] | None = None):
        values = {spec.name: self._param(spec.name) for spec in SETTING_PARAMETERS}
        return load_navigation_settings({**values, **(changed or {})}, where=f"{self.get_name()} parameters")

    def _floor_area(self) -> FloorArea:
        path, preset = self._param("calibration_file"), self._param("calibration_preset")
        if not path and preset == "sim_bands":
            from srs_ros.nodes.camera_tracker import sim_band_calibration

            calibration = sim_band_calibration(self._param(SIM_CONFIG_FILE.name))
        else:
            calibration = load_calibration(path or None)
        return FloorArea.from_calibration(calibration, margin_m=self._param("view_margin_m"))

    def _check_parameters(self, params) -> SetParametersResult:
        result = check_parameters(self._specs, params)
        changed = {p.name: p.value for p in params if p.name in NAVIGATION_TABLE}
        if result.successful and changed:
            try:  # the rules that span several settings, and the turning map file
                self._settings(changed)
            except ConfigurationError as exc:
                return SetParametersResult(successful=False, reason=str(exc))
        return result

    def _apply_parameters(self, params) -> None:
        names = {p.name for p in params}
        if names & set(NAVIGATION_TABLE.names):
            settings = self._settings()
            self._nav.settings = settings  # read on every decision
            if "view_margin_m" in names:
                self._nav.area = dataclasses.replace(self._nav.area, margin_m=settings.view_margin_m)

    # ------------------------------------------------------------- goals
    def _goal_frame_refusal(self, frame_id: str, what: str) -> str:
        if frame_id in ("", FLOOR_FRAME):
            return ""
        return (f"{what} is in frame '{frame_id}'; expected '{FLOOR_FRAME}', the camera's floor frame (in RViz set "
                f"the Fixed Frame to '{FLOOR_FRAME}')")

    def _on_goal_pose(self, msg: PoseStamped) -> None:
        point = (msg.pose.position.x, msg.pose.position.y)
        self._take_goal([point], self._goal_frame_refusal(msg.header.frame_id, "the goal"), "goal")

    def _on_goal_path(self, msg: Path) -> None:
        frames = {msg.header.frame_id, *(pose.header.frame_id for pose in msg.poses)} - {""}
        refusal = next(filter(None, (self._goal_frame_refusal(f, "the path") for f in sorted(frames))), "")
        points = [(pose.pose.position.x, pose.pose.position.y) for pose in msg.poses]
        self._take_goal(points, refusal, f"path of {len(points)} waypoints")

    def _take_goal(self, points: list[tuple[float, float]], refusal: str, what: str) -> None:
        now = time.monotonic()
        loop = len(points) > 1 and bool(self._param("loop_path"))
        if refusal:
            self._nav.refuse(refusal)  # the progress and /diagnostics say this refusal, not an older one
        else:
            decision = self._nav.set_path(points, now, rounds=LOOP_ROUNDS if loop else 1)
            refusal = "" if decision.accepted else decision.reason
        if refusal:
            self._refusal = refusal
            self.get_logger().warning(f"{what} refused: {refusal}")
        elif decision.unchanged:  # the goal driven to, sent again (`ros2 topic pub` at 1 Hz): nothing restarts
            self._refusal = ""
        else:
            self._refusal, self._path, self._loop = "", points, loop
            self._track.restart()
            self._markers_due_s = 0.0  # the new goal drawn at once
            self.get_logger().info(f"{what} accepted{' (patrolled in a loop)' if loop else ''}: {decision.reason}")
        self._after_event(now)

    def _on_cancel(self, _request, response):
        active = self._nav.state.active
        self._driver.stop(self._nav.cancel(time.monotonic(), "cancelled by ~/cancel"))
        self._loop = False
        response.success = True
        response.message = ("cancelled: the gait ramps out and stops (every muscle vented)" if active else
                            f"nothing to cancel (state {self._nav.state.value}); the gait is told to stop anyway")
        self.get_logger().info(response.message)
        self._after_event(time.monotonic())
        return response

    # ------------------------------------------------------------- poses and time
    def _on_gait_phase(self, msg: JointState) -> None:
        if list(msg.name) != [GAIT_PHASE_JOINT] or len(msg.position) != 1 or len(msg.velocity) != 1:
            self.get_logger().error(f"{GAIT_PHASE_TOPIC} ignored: names {list(msg.name)}; expected "
                                    f"['{GAIT_PHASE_JOINT}'] with one position and one velocity",
                                    throttle_duration_sec=5.0)
            return
        sample = (stamp_to_seconds(msg.header.stamp), float(msg.position[0]), float(msg.velocity[0]))
        if all(math.isfinite(v) for v in sample):
            if self._phases and sample[0] < self._phases[-1][0]:
                self._phases.clear()  # the stamp clock went back (a restarted simulation)
            self._phases.append(sample)

    def gait_phase_at(self, stamp_s: float) -> float | None:
        """gait_player's phase at the time ``stamp_s`` (the clock of the messages' stamps), or None if unknown.

        The controller compares where the robot is with the gait's phase (it stops as the gait passes set
        phases, from where the robot rests after a stop at each): both must be of the same instant, the camera
        frame's. Measured offline with a pose one frame late (33 ms), the phase of the frame reached 5 of 10
        random goals, the phase of the moment the pose arrived 2 of 10 (none late: 6 of 10).
        """
        before = [p for p in self._phases if p[0] <= stamp_s]
        sample = before[-1] if before else (self._phases[0] if self._phases else None)
        if sample is None or abs(stamp_s - sample[0]) > PHASE_MAX_AGE_S:
            return None
        sample_s, phase, frequency_hz = sample
        return (phase + frequency_hz * (stamp_s - sample_s)) % 1.0

    def _on_pose(self, msg: PoseStamped) -> None:
        arrival = time.monotonic()
        if msg.header.frame_id not in ("", FLOOR_FRAME):
            self._pose_ignored(f"robot_pose in frame '{msg.header.frame_id}'; expected '{FLOOR_FRAME}'")
            return
        stamp_s = stamp_to_seconds(msg.header.stamp)
        if self._stamps.repeats(stamp_s):
            self._pose_ignored(f"robot_pose stamped {stamp_s:.3f} s, not newer than the last pose (a camera that "
                               "repeats its last frame): counted as no pose")
            return
        q = msg.pose.orientation
        pose = Pose2D(msg.pose.position.x, msg.pose.position.y, yaw_from_quaternion(q.z, q.w, q.x, q.y),
                      self._stamps.steady_s(stamp_s, arrival))
        phase = self.gait_phase_at(stamp_to_seconds(msg.header.stamp))
        try:
            if phase is not None:
                self._nav.update_gait_phase(phase)
            self._nav.update_pose(pose)
        except SrsError as exc:  # a NaN pose: ignored, the lost-pose check still runs on time
            self._pose_ignored(str(exc))
            return
        self._last_pose_s = arrival
        self._track.add(pose.x_m, pose.y_m)
        if self._loop and self._nav.state is NavigationState.REACHED:  # after LOOP_ROUNDS rounds: go on
            self._nav.set_path(self._path, pose.time_s, rounds=LOOP_ROUNDS)
            self._nav.update_pose(dataclasses.replace(pose, time_s=pose.time_s + 1e-6))
        self._driver.drive(self._nav.command)

    def _pose_ignored(self, reason: str) -> None:
        self._nav.pose_ignored(reason, time.monotonic())  # a pose lost soon after names this, not only the log
        self.get_logger().error(f"robot_pose ignored: {reason}", throttle_duration_sec=5.0)

    def _on_tick(self) -> None:
        self._after_event(time.monotonic())

    def _after_event(self, now: float) -> None:
        self._driver.drive(self._nav.tick(now))
        progress = self._publish_progress(now)
        if self._nav.state != self._last_state or (now >= self._markers_due_s and self._nav.goal is not None):
            self._publish_markers(now, progress)  # before any goal: the one DELETEALL of the first state
        if self._nav.state != self._last_state:
            self._last_state = self._nav.state
            where = ""
            if self._loop:
                extra = self._extra(now)
                where = f" (patrol: waypoint {extra['waypoint_index'] + 1} of {extra['waypoint_count']}, round " \
                        f"{extra['round']})"
            self.get_logger().info(f"state {self._nav.state.value}{where}: {progress.message}")
            self._publish_diagnostics()

    # ------------------------------------------------------------- outputs
    def _extra(self, now: float) -> dict[str, Any]:
        """The node's own fields: refusal, gait errors, pose age, and the waypoint and round of a patrol."""
        index, count, round_ = self._nav.waypoint()
        phase = self.gait_phase_at(self.get_clock().now().nanoseconds * 1e-9)
        return {"refused": self._refusal, "gait_error": self._driver.error, "loop": self._loop,
                "pose_age_s": now - self._last_pose_s if math.isfinite(self._last_pose_s) else None,
                "gait_playing": self._driver.playing, "gait_phase": phase,
                "waypoint_index": index, "waypoint_count": count, "round": round_}

    def _publish_progress(self, now: float | None = None):
        """Publish navigation_progress; the progress it published."""
        now = time.monotonic() if now is None else now
        progress = self._nav.progress(now)
        self._progress_pub.publish(progress_message(progress_fields(progress, **self._extra(now))))
        return progress

    def _publish_markers(self, now: float, progress) -> None:
        self._markers_due_s = now + MARKERS_PERIOD_S
        self._markers_pub.publish(navigation_markers(
            progress, self._nav.goals_ahead, self._track.last, self._track.points, self._nav.settings.goal_tolerance_m,
            self.get_clock().now().to_msg()))

    def _publish_diagnostics(self) -> None:
        now = time.monotonic()
        progress = self._nav.progress(now)
        level, message = progress.level, progress.message
        if self._driver.error:
            level, message = "ERROR", f"{message}; gait command not applied: {self._driver.error}"
        extra = self._extra(now)
        values = {**progress.values(), "refused": self._refusal or "none", "gait_error": self._driver.error or "none"}
        if self._loop:
            values["goal"] = f"{extra['waypoint_index'] + 1} of {extra['waypoint_count']}, round {extra['round']}"
        status = diagnostic_status(self.status_name, self.resolve_topic_name(POSE_TOPIC), level, message, values)
        self._diag_pub.publish(diagnostic_array([status], self.get_clock().now().to_msg()))

    # ------------------------------------------------------------- for tests and the bringup
    @property
    def controller(self) -> NavigationController:
        """The controller (the same class the offline ``srs_navigate`` runs)."""
        return self._nav

    def stop_gait(self, timeout_s: float = 1.0) -> None:
        """At shutdown: tell gait_player to stop (it ramps out, every muscle vents) and wait for its answer."""
        if not (self._driver.playing or self._nav.state.active) or not self.context.ok():
            return
        self._driver.stop(self._nav.cancel(time.monotonic(), "navigator shutting down"))
        deadline_s = time.monotonic() + timeout_s
        while self._driver.busy and time.monotonic() < deadline_s:  # a start in flight answers, then the stop
            rclpy.spin_once(self, timeout_sec=0.05)
        answered = "no answer" if self._driver.busy or self._driver.error else "answered"
        print(f"navigator: shutting down, gait_player told to stop ({answered})", flush=True)


def main(args: list[str] | None = None) -> int:
    """Console script ``navigator``."""
    return run_node(Navigator, args, on_shutdown=lambda node: node.stop_gait())


if __name__ == "__main__":
    raise SystemExit(main())
