"""The small nodes of ``srs_bringup`` (the main job): its status line, its patrol and its video recorder.

- :class:`StatusMonitor`: one status line per period: gait, cycles, setpoint and command rates, the largest
  pressure, the hardware's state; with the navigator its state, goal, distance to go and heading error
  (:func:`navigation_text`); on the simulated robot the tracked and true travel speeds (:class:`SpeedMeter`)
  and what the camera tracker says about the robot's view.
- :class:`Patrol`: ``--patrol``: sends the waypoints on ``goal_path`` once the navigator listens.
- :class:`VideoRecorder`: ``--video``: the overhead camera's images to a file.
"""

from __future__ import annotations

import collections
import math
import sys
import time
from typing import TYPE_CHECKING, Any

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Path
from rclpy.node import Node
from sensor_msgs.msg import Image, JointState
from std_msgs.msg import Float64MultiArray, String

from srs_ros.core.errors import ConfigurationError, InvalidInputError, SrsError
from srs_ros.core.gait.library import played_gait
from srs_ros.core.gait.playback import describe_frequency
from srs_ros.core.vision.view import ViewStatus
from srs_ros.ros.interfaces import (
    COMMANDED_PRESSURE_TOPIC,
    DIAGNOSTICS_TOPIC,
    FLOOR_FRAME,
    GOAL_PATH_TOPIC,
    GROUND_TRUTH_TOPIC,
    IMAGE_TOPIC,
    NAVIGATION_PROGRESS_TOPIC,
    POSE_TOPIC,
    SETPOINT_TOPIC,
    diagnostic_values,
    image_msg_to_array,
    latched_qos,
    progress_fields,
    setpoint_qos,
    stamp_to_seconds,
)
from srs_ros.ros.process import steady_timer

if TYPE_CHECKING:
    from srs_ros.nodes.gait_player import GaitPlayer
    from srs_ros.nodes.hardware_node import HardwareNode
    from srs_ros.nodes.trajectory_server import TrajectoryServer


#: With the navigator, the status line's travel speeds are over this many seconds of poses (s).
NAVIGATING_SPEED_WINDOW_S = 5.0


