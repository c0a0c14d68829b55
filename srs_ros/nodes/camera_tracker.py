"""ROS 2 node ``camera_tracker``: the robot's floor pose, velocity and trail from a fixed overhead camera.

Input: ``image_raw`` (sensor_msgs/Image: bgr8, rgb8, mono8, bgra8, rgba8, bayer_*8) from any camera driver, or, when
the ``source`` parameter is set, a video file or camera index read directly with OpenCV. Output, stamped
with the image's stamp, in the calibration's floor frame: ``robot_pose`` (geometry_msgs/PoseStamped),
``robot_twist`` (geometry_msgs/TwistStamped, smoothed) and ``robot_path`` (nav_msgs/Path). A frame where a
marker is missing publishes nothing. ``/diagnostics`` (status ``camera_tracker: marker tracking``) says:

- OK ``tracking``;
- WARN ``markers lost (not seen: head)`` for frames without a pose, shorter than ``lost_after_s`` (0.5 s);
- WARN ``robot out of the camera's view: last seen .. s ago at x .. y .. m (floor)`` once frames keep
  arriving without a pose for ``lost_after_s``; the key/values ``view_state``, ``last_seen_x_m``,
  ``last_seen_y_m``, ``last_seen_frame_id``, ``last_seen_ago_s`` carry the same;
- ERROR ``no images from /image_raw for .. s (camera silent)`` after ``image_timeout_s`` (1 s) without a frame;
- ERROR ``images refused: <reason>`` while frames arrive that cannot be tracked (a size other than the
  calibration's ``image_size_px``, an unknown encoding, an empty image), the reason also in the log (one line
  per 5 s at most);

and returns to OK when the robot is seen again. The decisions are :class:`srs_ros.core.vision.tracking.ViewWatch`'s,
all tracking is in :mod:`srs_ros.core.vision.tracking`; this module is ROS wiring only.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseStamped, TwistStamped
from nav_msgs.msg import Path as PathMsg
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import Image

from srs_ros.core.errors import ConfigurationError, InvalidInputError, SrsError
from srs_ros.core.rig import COLOR_PRESETS, SIM_COLOR_PRESET
from srs_ros.core.vision.camera_calibration import load_calibration
from srs_ros.core.vision.tracking import (
    TRACKER_TABLE,
    Tracker,
    TrackerConfig,
    TrackResult,
    yaw_to_quaternion,
)
from srs_ros.core.vision.view import ViewStatus, ViewWatch
from srs_ros.ros.interfaces import (
    DIAGNOSTICS_TOPIC,
    IMAGE_TOPIC,
    PATH_TOPIC,
    POSE_TOPIC,
    TWIST_TOPIC,
    diagnostic_array,
    diagnostic_status,
    image_msg_to_array,
    seconds_to_stamp,
    stamp_to_seconds,
)
from srs_ros.ros.parameters import SIM_CONFIG_FILE, ParameterSpec, declare_parameters
from srs_ros.ros.process import run_node, steady_timer

#: The tracker's status on /diagnostics is named "<node name>: marker tracking".
STATUS_NAME_SUFFIX = "marker tracking"
#: A parameter this node no longer has, and what replaced it (said at start-up when it is still given).
RENAMED_PARAMETERS = {"lost_timeout_s": "image_timeout_s (no images: ERROR camera silent) and lost_after_s "
                                        "(no pose: WARN robot out of the camera's view)"}

#: Refused frames are logged at most this often (one line, the newest reason), s.
REFUSAL_LOG_PERIOD_S = 5.0
#: robot_path is published at most this often (s): sent whole with every new point, its 5000 poses took 48 ms of a
#: 33 ms frame after a few minutes' travel (a helper's review). The points are still taken at every frame.
PATH_PERIOD_S = 0.5
#: A camera whose reads fail this many times in a row is opened again (a USB read timeout, a replugged camera).
CAMERA_REOPEN_AFTER = 30
#: Options of the tracker the node does not take as parameters (the default holds).
NOT_PARAMETERS = ("max_marker_spacing_m",)

PARAMETERS = (
    ParameterSpec("calibration_file", "", "floor calibration YAML; empty = config/camera_calibration.yaml",
                  read_only=True),
    ParameterSpec("source", "", "empty = subscribe to image_raw; else a video file path or a camera index (e.g. '0')",
                  read_only=True),
    ParameterSpec("source_rate_hz", 0.0, "frame rate for 'source', Hz; 0 = the video's own rate (30 if unknown)",
                  0.0, 1000.0, read_only=True),
    ParameterSpec("loop", False, "restart a 'source' video file at its end", read_only=True),
    # the tracker's options: types, ranges and defaults from srs_ros.core.vision.tracking.TRACKER_TABLE
    *(ParameterSpec.from_field(f, read_only=True) for f in TRACKER_TABLE if f.name not in NOT_PARAMETERS),
    ParameterSpec("color_preset", "", f"'' or '{SIM_COLOR_PRESET}': the colour detector set for the simulated robot's "
                  "head and tail bands (config/sim.yaml), replacing detector and the HSV bounds; with no "
                  "calibration_file the simulated camera's calibration in the bands' plane", read_only=True,
                  choices=COLOR_PRESETS),
    SIM_CONFIG_FILE,
    ParameterSpec("frame_id", "", "frame of the outputs; empty = the calibration's frame_id", read_only=True),
    ParameterSpec("path_max_poses", 5000, "longest trail kept in robot_path", 2, 1000000, read_only=True),
    ParameterSpec("path_min_step_m", 0.002, "a trail point is added after this much motion, m", 0.0, 10.0,
                  read_only=True),
    ParameterSpec("lost_after_s", 0.5, "frames arriving without a pose this long = WARN 'robot out of the "
                  "camera's view' (with the last seen position) on /diagnostics, s", 0.01, 3600.0, read_only=True),
    ParameterSpec("image_timeout_s", 1.0, "no image this long = ERROR 'camera silent' on /diagnostics, s",
                  0.01, 3600.0, read_only=True),
    ParameterSpec("diagnostics_period_s", 1.0, "period of the /diagnostics report, s", 0.05, 60.0, read_only=True),
)


def tracker_config(params: dict[str, Any]) -> TrackerConfig:
    """The tracker settings from the node's parameters, with the ``color_preset`` applied."""
    config = TrackerConfig.from_dict(params, "camera_tracker")
    preset = params.get("color_preset", "")
    if not preset:
        return config
    if preset != SIM_COLOR_PRESET:
        raise ConfigurationError(f"color_preset is {preset!r}; expected one of {list(COLOR_PRESETS)}.")
    from srs_ros.sim.camera import band_tracker_config
    from srs_ros.sim.config import load_sim_config

    bands = band_tracker_config(load_sim_config(params.get(SIM_CONFIG_FILE.name) or None).camera)
    return dataclasses.replace(config, detector="color", tail_color=bands.tail_color, head_color=bands.head_color)


