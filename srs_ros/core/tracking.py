"""Pose and velocity of the robot from an overhead camera: marker detection, floor projection, smoothing.

The paper tracked the SRS with a fixed camera and perspective projection onto the floor (Sec. IV) and
reports a traveling velocity = X and Y displacement / experiment time, in cm/s (Table I). Here a head
and a tail marker (ArUco by default, or coloured blobs) are found in each frame, mapped to the floor
through the calibration (:mod:`srs_ros.core.camera_calibration`: lens distortion removed when the
file has the camera's intrinsics, then the homography), and give the pose
``(x_m, y_m, yaw_rad)``: position at a configurable point between tail and head, heading from tail to
head. A frame where either marker is missing gives no pose, never a guess; :class:`ViewWatch` tells the
frames without a pose apart (markers lost for a moment, robot out of the camera's view, camera silent) for
``camera_tracker``'s ``/diagnostics``. OpenCV and NumPy only.

Markers are assumed to lie in the calibrated plane; a marker raised ``h`` above it by a camera at height
``H`` appears displaced by ``h/H`` of its distance from the camera's nadir, so calibrate at marker height.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from collections import deque
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import cv2
import numpy as np

from srs_ros.core import aruco
from srs_ros.core.aruco import dictionary as aruco_dictionary  # noqa: F401 (public name)
from srs_ros.core.camera_calibration import CameraCalibration, apply_homography
from srs_ros.core.errors import ConfigurationError, InvalidInputError

#: Default ArUco dictionary: 4 x 4 bits survive the small image size of a 4 cm marker seen from 1 m.
DEFAULT_ARUCO_DICTIONARY = "DICT_4X4_50"


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
@dataclass(frozen=True)
class MarkerDetection:
    """One marker found in an image: its centre and outline in pixels."""

    key: str
    centre_px: np.ndarray
    corners_px: np.ndarray


def quad_centre(corners_px: np.ndarray) -> np.ndarray:
    """Intersection of a quadrilateral's diagonals (..., 4, 2) -> (..., 2).

    A homography maps the centre of a square to the intersection of the diagonals of its image, so this
    is the projectively exact centre of a square marker (the corner mean is not).
    """
    p0, p1, p2, p3 = (corners_px[..., i, :] for i in range(4))
    d1, d2 = p2 - p0, p3 - p1
    cross = d1[..., 0] * d2[..., 1] - d1[..., 1] * d2[..., 0]
    w = p1 - p0
    t = (w[..., 0] * d2[..., 1] - w[..., 1] * d2[..., 0]) / np.where(cross == 0, np.nan, cross)
    centre = p0 + t[..., None] * d1
    return np.where(np.isfinite(centre), centre, corners_px.mean(axis=-2))


@dataclass
class _Seen:
    """Where a marker was last found: centre (px), image velocity (px per frame), side (px), frame number."""

    centre_px: np.ndarray
    velocity_px: np.ndarray
    side_px: float
    frame: int


class ArucoMarkerDetector:
    """Find ArUco markers by id with sub-pixel corners, in a fast pass and, for missed markers, a refined one.

    Fast pass: near the last detections (or the whole frame), one threshold window pair, the bits read at
    8 px per cell (OpenCV's default of 4 misreads the 3-4 px cells of a 4 cm marker seen obliquely from
    1 m: that alone lost a quarter of the frames of a tilted camera). Refined pass, only for markers the
    fast pass missed: a region around where each was last seen (moved on by its image velocity), upscaled
    2x and thresholded at several window sizes; a marker not seen for ``PREDICTION_FRAMES`` frames is
    searched for in the whole frame at several window sizes. A marker counts only when its id decodes:
    the prediction decides where to look, never what is reported.
    """

    #: Factor by which the regions of the refined pass are upscaled (cubic) before detection.
    REFINE_UPSCALE = 2
    #: Frames for which a marker's last position still guides the refined search.
    PREDICTION_FRAMES = 15

    def __init__(self, dictionary: str = DEFAULT_ARUCO_DICTIONARY, marker_ids: Mapping[str, int] | None = None,
                 roi_margin_px: int = 40):
        """``marker_ids`` names the ids to find, e.g. ``{"tail": 0, "head": 1}``."""
        self.marker_ids = dict(marker_ids or {"tail": 0, "head": 1})
        if len(set(self.marker_ids.values())) != len(self.marker_ids):
            raise ConfigurationError(f"marker ids {self.marker_ids} repeat; every marker needs its own id.")
        subpix = cv2.aruco.CORNER_REFINE_SUBPIX
        # One threshold window pair (not the default three) keeps 640x480 above 100 fps on one core.
        self._detector = aruco.MarkerDetector(dictionary, aruco.detector_parameters(
            cornerRefinementMethod=subpix, cornerRefinementWinSize=3, adaptiveThreshWinSizeMin=7,
            adaptiveThreshWinSizeMax=17, adaptiveThreshWinSizeStep=10, minMarkerPerimeterRate=0.02,
            perspectiveRemovePixelPerCell=8))
        self._refiner = aruco.MarkerDetector(dictionary, aruco.detector_parameters(
            cornerRefinementMethod=subpix, cornerRefinementWinSize=5, adaptiveThreshWinSizeMin=3,
            adaptiveThreshWinSizeMax=33, adaptiveThreshWinSizeStep=6, minMarkerPerimeterRate=0.01,
            perspectiveRemovePixelPerCell=8))
        self._id_to_key = {v: k for k, v in self.marker_ids.items()}
        self.roi_margin_px = int(roi_margin_px)
        self._last_box: tuple[int, int, int, int] | None = None
        self._seen: dict[str, _Seen] = {}
        self._frame = 0
        #: Markers found by the refined pass so far (the fast pass missed them).
        self.refined_count = 0

    def _detect(self, gray: np.ndarray, offset: tuple[int, int], detector: aruco.MarkerDetector | None = None,
                scale: float = 1.0) -> dict[str, MarkerDetection]:
        """Markers in ``gray`` (a crop at ``offset`` of the frame, upscaled by ``scale``), in frame pixels."""
        corners, ids = (detector or self._detector).detect(gray)
        found: dict[str, MarkerDetection] = {}
        for quad, marker_id in zip(corners, ids):
            key = self._id_to_key.get(int(marker_id))
            if key is None or key in found:
                continue
            quad = (quad + 0.5) / scale - 0.5 + offset  # pixel centres of the upscaled crop -> the frame's
            found[key] = MarkerDetection(key, quad_centre(quad), quad)
        return found

    def detect(self, gray: np.ndarray) -> dict[str, MarkerDetection]:
        """Markers found in a single-channel 8-bit image, by name; absent names were not seen."""
        self._frame += 1
        found: dict[str, MarkerDetection] = {}
        if self._last_box is not None and self.roi_margin_px > 0:
            x0, y0, x1, y1 = self._last_box
            found = self._detect(gray[y0:y1, x0:x1], (x0, y0))
        if len(found) < len(self.marker_ids):
            found = {**self._detect(gray, (0, 0)), **found}
        missing = [key for key in self.marker_ids if key not in found]
        if missing:
            refined = self._refine(gray, missing)
            self.refined_count += len(refined)
            found.update(refined)
        self._remember(found, gray.shape)
        return found

    def _refine(self, gray: np.ndarray, missing: list[str]) -> dict[str, MarkerDetection]:
        """The refined pass for the markers ``missing`` from the fast pass."""
        height, width = gray.shape[:2]
        found: dict[str, MarkerDetection] = {}
        for key in missing:
            seen = self._seen.get(key)
            if seen is None or self._frame - seen.frame > self.PREDICTION_FRAMES:
                return {k: d for k, d in self._detect(gray, (0, 0), self._refiner).items() if k in missing}
            frames = self._frame - seen.frame
            centre = seen.centre_px + seen.velocity_px * frames
            half = 2.0 * seen.side_px + 8.0 + 2.0 * frames * float(np.linalg.norm(seen.velocity_px))
            x0, y0 = (max(int(c - half), 0) for c in centre)
            x1, y1 = min(int(centre[0] + half) + 1, width), min(int(centre[1] + half) + 1, height)
            if x1 - x0 < 8 or y1 - y0 < 8:
                continue
            crop = cv2.resize(gray[y0:y1, x0:x1], None, fx=self.REFINE_UPSCALE, fy=self.REFINE_UPSCALE,
                              interpolation=cv2.INTER_CUBIC)
            detection = self._detect(crop, (x0, y0), self._refiner, self.REFINE_UPSCALE).get(key)
            if detection is not None:
                found[key] = detection
        return found

    def _remember(self, found: Mapping[str, MarkerDetection], shape: Sequence[int]) -> None:
        for key, detection in found.items():
            previous = self._seen.get(key)
            velocity = np.zeros(2)
            if previous is not None and self._frame - previous.frame <= self.PREDICTION_FRAMES:
                velocity = (detection.centre_px - previous.centre_px) / (self._frame - previous.frame)
            side = float(np.mean(np.linalg.norm(np.diff(detection.corners_px, axis=0, append=detection.corners_px[:1]),
                                                axis=1)))
            self._seen[key] = _Seen(detection.centre_px, velocity, side, self._frame)
        if len(found) != len(self.marker_ids):
            self._last_box = None
            return
        corners = np.concatenate([d.corners_px for d in found.values()])
        lo = np.floor(corners.min(axis=0)).astype(int) - self.roi_margin_px
        hi = np.ceil(corners.max(axis=0)).astype(int) + self.roi_margin_px
        self._last_box = (max(lo[0], 0), max(lo[1], 0), min(hi[0], shape[1]), min(hi[1], shape[0]))


@dataclass(frozen=True)
class ColorRange:
    """An HSV box (OpenCV scale: H 0-179, S and V 0-255); ``low[0] > high[0]`` wraps through red."""

    low_hsv: tuple[int, int, int]
    high_hsv: tuple[int, int, int]

    def __post_init__(self):
        for name in ("low_hsv", "high_hsv"):
            value = getattr(self, name)
            if len(value) != 3 or not all(0 <= int(v) <= 255 for v in value):
                raise ConfigurationError(f"colour range {name} is {value!r}; expected three integers in 0..255 (HSV).")


class ColorBlobDetector:
    """Find one blob per named colour range (largest connected blob above ``min_area_px``)."""

    def __init__(self, colors: Mapping[str, ColorRange], min_area_px: float = 20.0):
        """``colors`` maps marker names to HSV ranges, e.g. ``{"tail": ColorRange(...), "head": ...}``."""
        self.colors = dict(colors)
        self.min_area_px = float(min_area_px)
        self._kernel = np.ones((3, 3), np.uint8)

    def _mask(self, hsv: np.ndarray, rng: ColorRange) -> np.ndarray:
        low, high = np.array(rng.low_hsv, np.uint8), np.array(rng.high_hsv, np.uint8)
        if rng.low_hsv[0] <= rng.high_hsv[0]:
            return cv2.inRange(hsv, low, high)
        upper = cv2.inRange(hsv, low, np.array([179, high[1], high[2]], np.uint8))
        lower = cv2.inRange(hsv, np.array([0, low[1], low[2]], np.uint8), high)
        return cv2.bitwise_or(upper, lower)

    def detect(self, bgr: np.ndarray) -> dict[str, MarkerDetection]:
        """Blobs found in a BGR image, by name; the centre is the blob's intensity-weighted centroid."""
        if bgr.ndim != 3:
            raise InvalidInputError(f"colour-blob detection needs a 3-channel BGR image; got shape {bgr.shape}.")
        hsv = cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV)
        found: dict[str, MarkerDetection] = {}
        for key, rng in self.colors.items():
            mask = cv2.morphologyEx(self._mask(hsv, rng), cv2.MORPH_OPEN, self._kernel)
            count, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
            if count < 2:
                continue
            best = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
            if stats[best, cv2.CC_STAT_AREA] < self.min_area_px:
                continue
            x, y, w, h = (int(stats[best, i]) for i in range(4))
            moments = cv2.moments((labels[y:y + h, x:x + w] == best).astype(np.uint8), binaryImage=True)
            centre = np.array([x + moments["m10"] / moments["m00"], y + moments["m01"] / moments["m00"]])
            box = np.array([[x, y], [x + w, y], [x + w, y + h], [x, y + h]], dtype=np.float64)
            found[key] = MarkerDetection(key, centre, box)
        return found


