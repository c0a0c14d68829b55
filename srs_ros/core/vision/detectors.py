"""Head and tail markers in a camera frame: ArUco markers (ROI search first) or coloured blobs. OpenCV only."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from srs_ros.core.errors import ConfigurationError, InvalidInputError
from srs_ros.core.vision import aruco

#: Default ArUco dictionary: 4 x 4 bits survive the small image size of a 4 cm marker seen from 1 m.
DEFAULT_ARUCO_DICTIONARY = "DICT_4X4_50"


def search_window(corners_px: np.ndarray, margin_px: int, width: int, height: int) -> tuple[int, int, int, int]:
    """Where to look first in the next frame, as (x0, y0, x1, y1) px.

    The box of ``corners_px`` (n, 2) grown by ``margin_px``, inside a ``width`` x ``height`` frame.
    """
    lo = np.floor(corners_px.min(axis=0)).astype(int) - margin_px
    hi = np.ceil(corners_px.max(axis=0)).astype(int) + margin_px
    return max(int(lo[0]), 0), max(int(lo[1]), 0), min(int(hi[0]), width), min(int(hi[1]), height)


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

    def forget(self) -> None:
        """Search the whole of the next frame (a tracker rejected what was found)."""
        self._last_box = None

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
        self._last_box = search_window(corners, self.roi_margin_px, shape[1], shape[0])


#: Largest hue of OpenCV's 8-bit HSV (degrees / 2: 0..179); saturation and value run to 255.
HUE_MAX = 179
#: Largest saturation and value of OpenCV's 8-bit HSV.
SV_MAX = 255


def _whole(value) -> bool:
    """True for an integer (or a float with an integer value), False for NaN, inf, booleans and others."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool) \
        and float(value).is_integer()


def hsv_range_problem(low_hsv, high_hsv) -> tuple[str, str] | None:
    """What is wrong with the HSV box ``low_hsv`` .. ``high_hsv``, or None when it is a usable box.

    The problem is (``"low_hsv"`` or ``"high_hsv"``, what is expected); OpenCV scale, only the hue may wrap
    (low > high going through red).
    """
    bounds = {"low_hsv": low_hsv, "high_hsv": high_hsv}
    for name, value in bounds.items():
        if len(value) != 3 or not all(_whole(v) for v in value):
            return name, f"three integers [h, s, v] (OpenCV scale: h 0..{HUE_MAX}, s and v 0..{SV_MAX})"
        if not 0 <= value[0] <= HUE_MAX:
            return name, (f"a hue in 0..{HUE_MAX} (OpenCV's H is degrees / 2; hue {value[0]} would match no pixel), "
                          f"then s and v in 0..{SV_MAX}")
        if not all(0 <= v <= SV_MAX for v in value[1:]):
            return name, f"a hue in 0..{HUE_MAX}, then s and v in 0..{SV_MAX}"
    for index, channel in ((1, "saturation"), (2, "value")):
        if low_hsv[index] > high_hsv[index]:
            return "high_hsv", (f"a {channel} at least the low bound's {low_hsv[index]} (low above high matches no "
                                "pixel; only the hue wraps, low > high going through red)")
    return None


@dataclass(frozen=True)
class ColorRange:
    """An HSV box (OpenCV scale: H 0-179, S and V 0-255); ``low[0] > high[0]`` wraps through red."""

    low_hsv: tuple[int, int, int]
    high_hsv: tuple[int, int, int]

    def __post_init__(self):
        problem = hsv_range_problem(self.low_hsv, self.high_hsv)
        if problem is not None:
            name, expected = problem
            raise ConfigurationError(f"colour range {self.low_hsv!r} .. {self.high_hsv!r}: {name} is "
                                     f"{getattr(self, name)!r}; expected {expected}.")


