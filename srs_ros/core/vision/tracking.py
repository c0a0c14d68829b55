"""Pose and velocity of the robot from an overhead camera: marker detection, floor projection, smoothing.

The paper tracked the SRS with a fixed camera and perspective projection onto the floor (Sec. IV) and
reports a traveling velocity = X and Y displacement / experiment time, in cm/s (Table I). Here a head
and a tail marker (ArUco by default, or coloured blobs) are found in each frame, mapped to the floor
through the calibration (:mod:`srs_ros.core.vision.camera_calibration`: lens distortion removed when the
file has the camera's intrinsics, then the homography), and give the pose
``(x_m, y_m, yaw_rad)``: position at a configurable point between tail and head, heading from tail to
head. A frame where either marker is missing gives no pose, never a guess
(:mod:`srs_ros.core.vision.view` tells such frames apart for ``camera_tracker``'s ``/diagnostics``). The
detectors live in :mod:`srs_ros.core.vision.detectors`. OpenCV and NumPy only.

Markers are assumed to lie in the calibrated plane; a marker raised ``h`` above it by a camera at height
``H`` appears displaced by ``h/H`` of its distance from the camera's nadir, so calibrate at marker height.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from srs_ros.core.errors import ConfigurationError, InvalidInputError
from srs_ros.core.schema import Field, Table, refusal
from srs_ros.core.vision import aruco as aruco_ids
from srs_ros.core.vision.aruco import dictionary as aruco_dictionary  # noqa: F401 (public name)
from srs_ros.core.vision.camera_calibration import CameraCalibration
from srs_ros.core.vision.detectors import (  # noqa: F401 (also public here)
    DEFAULT_ARUCO_DICTIONARY,
    SV_MAX,
    ArucoMarkerDetector,
    ColorBlobDetector,
    ColorRange,
    MarkerDetection,
    hsv_range_problem,
    quad_centre,
    to_gray,
)
from srs_ros.core.vision.homography import apply_homography_keeping_nan


# ------------------------------------------------------------------------------------------
# Geometry: pose from head and tail, batched
# ------------------------------------------------------------------------------------------
def pose_from_markers(tail_xy_m: Any, head_xy_m: Any, position_ratio: float = 0.5) -> np.ndarray:
    """Pose ``(x_m, y_m, yaw_rad)`` (..., 3) from tail and head marker centres (..., 2) on the floor.

    Position is ``tail + position_ratio * (head - tail)`` (0 = tail, 0.5 = midpoint, 1 = head); yaw is
    the heading of the tail -> head vector, ``atan2`` in (-pi, pi]. Example: tail (0, 0), head (0, 0.4)
    gives (0, 0.2, pi/2).
    """
    tail = np.asarray(tail_xy_m, dtype=np.float64)
    head = np.asarray(head_xy_m, dtype=np.float64)
    if tail.shape != head.shape or tail.shape[-1:] != (2,):
        raise InvalidInputError(f"tail {tail.shape} and head {head.shape} must both be (..., 2) floor points.")
    delta = head - tail
    position = tail + position_ratio * delta
    yaw = np.arctan2(delta[..., 1], delta[..., 0])
    return np.concatenate([position, yaw[..., None]], axis=-1)


def yaw_to_quaternion(yaw_rad: Any) -> np.ndarray:
    """Quaternion (x, y, z, w) (..., 4) of a rotation by ``yaw_rad`` about +Z."""
    half = 0.5 * np.asarray(yaw_rad, dtype=np.float64)
    zeros = np.zeros_like(half)
    return np.stack([zeros, zeros, np.sin(half), np.cos(half)], axis=-1)


def wrap_angle(angle_rad: Any) -> np.ndarray:
    """Angles wrapped to [-pi, pi)."""
    return (np.asarray(angle_rad, dtype=np.float64) + math.pi) % (2.0 * math.pi) - math.pi


# ------------------------------------------------------------------------------------------
# Marker detection
# ------------------------------------------------------------------------------------------
def window_slope(time_s: Any, values: Any) -> np.ndarray:
    """Least-squares slope d(values)/dt (k,) of samples ``values`` (n, k) at ``time_s`` (n,).

    A straight-line fit over the window is the smoothed derivative: it averages out per-frame detection
    noise, and for a constant velocity it is exact. Needs two or more distinct times.
    """
    t = np.asarray(time_s, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64).reshape(len(t), -1)
    dt = t - t.mean()
    denom = float(dt @ dt)
    if len(t) < 2 or denom <= 0:
        raise InvalidInputError("a slope needs at least two samples at different times.")
    return dt @ (v - v.mean(axis=0)) / denom


class VelocityFilter:
    """Smoothed planar velocity ``(vx_m_s, vy_m_s, yaw_rate_rad_s)`` of the poses of the last ``window_s``.

    Yaw is unwrapped so a heading crossing +-pi does not give a spike. A gap longer than ``max_gap_s``
    (markers lost) restarts the window: no velocity is reported across a gap.
    """

    def __init__(self, window_s: float = 0.5, max_gap_s: float = 0.5, min_samples: int = 3):
        """``window_s`` sets the smoothing (longer = smoother, more lag)."""
        if not (window_s > 0 and max_gap_s > 0 and min_samples >= 2):
            raise ConfigurationError(
                f"velocity window {window_s} s, gap {max_gap_s} s, min samples {min_samples}; "
                "expected window > 0, gap > 0, min samples >= 2."
            )
        self.window_s, self.max_gap_s, self.min_samples = float(window_s), float(max_gap_s), int(min_samples)
        self._samples: deque[tuple[float, float, float, float]] = deque()

    def reset(self) -> None:
        """Forget every sample (e.g. when the markers are lost)."""
        self._samples.clear()

    def update(self, time_s: float, pose: Sequence[float]) -> np.ndarray | None:
        """Add a pose sample; return the smoothed velocity (3,) or None while the window is too short."""
        if self._samples and (time_s - self._samples[-1][0] > self.max_gap_s or time_s <= self._samples[-1][0]):
            self.reset()
        yaw = float(pose[2])
        if self._samples:
            yaw = self._samples[-1][3] + float(wrap_angle(yaw - self._samples[-1][3]))
        self._samples.append((float(time_s), float(pose[0]), float(pose[1]), yaw))
        while self._samples[0][0] < time_s - self.window_s:
            self._samples.popleft()
        if len(self._samples) < self.min_samples:
            return None
        data = np.array(self._samples)
        return window_slope(data[:, 0], data[:, 1:])


# ------------------------------------------------------------------------------------------
# Traveling velocity (paper Table I)
# ------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class TravelingVelocity:
    """The paper's traveling velocity of one run: X and Y displacement over the run time, in cm/s."""

    vx_cm_s: float
    vy_cm_s: float
    displacement_x_m: float
    displacement_y_m: float
    duration_s: float
    samples: int

    @property
    def speed_cm_s(self) -> float:
        """Net speed: straight-line displacement / time (cm/s)."""
        return math.hypot(self.vx_cm_s, self.vy_cm_s)

    def table_text(self) -> str:
        """``v_x / v_y`` as Table I prints it (magnitudes, cm/s)."""
        return f"{abs(self.vx_cm_s):.2f} / {abs(self.vy_cm_s):.2f} cm/s"