# ------------------------------------------------------------------------------------------
# Velocity: least-squares slope over a sliding time window
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
@dataclass(frozen=True)
class TrackerConfig:
    """What to look for and how to smooth it (the ``camera_tracker`` node's parameters)."""

    detector: str = "aruco"
    aruco_dictionary: str = DEFAULT_ARUCO_DICTIONARY
    tail_marker_id: int = 0
    head_marker_id: int = 1
    tail_color: ColorRange = ColorRange((100, 120, 70), (130, 255, 255))
    head_color: ColorRange = ColorRange((170, 120, 70), (10, 255, 255))
    min_blob_area_px: float = 20.0
    position_ratio: float = 0.5
    velocity_window_s: float = 0.5
    max_gap_s: float = 0.5
    roi_margin_px: int = 40
    max_marker_spacing_m: float = 2.0

    def __post_init__(self):
        if self.detector not in ("aruco", "color"):
            raise ConfigurationError(f"detector is {self.detector!r}; expected 'aruco' or 'color'.")
        if self.tail_marker_id == self.head_marker_id:
            raise ConfigurationError(f"head and tail marker ids are both {self.head_marker_id}; they must differ.")

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> TrackerConfig:
        """Build from a flat mapping (node parameters or YAML); colours as ``[h, s, v]`` lists."""
        known = {f: data[f] for f in cls.__dataclass_fields__ if f in data and not f.endswith("_color")}
        for end in ("tail", "head"):
            low, high = data.get(f"{end}_color_hsv_low"), data.get(f"{end}_color_hsv_high")
            if low is not None and high is not None:
                known[f"{end}_color"] = ColorRange(tuple(int(v) for v in low), tuple(int(v) for v in high))
        return cls(**known)


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