class StatusMonitor(Node):
    """Counts setpoints and commands and prints one status line per period (with speeds on the sim rig).

    ``tracker_status`` (sim rig) is the camera tracker's ``(status name, hardware_id)`` on ``/diagnostics``:
    what it reports about the robot's view is followed (another robot's tracker on the same domain is not).
    """

    def __init__(self, player: GaitPlayer, server: TrajectoryServer, hardware: HardwareNode, period_s: float,
                 simulated: bool = False, tracker_status: tuple[str, str] | None = None, context=None,
                 navigating: bool = False):
        super().__init__("srs_status", context=context)
        self._player, self._server, self._hardware = player, server, hardware
        self._setpoints = 0
        self._commands = 0
        self._largest_bar = 0.0
        self._since_s = time.monotonic()
        self._start_s = self._since_s
        self._tty = sys.stdout.isatty()
        # Open loop: Table I's speed (displacement since the start over time); a patrol returns to where it began,
        # so with the navigator the speed is over the last few seconds (how fast it is rolling now).
        window_s = NAVIGATING_SPEED_WINDOW_S if navigating else None
        self._speed_label = f"travel speed over {window_s:g} s" if window_s else "travel speed"
        self._tracked = SpeedMeter(window_s)
        self._truth = SpeedMeter(window_s) if simulated else None
        self._tracker_status = tracker_status
        self._view: tuple[ViewStatus, float] | None = None  # the tracker's last report, when it arrived (steady s)
        self.create_subscription(JointState, SETPOINT_TOPIC, self._on_setpoint, setpoint_qos())
        self.create_subscription(Float64MultiArray, COMMANDED_PRESSURE_TOPIC, self._on_command, 10)
        if simulated:
            self.create_subscription(PoseStamped, POSE_TOPIC, self._tracked.add, 10)
            self.create_subscription(PoseStamped, GROUND_TRUTH_TOPIC, self._truth.add, 10)
        if simulated and tracker_status is not None:
            self.create_subscription(DiagnosticArray, DIAGNOSTICS_TOPIC, self._on_diagnostics, 10)
        self._navigation: dict[str, Any] | None = {} if navigating else None  # the navigator's last progress
        if navigating:
            self.create_subscription(String, NAVIGATION_PROGRESS_TOPIC, self._on_progress, latched_qos())
        steady_timer(self, period_s, self._print)

    def _on_progress(self, msg: String) -> None:
        try:
            self._navigation = progress_fields(msg)
        except SrsError as exc:
            self.get_logger().error(f"navigation progress ignored: {exc}", throttle_duration_sec=5.0)

    def _on_setpoint(self, _msg: JointState) -> None:
        self._setpoints += 1

    def _on_command(self, msg: Float64MultiArray) -> None:
        self._commands += 1
        self._largest_bar = max(self._largest_bar, max(msg.data, default=0.0))

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            if (status.name, status.hardware_id) == self._tracker_status:
                view = ViewStatus.from_values(diagnostic_values(status), status.message)
                if view is not None:
                    self._view = (view, time.monotonic())

    def _speeds(self, now_s: float) -> str:
        """The sim rig's speeds; the tracked one is ``--`` while the tracker has no current pose (said why)."""
        view = self._view[0].aged(now_s - self._view[1]) if self._view is not None else None
        current = view is None or view.pose_current
        tracked = self._tracked.take() if current else "  --"
        text = f" | {self._speed_label} tracked {tracked} truth {self._truth.take()} cm/s"
        return text if current else f"{text} | {view.summary()}"

    def status_line(self) -> str:
        """One line: gait, cycles played, rates (Hz), the largest pressure in the period, speeds (sim rig).

        On the simulated robot it ends with the traveling speed since the start (Table I's displacement over
        time; with the navigator over the last :data:`NAVIGATING_SPEED_WINDOW_S`), tracked by the camera beside
        the ground truth (cm/s), or ``--`` and e.g. ``robot out of the
        camera's view: last seen 2.1 s ago at x 1.234 y 0.056 m (floor)`` while the tracker says so.
        Cycles played (e.g. ``cycle  12.37``: 12 whole cycles, phase 0.37) rather than the bare phase,
        which a 1 s status period samples at the same value every time for a 1 Hz gait.
        """
        now_s = time.monotonic()
        span_s = max(now_s - self._since_s, 1e-9)
        get = self._server.get_parameter
        playback = self._player.playback
        # The gait as played: the navigator plays inward rolling backward (outward rolling), at its own frequency.
        frequency = describe_frequency(playback.frequency_hz, playback.target_frequency_hz)
        line = (f"[{now_s - self._start_s:6.1f} s] {played_gait(get('gait').value, playback.reverse)} "
                f"{get('amplitude_bar').value:g} bar {frequency} | {playback.state.value} cycle "
                f"{playback.cycles_done:7.2f} | "
                f"setpoints {self._setpoints / span_s:5.0f} Hz | commands {self._commands / span_s:5.0f} Hz | "
                f"largest {self._largest_bar:4.2f} bar | hardware {self._hardware.status.reason.value}")
        if self._navigation is not None:
            line += " | " + navigation_text(self._navigation)
        if self._truth is not None:
            line += self._speeds(now_s)
        self._setpoints = self._commands = 0
        self._largest_bar = 0.0
        self._since_s = now_s
        return line

    def _print(self) -> None:
        line = self.status_line()
        if self._tty:
            print("\r" + line.ljust(170), end="", flush=True)
        else:
            print(line, flush=True)


def navigation_text(fields: dict[str, Any]) -> str:
    """The navigator's progress for the status line: state, goal, distance to go, heading error (or why stopped).

    E.g. ``nav driving to (0.500, 0.400) m [waypoint 2 of 4, round 1]: 0.31 m to go, heading error 12 deg,
    inward_rolling turn +0.20 rad``.
    """
    state = fields.get("state")
    if state is None:
        return "nav: no progress from the navigator yet"
    goal = fields.get("goal_xy_m")
    if state == "idle" or goal is None:
        text = f"nav {state}: waiting for a goal"
    else:
        where = f"{state} to ({goal[0]:.3f}, {goal[1]:.3f}) m"
        if fields.get("loop"):
            where += (f" [waypoint {fields['waypoint_index'] + 1} of {fields['waypoint_count']}, "
                      f"round {fields['round']}]")
        elif fields.get("goal_count", 1) > 1:
            where += f" [goal {fields['goal_index'] + 1} of {fields['goal_count']}]"
        to_go = fields.get("distance_to_go_m")
        text = f"nav {where}: " + ("-- m to go" if to_go is None else f"{to_go:.2f} m to go")
        if state in ("driving", "stopping"):
            text += f", heading error {fields.get('heading_error_deg') or 0.0:.0f} deg"
            if fields.get("direction"):
                text += f", {fields['direction']} turn {fields.get('turn_phase_rad') or 0.0:+.2f} rad"
        else:
            text += f" ({fields.get('message', '')})"
    if fields.get("gait_error"):
        text += f" | gait command not applied: {fields['gait_error']}"
    if fields.get("refused"):
        text += f" | goal refused: {fields['refused']}"
    return text