def traveling_velocity(time_s: Any, x_m: Any, y_m: Any, end_window_s: float = 0.0) -> TravelingVelocity:
    """Traveling velocity of a track (paper Table I): X and Y displacement divided by the run time.

    Table I's caption: "velocity is computed by dividing the mean of the X and Y displacements by the
    experiment time". Here the displacement runs from the mean position over the first ``end_window_s``
    of the track to the mean over the last ``end_window_s`` (0 = the first and last samples), and the
    time between the mean times of the two windows, so averaging the ends removes detection noise
    without biasing a constant speed. NaN samples (no pose) are skipped. Components are signed (floor
    frame); :meth:`TravelingVelocity.table_text` gives Table I's magnitudes.
    """
    t = np.asarray(time_s, dtype=np.float64).ravel()
    xy = np.column_stack([np.asarray(x_m, dtype=np.float64).ravel(), np.asarray(y_m, dtype=np.float64).ravel()])
    if len(t) != len(xy):
        raise InvalidInputError(f"{len(t)} times but {len(xy)} positions; expected one position per time.")
    valid = np.isfinite(t) & np.all(np.isfinite(xy), axis=1)
    t, xy = t[valid], xy[valid]
    if len(t) < 2 or t[-1] <= t[0]:
        raise InvalidInputError(
            f"{len(t)} valid samples spanning {t[-1] - t[0] if len(t) else 0:.3f} s; a traveling velocity needs "
            "two or more tracked frames at different times (were the markers ever seen?)."
        )
    first = t <= t[0] + end_window_s
    last = t >= t[-1] - end_window_s
    duration = float(t[last].mean() - t[first].mean())
    if duration <= 0:
        raise InvalidInputError(f"end windows of {end_window_s} s overlap the whole track; use a shorter window.")
    disp = xy[last].mean(axis=0) - xy[first].mean(axis=0)
    return TravelingVelocity(100.0 * disp[0] / duration, 100.0 * disp[1] / duration, float(disp[0]), float(disp[1]),
                             duration, int(len(t)))