def to_gray(image: np.ndarray) -> np.ndarray:
    """A single-channel 8-bit view of a BGR or mono image."""
    if image.ndim == 2:
        return image
    if image.ndim == 3 and image.shape[2] == 3:
        return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    if image.ndim == 3 and image.shape[2] == 1:
        return image[:, :, 0]
    raise InvalidInputError(f"image has shape {image.shape}; expected (h, w) mono or (h, w, 3) BGR.")


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
            self.detector = ColorBlobDetector({"tail": cfg.tail_color, "head": cfg.head_color}, cfg.min_blob_area_px)
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
        return apply_homography(calibration.homography_image_to_floor, centre)

    def process(self, image: np.ndarray, time_s: float) -> TrackResult:
        """Track one frame (BGR or mono uint8) taken at ``time_s``; no pose unless both markers are seen."""
        if image.dtype != np.uint8:
            raise InvalidInputError(f"image dtype is {image.dtype}; expected uint8.")
        if isinstance(self.detector, ArucoMarkerDetector):
            found = self.detector.detect(to_gray(image))
        else:
            found = self.detector.detect(image)
        markers_px = {k: d.centre_px for k, d in found.items()}
        markers_m = {k: self._floor_centre(d) for k, d in found.items()}
        missing = [k for k in ("tail", "head") if k not in found]
        if missing:
            self.velocity_filter.reset()
            return TrackResult(time_s, None, None, markers_px, markers_m, f"not seen: {', '.join(missing)}")
        spacing = float(np.linalg.norm(markers_m["head"] - markers_m["tail"]))
        if not (np.isfinite(spacing) and 0 < spacing <= self.config.max_marker_spacing_m):
            self.velocity_filter.reset()
            return TrackResult(time_s, None, None, markers_px, markers_m,
                               f"head-tail spacing {spacing:.3f} m outside (0, {self.config.max_marker_spacing_m}] m")
        pose = pose_from_markers(markers_m["tail"], markers_m["head"], self.config.position_ratio)
        velocity = self.velocity_filter.update(time_s, pose)
        return TrackResult(time_s, pose, velocity, markers_px, markers_m, "tracked")