def tracking_status(view: ViewStatus, name: str, hardware_id: str, values: dict[str, Any]) -> DiagnosticStatus:
    """The tracker's DiagnosticStatus: the view's level and message, its key/values after ``values``."""
    return diagnostic_status(name, hardware_id, view.level, view.message, {**values, **view.values()})


def sim_band_calibration(sim_config_file: str | None = None):
    """The simulated camera's calibration in the plane of its bands (one skin radius above the floor).

    A lab calibrates with its markers' height in mind; the simulated bands ride on the body's axis.
    ``sim_config_file``: the simulated robot's config (None: the package's).
    """
    from srs_ros.sim.camera import OverheadCamera
    from srs_ros.sim.config import load_sim_config

    config = load_sim_config(sim_config_file or None)
    return OverheadCamera(config).calibration_at_height(config.body.skin_radius_m)


# ------------------------------------------------------------------------------------------
# The node
# ------------------------------------------------------------------------------------------
class CameraTrackerNode(Node):
    """Wires images in and pose, twist, path and diagnostics out around a :class:`Tracker`."""

    def __init__(self):
        """Declare parameters, load the calibration, start the subscription or the video reader."""
        super().__init__("camera_tracker")
        declare_parameters(self, PARAMETERS)
        p = {spec.name: self.get_parameter(spec.name).value for spec in PARAMETERS}
        calibration_file = p["calibration_file"] or None
        if p["color_preset"] == SIM_COLOR_PRESET and calibration_file is None:
            self.calibration = sim_band_calibration(p[SIM_CONFIG_FILE.name])
        else:
            self.calibration = load_calibration(calibration_file)
        self.tracker = Tracker(self.calibration, tracker_config(p))
        self.frame_id = p["frame_id"] or self.calibration.frame_id
        self.path_max_poses = int(p["path_max_poses"])
        self.path_min_step_m = float(p["path_min_step_m"])
        self._warn_renamed_parameters()

        self.pose_pub = self.create_publisher(PoseStamped, POSE_TOPIC, 10)
        self.twist_pub = self.create_publisher(TwistStamped, TWIST_TOPIC, 10)
        self.path_pub = self.create_publisher(PathMsg, PATH_TOPIC, 1)
        self.diag_pub = self.create_publisher(DiagnosticArray, DIAGNOSTICS_TOPIC, 10)
        self.path = PathMsg()
        self.path.header.frame_id = self.frame_id
        self._path_changed = False
        self.failed_reads = 0  # a camera source's failed reads in a row

        self.frames = 0
        self.tracked_frames = 0
        self.refused_frames = 0
        self.last_refusal_log_s = -math.inf  # when a refusal was last logged (steady clock, s)
        self.last_result: TrackResult | None = None
        self.last_state = None

        self.capture: cv2.VideoCapture | None = None
        self.source = str(p["source"])
        #: The status this node publishes on /diagnostics is named ``status_name``, for ``hardware_id``.
        self.status_name = f"{self.get_name()}: {STATUS_NAME_SUFFIX}"
        self.hardware_id = self.source or self.resolve_topic_name(IMAGE_TOPIC)
        where = f"source {self.source!r}" if self.source else self.hardware_id
        self.watch = ViewWatch(float(p["lost_after_s"]), float(p["image_timeout_s"]), time.monotonic(),
                               self.frame_id, where)
        if self.source:
            self._open_source(self.source, float(p["source_rate_hz"]), bool(p["loop"]))
        else:
            self.create_subscription(Image, IMAGE_TOPIC, self.on_image, qos_profile_sensor_data)
        # On the steady clock, as every node's status: with use_sim_time a ROS-clock timer stops with /clock, and
        # a simulator that stalls or dies is exactly when "camera silent" must still be said.
        steady_timer(self, float(p["diagnostics_period_s"]), self.publish_diagnostics)
        steady_timer(self, PATH_PERIOD_S, self._publish_path)
        self.get_logger().info(
            f"tracking {self.tracker.describe_markers()} from {where}; calibration {self.calibration.source} "
            f"(reprojection rms {self.calibration.rms_error_mm:.2f} mm), frame '{self.frame_id}'"
        )

    def _warn_renamed_parameters(self) -> None:
        given = getattr(self, "_parameter_overrides", {})  # rclpy's start-up values, declared or not
        for old, new in RENAMED_PARAMETERS.items():
            if old in given:
                self.get_logger().warning(f"parameter {old} is no longer used and is ignored; set {new} instead")

    # -- inputs ------------------------------------------------------------------------------------
    def _open_source(self, source: str, rate_hz: float, loop: bool) -> None:
        is_camera = source.isdigit()
        if not is_camera and not Path(source).is_file():
            raise ConfigurationError(f"source {source!r} is neither a camera index nor an existing video file.")
        self.capture = cv2.VideoCapture(int(source) if is_camera else source)
        if not self.capture.isOpened():
            raise ConfigurationError(f"OpenCV cannot open source {source!r}; check the path, codec or camera index.")
        self.source_is_camera, self.loop = is_camera, loop
        fps = rate_hz or self.capture.get(cv2.CAP_PROP_FPS) or 30.0
        self.source_start_s = stamp_to_seconds(self.get_clock().now().to_msg())
        self.last_source_stamp_s = self.source_start_s
        self.source_frame_period_s = 1.0 / (self.capture.get(cv2.CAP_PROP_FPS) or fps)
        self.source_timer = self.create_timer(1.0 / fps, self.on_source_timer)

    def on_source_timer(self) -> None:
        """Read one frame of the video/camera and track it."""
        ok, frame = self.capture.read()
        if not ok and self.loop and not self.source_is_camera:
            self.capture.set(cv2.CAP_PROP_POS_FRAMES, 0)
            # The next pass continues the file's time line, so stamps never run backwards.
            self.source_start_s = self.last_source_stamp_s + self.source_frame_period_s
            self.tracker.velocity_filter.reset()
            ok, frame = self.capture.read()
        if not ok and self.source_is_camera:  # a live camera goes on: one failed read stopped it for good (a review)
            self._camera_read_failed()
            return
        if not ok:
            self.get_logger().info(f"source {self.source!r}: no more frames; tracking stopped.")
            self.source_timer.cancel()
            return
        self.failed_reads = 0
        if self.source_is_camera:
            stamp = self.get_clock().now().to_msg()
        else:
            self.last_source_stamp_s = self.source_start_s + self.capture.get(cv2.CAP_PROP_POS_MSEC) / 1000.0
            stamp = seconds_to_stamp(self.last_source_stamp_s)
        self.track(frame, stamp)

    def _camera_read_failed(self) -> None:
        self.failed_reads += 1
        self.get_logger().warning(f"camera {self.source!r}: a frame could not be read ({self.failed_reads} in a row); "
                                  "trying on", throttle_duration_sec=5.0)
        if self.failed_reads % CAMERA_REOPEN_AFTER == 0:
            self.capture.release()
            self.capture = cv2.VideoCapture(int(self.source))
            self.get_logger().warning(f"camera {self.source!r}: opened again after {self.failed_reads} failed reads"
                                      + ("" if self.capture.isOpened() else " (it did not open; trying on)"))

    def on_image(self, msg: Image) -> None:
        """Track one received image; a malformed one is refused with the reason and tracking goes on."""
        try:
            frame = image_msg_to_array(msg)
        except InvalidInputError as exc:
            self.refuse(str(exc))
            return
        try:
            self.track(frame, msg.header.stamp)
        except Exception as exc:  # a callback must never stop the tracker; this frame is skipped
            self.refuse(f"unexpected error, please report: {type(exc).__name__}: {exc}")

    def refuse(self, reason: str) -> None:
        """A frame arrived that cannot be tracked: count it, say why on /diagnostics and in the log.

        The log gets one line every :data:`REFUSAL_LOG_PERIOD_S` at most (not one per frame), with the newest reason;
        /diagnostics says the newest reason at once.
        """
        now = time.monotonic()
        self.refused_frames += 1
        self.watch.refused(now, reason)
        if now - self.last_refusal_log_s >= REFUSAL_LOG_PERIOD_S:
            self.last_refusal_log_s = now
            self.get_logger().error(f"image refused: {reason} ({self.refused_frames} frames refused so far)")
        if self.watch.status(time.monotonic()).state != self.last_state:
            self.publish_diagnostics()

    # -- outputs -----------------------------------------------------------------------------------
    def track(self, frame: np.ndarray, stamp: Time) -> None:
        """Run the tracker on a frame and publish what it found (nothing when a marker is missing or it is refused)."""
        try:
            result = self.tracker.process(frame, stamp_to_seconds(stamp))
        except InvalidInputError as exc:  # expected: a frame of the wrong size or shape; the reason says which
            self.refuse(str(exc))
            return
        now = time.monotonic()
        self.frames += 1
        self.last_result = result
        self.watch.frame(now, result)
        if result.tracked:
            self.tracked_frames += 1
            self._publish_pose(result, stamp)
        if self.watch.status(now).state != self.last_state:
            self.publish_diagnostics()

    def _publish_pose(self, result: TrackResult, stamp: Time) -> None:
        x, y, yaw = (float(v) for v in result.pose)
        pose = PoseStamped()
        pose.header.stamp, pose.header.frame_id = stamp, self.frame_id
        pose.pose.position.x, pose.pose.position.y = x, y
        q = yaw_to_quaternion(yaw)
        pose.pose.orientation.z, pose.pose.orientation.w = float(q[2]), float(q[3])
        self.pose_pub.publish(pose)
        if result.velocity is not None:
            twist = TwistStamped()
            twist.header = pose.header
            twist.twist.linear.x, twist.twist.linear.y = float(result.velocity[0]), float(result.velocity[1])
            twist.twist.angular.z = float(result.velocity[2])
            self.twist_pub.publish(twist)
        last = self.path.poses[-1].pose.position if self.path.poses else None
        if last is None or np.hypot(x - last.x, y - last.y) >= self.path_min_step_m:
            self.path.poses.append(pose)
            del self.path.poses[:-self.path_max_poses]
            self.path.header.stamp = stamp
            self._path_changed = True

    def _publish_path(self) -> None:
        if self._path_changed:
            self._path_changed = False
            self.path_pub.publish(self.path)

    def publish_diagnostics(self) -> None:
        """Publish the tracking status on /diagnostics (also at once whenever its state changes)."""
        view = self.watch.status(time.monotonic())
        self.last_state = view.state
        values: dict[str, Any] = {
            "frames": self.frames, "tracked_frames": self.tracked_frames, "refused_frames": self.refused_frames,
            "markers": self.tracker.describe_markers(), "frame_id": self.frame_id,
            "calibration_rms_mm": f"{self.calibration.rms_error_mm:.3f}",
        }
        if self.last_result is not None:
            values["seen"] = ",".join(sorted(self.last_result.markers_px)) or "none"
        status = tracking_status(view, self.status_name, self.hardware_id, values)
        self.diag_pub.publish(diagnostic_array([status], self.get_clock().now().to_msg()))

    def destroy_node(self) -> None:
        """Release the video source, then the ROS entities."""
        if self.capture is not None:
            self.capture.release()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """Console script ``camera_tracker``; a bad calibration or source exits with status 2 and the reason."""
    try:
        return run_node(CameraTrackerNode, args)
    except SrsError as exc:
        print(f"camera_tracker: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