# ------------------------------------------------------------------------------------------
# The per-frame tracker
# ------------------------------------------------------------------------------------------
#: The detectors a tracker can use.
DETECTORS = ("aruco", "color")
_HSV = {"item": int, "length": 3, "minimum": 0, "maximum": SV_MAX}  # hue: at most HUE_MAX (hsv_range_problem)

#: The tracker's options (the ``camera_tracker`` node's tracking parameters), with their defaults and ranges.
TRACKER_TABLE = Table("", (
    Field("detector", str, "aruco", choices=DETECTORS, description="marker kind: 'aruco' or 'color'"),
    Field("aruco_dictionary", str, DEFAULT_ARUCO_DICTIONARY, nonempty=True,
          description="cv2.aruco predefined dictionary name"),
    Field("tail_marker_id", int, 0, 0, 1023, description="ArUco id of the tail marker"),
    Field("head_marker_id", int, 1, 0, 1023, description="ArUco id of the head marker"),
    Field("tail_color_hsv_low", list, [100, 120, 70], **_HSV,
          description="colour detector: tail HSV lower bound (OpenCV scale)"),
    Field("tail_color_hsv_high", list, [130, 255, 255], **_HSV, description="colour detector: tail HSV upper bound"),
    Field("head_color_hsv_low", list, [170, 120, 70], **_HSV,
          description="colour detector: head HSV lower bound (H wraps)"),
    Field("head_color_hsv_high", list, [10, 255, 255], **_HSV, description="colour detector: head HSV upper bound"),
    Field("min_blob_area_px", float, 20.0, 1.0, 1e7, description="colour detector: smallest blob, px^2"),
    Field("position_ratio", float, 0.5, 0.0, 1.0, description="pose point between tail (0) and head (1)"),
    Field("velocity_window_s", float, 0.5, 0.01, 60.0, description="velocity smoothing window, s; it must span "
          "at least two frame periods (three frames: 0.07 s at 30 fps), or no velocity is given (a review)"),
    Field("max_gap_s", float, 0.5, 0.01, 60.0,
          description="longest gap between tracked frames inside one velocity window, s"),
    Field("roi_margin_px", int, 40, 0, 10000,
          description="search margin around the last markers, px (0 = whole frame)"),
    Field("max_marker_spacing_m", float, 2.0, 0.0, 100.0, above_minimum=True,
          description="head and tail farther apart than this on the floor are a false detection, m"),
), description="the tracker's options")


def _color(end: str) -> ColorRange:
    """The default HSV box of the ``end`` ("tail", "head") marker."""
    return ColorRange(tuple(TRACKER_TABLE[f"{end}_color_hsv_low"].default),
                      tuple(TRACKER_TABLE[f"{end}_color_hsv_high"].default))