# ------------------------------------------------------------------------------------------
# In view, out of view, camera silent: what the tracker says about the robot (camera_tracker's /diagnostics)
# ------------------------------------------------------------------------------------------
class ViewState(enum.Enum):
    """What the frames say about the robot, with the diagnostic level each state is reported at."""

    TRACKING = "tracking"
    MARKERS_LOST = "markers_lost"    # frames without a pose for less than ``lost_after_s`` (a hand, a glare)
    OUT_OF_VIEW = "out_of_view"      # frames without a pose for ``lost_after_s`` or longer
    NO_IMAGES = "no_images"          # no frame yet, for less than ``image_timeout_s`` since the start
    CAMERA_SILENT = "camera_silent"  # no frame for ``image_timeout_s``: the camera or its driver stopped

    @property
    def level(self) -> str:
        """``"OK"``, ``"WARN"`` or ``"ERROR"``: only a silent camera is a fault; a robot out of view is not."""
        return {"tracking": "OK", "camera_silent": "ERROR"}.get(self.value, "WARN")


@dataclass(frozen=True)
class ViewStatus:
    """The tracker's report at one moment: the state, a message for people, where the robot was last seen.

    ``last_seen_xy_m`` is the last published position (``frame_id``, normally the floor), ``last_seen_ago_s``
    how long before the report it was seen, ``last_image_ago_s`` the age of the newest frame (None: never).
    :meth:`values` and :meth:`from_values` carry it through ``/diagnostics`` key/values as text.
    """

    state: ViewState
    message: str = ""
    last_seen_xy_m: tuple[float, float] | None = None
    last_seen_ago_s: float | None = None
    last_image_ago_s: float | None = None
    frame_id: str = "floor"

    @property
    def level(self) -> str:
        """The diagnostic level of the state (``"OK"``, ``"WARN"``, ``"ERROR"``)."""
        return self.state.level

    @property
    def pose_current(self) -> bool:
        """True while poses still flow (tracking, or a short loss of markers); False out of view or camera silent."""
        return self.state in (ViewState.TRACKING, ViewState.MARKERS_LOST)

    def last_seen_text(self) -> str:
        """E.g. ``last seen 2.3 s ago at x 1.234 y -0.456 m (floor)``, or ``never seen``."""
        if self.last_seen_xy_m is None or self.last_seen_ago_s is None:
            return "never seen"
        x_m, y_m = self.last_seen_xy_m
        return f"last seen {self.last_seen_ago_s:.1f} s ago at x {x_m:.3f} y {y_m:.3f} m ({self.frame_id})"

    def summary(self) -> str:
        """One phrase for a status line when the robot's pose is not current ('' while it is)."""
        if self.state is ViewState.OUT_OF_VIEW:
            return f"robot out of the camera's view: {self.last_seen_text()}"
        if self.state is ViewState.CAMERA_SILENT:
            silent = "" if self.last_image_ago_s is None else f" for {self.last_image_ago_s:.1f} s"
            return f"camera silent: no images{silent}; robot {self.last_seen_text()}"
        if self.state is ViewState.NO_IMAGES:
            return "no camera images yet"
        return ""

    def aged(self, seconds: float) -> ViewStatus:
        """The same report ``seconds`` later (the ages grow; the state is what was reported)."""
        return dataclasses.replace(self, last_seen_ago_s=_later(self.last_seen_ago_s, seconds),
                                   last_image_ago_s=_later(self.last_image_ago_s, seconds))

    def values(self) -> dict[str, str]:
        """Key/values for ``/diagnostics`` (positions in m, ages in s; absent when unknown)."""
        values = {"view_state": self.state.value, "last_seen_frame_id": self.frame_id}
        if self.last_seen_xy_m is not None:
            values["last_seen_x_m"], values["last_seen_y_m"] = (f"{v:.4f}" for v in self.last_seen_xy_m)
        if self.last_seen_ago_s is not None:
            values["last_seen_ago_s"] = f"{self.last_seen_ago_s:.3f}"
        if self.last_image_ago_s is not None:
            values["last_image_ago_s"] = f"{self.last_image_ago_s:.3f}"
        return values

    @classmethod
    def from_values(cls, values: Mapping[str, str], message: str = "") -> ViewStatus | None:
        """The report back from :meth:`values` (extra keys ignored); None without a known ``view_state``."""
        try:
            state = ViewState(values.get("view_state", ""))
            x_m, y_m = _number(values, "last_seen_x_m"), _number(values, "last_seen_y_m")
            return cls(state, message, None if x_m is None or y_m is None else (x_m, y_m),
                       _number(values, "last_seen_ago_s"), _number(values, "last_image_ago_s"),
                       values.get("last_seen_frame_id", "floor"))
        except ValueError:  # not one of ours, or a number that is not one
            return None