class ColorBlobDetector:
    """Find one blob per named colour range (largest connected blob above ``min_area_px``).

    ROI search first, as the ArUco detector: each colour is looked for in a window ``roi_margin_px`` around
    where it was last found, and in the whole frame when it is not found there, when its blob reaches the
    window's edge (a blob cut by the window would have a wrong centre), and every :data:`WHOLE_FRAME_EVERY`
    frames. A blob found in its window is the one the whole frame gives (every step is per pixel or per blob,
    and the window's edge is at least 2 px from it), unless a blob elsewhere is at least as large: the window
    keeps the marker it tracks, and the periodic whole-frame search (or :meth:`forget`, which a tracker calls
    when it rejects a frame) lets go of a wrong one, such as a same-coloured object taken while the marker hid.
    """

    EDGE_PX = 2  #: a blob this close to a window's inner edge may reach past it: search the whole frame
    WHOLE_FRAME_EVERY = 15  #: frames: every 15th (0.5 s at 30 fps) is searched whole (3 ms at 640x480)

    def __init__(self, colors: Mapping[str, ColorRange], min_area_px: float = 20.0, roi_margin_px: int = 0):
        """``colors`` maps marker names to HSV ranges, e.g. ``{"tail": ColorRange(...), "head": ...}``."""
        self.colors = dict(colors)
        self.min_area_px = float(min_area_px)
        self.roi_margin_px = int(roi_margin_px)
        self.roi_hits = 0  #: detections made in a window (the rest needed the whole frame)
        self._kernel = np.ones((3, 3), np.uint8)
        self._windows: dict[str, tuple[int, int, int, int]] = {}  # name -> x0, y0, x1, y1 (px) to search first
        self._frame = 0

    def forget(self) -> None:
        """Search the whole of the next frame (a tracker rejected what was found)."""
        self._windows.clear()

    def _mask(self, hsv: np.ndarray, rng: ColorRange) -> np.ndarray:
        low, high = np.array(rng.low_hsv, np.uint8), np.array(rng.high_hsv, np.uint8)
        if rng.low_hsv[0] <= rng.high_hsv[0]:
            return cv2.inRange(hsv, low, high)
        upper = cv2.inRange(hsv, low, np.array([HUE_MAX, high[1], high[2]], np.uint8))
        lower = cv2.inRange(hsv, np.array([0, low[1], low[2]], np.uint8), high)
        return cv2.bitwise_or(upper, lower)

    def detect(self, bgr: np.ndarray) -> dict[str, MarkerDetection]:
        """Blobs found in a BGR image, by name; the centre is the blob's centroid."""
        if bgr.ndim != 3 or bgr.shape[2] != 3:
            raise InvalidInputError(f"colour-blob detection needs a 3-channel BGR image; got shape {bgr.shape}.")
        height, width = bgr.shape[:2]
        found: dict[str, MarkerDetection] = {}
        whole_hsv, self._frame = None, self._frame + 1
        windowed = self.roi_margin_px > 0 and self._frame % self.WHOLE_FRAME_EVERY != 0
        for key, rng in self.colors.items():
            window = self._windows.get(key) if windowed else None
            detection = None
            if window is not None:
                x0, y0, x1, y1 = window
                inner = (x0 > 0, y0 > 0, x1 < width, y1 < height)
                hsv = cv2.cvtColor(bgr[y0:y1, x0:x1], cv2.COLOR_BGR2HSV)
                detection = self._blob(key, self._mask(hsv, rng), (x0, y0), inner)
                self.roi_hits += detection is not None
            if detection is None:
                whole_hsv = cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV) if whole_hsv is None else whole_hsv
                detection = self._blob(key, self._mask(whole_hsv, rng), (0, 0), (False,) * 4)
            if detection is not None:
                found[key] = detection
            self._windows[key] = None if detection is None else \
                search_window(detection.corners_px, self.roi_margin_px, width, height)
        return found

    def _blob(self, key: str, mask: np.ndarray, offset: tuple[int, int],
              inner_edges: tuple[bool, bool, bool, bool]) -> MarkerDetection | None:
        """The largest blob of ``mask`` (a crop at ``offset``), or None: none, too small, or at an inner edge."""
        mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, self._kernel)
        count, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        if count < 2:
            return None
        best = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
        if stats[best, cv2.CC_STAT_AREA] < self.min_area_px:
            return None
        x, y, w, h = (int(stats[best, i]) for i in range(4))
        rows, cols = mask.shape
        edge = self.EDGE_PX
        if (inner_edges[0] and x < edge) or (inner_edges[1] and y < edge) or \
                (inner_edges[2] and x + w > cols - edge) or (inner_edges[3] and y + h > rows - edge):
            return None
        moments = cv2.moments((labels[y:y + h, x:x + w] == best).astype(np.uint8), binaryImage=True)
        ox, oy = offset
        centre = np.array([ox + x + moments["m10"] / moments["m00"], oy + y + moments["m01"] / moments["m00"]])
        box = np.array([[x, y], [x + w, y], [x + w, y + h], [x, y + h]], dtype=np.float64) + offset
        return MarkerDetection(key, centre, box)


# ------------------------------------------------------------------------------------------
# Velocity: least-squares slope over a sliding time window
# ------------------------------------------------------------------------------------------
def to_gray(image: np.ndarray) -> np.ndarray:
    """A single-channel 8-bit view of a BGR or mono image."""
    if image.ndim == 2:
        return image
    if image.ndim == 3 and image.shape[2] == 3:
        return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    if image.ndim == 3 and image.shape[2] == 1:
        return image[:, :, 0]
    raise InvalidInputError(f"image has shape {image.shape}; expected (h, w) mono or (h, w, 3) BGR.")