@dataclass(frozen=True)
class TrackerConfig:
    """What to look for and how to smooth it (the ``camera_tracker`` node's parameters).

    The defaults are :data:`TRACKER_TABLE`'s; :meth:`from_dict` builds it from options checked against the table.
    """

    detector: str = TRACKER_TABLE["detector"].default
    aruco_dictionary: str = TRACKER_TABLE["aruco_dictionary"].default
    tail_marker_id: int = TRACKER_TABLE["tail_marker_id"].default
    head_marker_id: int = TRACKER_TABLE["head_marker_id"].default
    tail_color: ColorRange = _color("tail")
    head_color: ColorRange = _color("head")
    min_blob_area_px: float = TRACKER_TABLE["min_blob_area_px"].default
    position_ratio: float = TRACKER_TABLE["position_ratio"].default
    velocity_window_s: float = TRACKER_TABLE["velocity_window_s"].default
    max_gap_s: float = TRACKER_TABLE["max_gap_s"].default
    roi_margin_px: int = TRACKER_TABLE["roi_margin_px"].default
    max_marker_spacing_m: float = TRACKER_TABLE["max_marker_spacing_m"].default

    def __post_init__(self):
        if self.detector not in DETECTORS:
            raise refusal("the tracker settings", "detector", self.detector, f"one of {list(DETECTORS)}")
        _check_markers(vars(self), "the tracker settings")

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: str = "the tracker settings") -> TrackerConfig:
        """Build from a flat mapping of options (node parameters: keys the table does not know are left alone).

        Each option is checked against :data:`TRACKER_TABLE` (colours as ``[h, s, v]`` lists, hue 0..179), the
        ArUco ids against the dictionary's; a refusal names ``where``, the option, its value and what is expected.
        """
        values = TRACKER_TABLE.read({key: value for key, value in data.items() if key in TRACKER_TABLE}, where)
        _check_markers(values, where)
        for end in ("tail", "head"):
            problem = hsv_range_problem(values[f"{end}_color_hsv_low"], values[f"{end}_color_hsv_high"])
            if problem is not None:
                key = f"{end}_color_hsv_{problem[0].split('_')[0]}"
                raise refusal(where, key, values[key], problem[1])
        colors = {f"{end}_color": ColorRange(values.pop(f"{end}_color_hsv_low"), values.pop(f"{end}_color_hsv_high"))
                  for end in ("tail", "head")}
        return cls(**values, **colors)


def _check_markers(values: Mapping[str, Any], where: str) -> None:
    """Refuse equal tail and head ids and, for the ArUco detector, ids its dictionary does not hold."""
    if values["tail_marker_id"] == values["head_marker_id"]:
        raise refusal(where, "head_marker_id", values["head_marker_id"],
                      f"an id other than tail_marker_id {values['tail_marker_id']} (the two markers must differ)")
    if values["detector"] != "aruco":
        return
    for key in ("tail_marker_id", "head_marker_id"):
        expected = aruco_ids.expected_marker_id(values["aruco_dictionary"], values[key])
        if expected is not None:
            raise refusal(where, key, values[key], expected)


@dataclass(frozen=True)
class TrackResult:
    """The outcome of one frame: the pose (None unless both markers were seen) and what was seen."""

    time_s: float
    pose: np.ndarray | None
    velocity: np.ndarray | None
    markers_px: dict[str, np.ndarray] = field(default_factory=dict)
    markers_m: dict[str, np.ndarray] = field(default_factory=dict)
    message: str = ""

    @property
    def tracked(self) -> bool:
        """True when the frame gave a pose."""
        return self.pose is not None