def _later(age_s: float | None, seconds: float) -> float | None:
    return None if age_s is None else age_s + seconds


def _number(values: Mapping[str, str], key: str) -> float | None:
    return float(values[key]) if key in values else None


class ViewWatch:
    """Whether the robot is in the camera's view, from each frame's :class:`TrackResult` and when frames arrive.

    Frames arriving without a pose for ``lost_after_s`` or longer: the robot is out of the camera's view
    (WARN, with where and how long ago it was last seen); for a shorter time its markers are only lost
    (WARN naming them). No frame for longer than ``image_timeout_s``: the camera is silent (ERROR), whatever
    was seen before. Times are the caller's clock in seconds (``camera_tracker``: the steady clock at
    arrival, so a video's or a simulation's stamps do not matter). ``source`` names the images in messages.
    """

    def __init__(self, lost_after_s: float = 0.5, image_timeout_s: float = 1.0, start_s: float = 0.0,
                 frame_id: str = "floor", source: str = "image_raw"):
        """Start watching at ``start_s`` (no frame yet)."""
        if not (lost_after_s > 0 and image_timeout_s > 0):
            raise ConfigurationError(f"lost_after_s {lost_after_s} s and image_timeout_s {image_timeout_s} s; "
                                     "both must be > 0 s.")
        self.lost_after_s, self.image_timeout_s = float(lost_after_s), float(image_timeout_s)
        self.frame_id, self.source = frame_id, source
        self._start_s = float(start_s)
        self._last_frame_s: float | None = None
        self._last_seen: tuple[float, float, float] | None = None  # (time s, x m, y m)
        self._unseen_since_s: float | None = None  # first frame without a pose since the last pose
        self._missing = ""

    def frame(self, now_s: float, result: TrackResult) -> None:
        """One frame arrived at ``now_s`` and gave ``result``."""
        self._last_frame_s = now_s
        if result.tracked:
            self._last_seen = (now_s, float(result.pose[0]), float(result.pose[1]))
            self._unseen_since_s = None
            return
        self._missing = result.message
        if self._unseen_since_s is None:
            self._unseen_since_s = now_s

    def status(self, now_s: float) -> ViewStatus:
        """The report at ``now_s``."""
        seen = self._last_seen
        base = ViewStatus(ViewState.TRACKING, "tracking", None if seen is None else seen[1:],
                          None if seen is None else now_s - seen[0],
                          None if self._last_frame_s is None else now_s - self._last_frame_s, self.frame_id)
        say = partial(dataclasses.replace, base)
        if self._last_frame_s is None:
            waited_s = now_s - self._start_s
            if waited_s <= self.image_timeout_s:
                return say(state=ViewState.NO_IMAGES, message=f"no images received yet from {self.source}")
            return say(state=ViewState.CAMERA_SILENT,
                       message=f"no images from {self.source} for {waited_s:.1f} s since the start (camera silent)")
        silent_s = now_s - self._last_frame_s
        if silent_s > self.image_timeout_s:
            return say(state=ViewState.CAMERA_SILENT, message=f"no images from {self.source} for {silent_s:.1f} s "
                                                              f"(camera silent); robot {base.last_seen_text()}")
        if self._unseen_since_s is None:
            return base
        unseen_s = now_s - self._unseen_since_s
        if unseen_s < self.lost_after_s:
            return say(state=ViewState.MARKERS_LOST, message=f"markers lost ({self._missing}); no pose published")
        where = f"never seen in {unseen_s:.1f} s of images" if seen is None else base.last_seen_text()
        return say(state=ViewState.OUT_OF_VIEW,
                   message=f"robot out of the camera's view: {where}; no pose published ({self._missing})")