def patrol_path(waypoints_xy_m) -> Path:
    """The patrol's waypoints as a nav_msgs/Path in the floor frame."""
    path = Path()
    path.header.frame_id = FLOOR_FRAME
    for x_m, y_m in waypoints_xy_m:
        pose = PoseStamped()
        pose.header.frame_id = FLOOR_FRAME
        pose.pose.position.x, pose.pose.position.y = float(x_m), float(y_m)
        pose.pose.orientation.w = 1.0
        path.poses.append(pose)
    return path


class Patrol(Node):
    """``--patrol``: sends the waypoints on ``goal_path`` (the navigator patrols them in a loop) and resumes it.

    The path goes out once the navigator listens and the camera tracks the robot (a goal sent before the
    first pose would be lost at once). When the navigator stopped for a lost pose or no progress (states
    ``pose_lost``, ``failed``: a loaded machine's tracker can fall silent for a second) the patrol is sent
    again, from the waypoint it was driving to, once the robot has been tracked for :attr:`RESUME_AFTER_S`;
    never after a ``~/cancel``.
    """

    #: Tracked this long again after a stop for a lost pose or no progress: the patrol goes on.
    RESUME_AFTER_S = 2.0

    def __init__(self, waypoints_xy_m, context=None):
        super().__init__("srs_patrol", context=context)
        self.waypoints_xy_m = [tuple(p) for p in waypoints_xy_m]
        self.sent = 0  # times the path was sent
        self._state = ""  # the navigator's last state
        self._waypoint = 0  # the waypoint the navigator was driving to (a resumed patrol goes on from there)
        self._sent_from = 0  # the waypoint the path last sent starts with
        self._tracked_since: float | None = None  # steady s since poses arrive without a gap, None: none now
        self._last_pose_s = self._sent_s = -math.inf
        self._publisher = self.create_publisher(Path, GOAL_PATH_TOPIC, 10)
        self.create_subscription(PoseStamped, POSE_TOPIC, self._on_pose, 10)
        self.create_subscription(String, NAVIGATION_PROGRESS_TOPIC, self._on_progress, latched_qos())
        steady_timer(self, 0.1, self._check)

    def _on_pose(self, _msg: PoseStamped) -> None:
        now = time.monotonic()
        if now - self._last_pose_s > 0.5:
            self._tracked_since = now
        self._last_pose_s = now

    def _on_progress(self, msg: String) -> None:
        try:
            fields = progress_fields(msg)
        except SrsError:
            return
        self._state = fields.get("state", "")
        if fields.get("loop") and isinstance(fields.get("waypoint_index"), int):  # of the path as last sent
            self._waypoint = (self._sent_from + fields["waypoint_index"]) % len(self.waypoints_xy_m)

    def _check(self) -> None:
        now = time.monotonic()
        tracked = self._tracked_since is not None and now - self._last_pose_s < 0.5
        if not tracked or self._publisher.get_subscription_count() == 0:
            return
        if self.sent == 0:
            self._send("sent")
        elif (self._state in ("pose_lost", "failed") and now - self._tracked_since >= self.RESUME_AFTER_S
              and now - self._sent_s >= self.RESUME_AFTER_S):
            self._send(f"sent again (the navigator had stopped: {self._state}; the robot is tracked again)")

    def _send(self, what: str) -> None:
        self._sent_from = self._waypoint
        order = self.waypoints_xy_m[self._waypoint:] + self.waypoints_xy_m[:self._waypoint]
        self._publisher.publish(patrol_path(order))
        self.sent += 1
        self._state = "sent"  # until the navigator's progress says otherwise
        self._sent_s = time.monotonic()
        self.get_logger().info(f"patrol of {len(order)} waypoints {what} on {self._publisher.topic_name}: "
                               + ", ".join(f"({x:g}, {y:g})" for x, y in order))