class Tracker:
    """Frame in, pose out: detect head and tail, project to the floor, smooth the velocity."""

    def __init__(self, calibration: CameraCalibration, config: TrackerConfig | None = None):
        """Combine a floor calibration with a marker configuration."""
        self.calibration = calibration
        self.config = config or TrackerConfig()
        cfg = self.config
        if cfg.detector == "aruco":
            self.detector: ArucoMarkerDetector | ColorBlobDetector = ArucoMarkerDetector(
                cfg.aruco_dictionary, {"tail": cfg.tail_marker_id, "head": cfg.head_marker_id}, cfg.roi_margin_px)
        else:
            self.detector = ColorBlobDetector({"tail": cfg.tail_color, "head": cfg.head_color}, cfg.min_blob_area_px,
                                             cfg.roi_margin_px)
        self.velocity_filter = VelocityFilter(cfg.velocity_window_s, cfg.max_gap_s)

    def describe_markers(self) -> str:
        """Human-readable names of the markers looked for."""
        cfg = self.config
        if cfg.detector == "aruco":
            return f"ArUco {cfg.aruco_dictionary} tail id {cfg.tail_marker_id}, head id {cfg.head_marker_id}"
        return f"colour blobs tail {cfg.tail_color}, head {cfg.head_color}"

    def _floor_centre(self, detection: MarkerDetection) -> np.ndarray:
        """Floor position of a marker's centre; with lens distortion, from its undistorted corners.

        The centre of a square is projectively exact only in an undistorted image (:func:`quad_centre`).
        """
        calibration = self.calibration
        if calibration.intrinsics is None or not isinstance(self.detector, ArucoMarkerDetector):
            return calibration.image_to_floor(detection.centre_px)
        centre = quad_centre(calibration.undistort_px(detection.corners_px))
        return apply_homography_keeping_nan(calibration.homography_image_to_floor, centre)

    def _reject(self) -> None:
        """No pose from this frame: the velocity starts afresh and the next frame is searched whole."""
        self.velocity_filter.reset()
        self.detector.forget()

    def check_frame(self, image: np.ndarray) -> None:
        """Refuse (:class:`InvalidInputError`, with the reason) a frame this tracker cannot track.

        A frame must be uint8 (as cameras and cv_bridge give), non-empty, mono
        ``(h, w)`` / ``(h, w, 1)`` or BGR ``(h, w, 3)`` (BGR only for the colour detector), and the size the
        calibration was made at (``image_size_px``): the homography maps that image's pixels, so a frame of
        another size would give wrong poses.
        """
        image = np.asarray(image)
        if image.dtype != np.uint8:
            raise InvalidInputError(f"image dtype is {image.dtype}; expected uint8.")
        colour = isinstance(self.detector, ColorBlobDetector)
        channels = image.shape[2] if image.ndim == 3 else 1 if image.ndim == 2 else 0
        if image.ndim not in (2, 3) or channels not in ((3,) if colour else (1, 3)) or 0 in image.shape[:2]:
            expected = "a BGR (h, w, 3) image (the colour detector needs colour)" if colour else \
                "a mono (h, w) or BGR (h, w, 3) image"
            raise InvalidInputError(f"image has shape {image.shape}; expected {expected} of at least 1 x 1 px.")
        size = self.calibration.image_size_px
        if size is not None and (image.shape[1], image.shape[0]) != tuple(size):
            raise InvalidInputError(
                f"image is {image.shape[1]} x {image.shape[0]} px but the calibration {self.calibration.source} is "
                f"for {size[0]} x {size[1]} px (image_size_px); set the camera to {size[0]} x {size[1]} or "
                "calibrate it at the new size (srs_calibrate_camera).")

    def process(self, image: np.ndarray, time_s: float) -> TrackResult:
        """Track one frame (BGR or mono uint8) taken at ``time_s``; no pose unless both markers are seen.

        A frame :meth:`check_frame` refuses raises :class:`InvalidInputError` naming what is wrong.
        """
        self.check_frame(image)
        if isinstance(self.detector, ArucoMarkerDetector):
            found = self.detector.detect(to_gray(image))
        else:
            found = self.detector.detect(image)
        markers_m = {k: self._floor_centre(d) for k, d in found.items()}
        # A marker the lens model cannot undistort (NaN on the floor) counts as not seen, never as a guess.
        markers_m = {k: xy for k, xy in markers_m.items() if np.all(np.isfinite(xy))}
        markers_px = {k: found[k].centre_px for k in markers_m}
        missing = [k for k in ("tail", "head") if k not in markers_m]
        if missing:
            self._reject()
            return TrackResult(time_s, None, None, markers_px, markers_m, f"not seen: {', '.join(missing)}")
        spacing = float(np.linalg.norm(markers_m["head"] - markers_m["tail"]))
        if not (np.isfinite(spacing) and 0 < spacing <= self.config.max_marker_spacing_m):
            self._reject()
            return TrackResult(time_s, None, None, markers_px, markers_m,
                               f"head-tail spacing {spacing:.3f} m outside (0, {self.config.max_marker_spacing_m}] m")
        pose = pose_from_markers(markers_m["tail"], markers_m["head"], self.config.position_ratio)
        velocity = self.velocity_filter.update(time_s, pose)
        return TrackResult(time_s, pose, velocity, markers_px, markers_m, "tracked")