class SpeedMeter:
    """Traveling speed (cm/s) of a PoseStamped stream, by the stamps: since its first pose, or over a window.

    Since the first pose (``window_s`` None) it is the paper's Table I measure (displacement over time): a gait
    that only sways in place shows about 0. Over the last ``window_s`` seconds of stamps it is how fast the robot
    travels now (a patrol comes back to where it started, so its speed since the start falls toward 0).
    """

    def __init__(self, window_s: float | None = None) -> None:
        self.window_s = window_s
        self._first: tuple[float, float, float] | None = None
        self._recent: collections.deque[tuple[float, float, float]] = collections.deque()

    def add(self, msg: PoseStamped) -> None:
        """One pose (stamp s, x m, y m)."""
        sample = (stamp_to_seconds(msg.header.stamp), msg.pose.position.x, msg.pose.position.y)
        self._first = self._first or sample
        self._recent.append(sample)
        while self.window_s is not None and len(self._recent) > 2 and sample[0] - self._recent[1][0] >= self.window_s:
            self._recent.popleft()  # keep the newest pose at least window_s older than the last
        while self.window_s is None and len(self._recent) > 1:
            self._recent.popleft()

    def take(self) -> str:
        """The speed so far as text (``--`` before two poses)."""
        first = self._first if self.window_s is None else (self._recent[0] if self._recent else None)
        last = self._recent[-1] if self._recent else None
        if first is None or last is None or last[0] <= first[0]:
            return "  --"
        return f"{100.0 * math.hypot(last[1] - first[1], last[2] - first[2]) / (last[0] - first[0]):4.1f}"


class VideoRecorder(Node):
    """``--video``: writes the overhead camera's images (``image_raw``) to a video file (MJPG) on their own time line.

    A frame goes in at ``fps`` by its stamp, repeated over the frames the camera skipped: the one-process bringup's
    camera gives about 20 of its 30 frames a second on a busy machine, and written one for one the video ran 1.5
    times fast (a helper's review). An image that cannot be written (an unknown encoding, another size) is counted
    and skipped, not the end of the run.
    """

    #: Most frames one image is repeated over (s of video): a long gap in the stamps is not filled frame by frame.
    MAX_GAP_S = 2.0

    def __init__(self, path: str, fps: float):
        super().__init__("srs_video_recorder")
        self.path, self.fps = path, fps
        self.frames = self.images = self.skipped = 0  # frames written, images taken, images skipped
        self._writer = None
        self._size: tuple[int, int] | None = None
        self._first_s = math.nan
        self.create_subscription(Image, IMAGE_TOPIC, self._on_image, 10)

    def _on_image(self, msg: Image) -> None:
        try:
            frame = image_msg_to_array(msg)
        except InvalidInputError as exc:
            self._skip(str(exc))
            return
        if self._writer is None:
            self._open(frame)
        if (frame.shape[1], frame.shape[0]) != self._size:
            self._skip(f"an image of {frame.shape[1]}x{frame.shape[0]}, the video's are {self._size[0]}x"
                       f"{self._size[1]}")
            return
        stamp_s = stamp_to_seconds(msg.header.stamp)
        if not stamp_s >= self._first_s or math.isnan(self._first_s):  # the first, or a clock that went back
            self._first_s = stamp_s - self.frames / self.fps
        due = int(round((stamp_s - self._first_s) * self.fps)) + 1  # frames the video should hold with this one
        repeats = min(max(due - self.frames, 0), int(self.MAX_GAP_S * self.fps) + 1)
        for _ in range(repeats):
            self._writer.write(frame)
        self.frames += repeats
        self.images += 1

    def _open(self, frame) -> None:
        import cv2  # only with --video: OpenCV is not loaded at start otherwise

        self._size = (frame.shape[1], frame.shape[0])
        self._writer = cv2.VideoWriter(self.path, cv2.VideoWriter_fourcc(*"MJPG"), self.fps, self._size)
        if not self._writer.isOpened():
            self._writer = None  # nothing saved: close() says nothing
            raise ConfigurationError(f"--video {self.path}: OpenCV cannot write this file (use a .avi path in "
                                     "a writable folder).")

    def _skip(self, reason: str) -> None:
        self.skipped += 1
        self.get_logger().warning(f"--video: image skipped: {reason} ({self.skipped} so far)",
                                  throttle_duration_sec=5.0)

    def close(self) -> None:
        """Finish the file and say where it is."""
        if self._writer is not None:
            self._writer.release()
            skipped = f"; {self.skipped} images skipped" if self.skipped else ""
            print(f"srs_bringup: saved {self.images} camera images as {self.frames} frames at {self.fps:g} fps "
                  f"({self.frames / self.fps:.1f} s) to {self.path}{skipped}", flush=True)
