"""The simulated overhead camera: what a fixed camera above the floor sees of the simulated robot, with OpenCV.

The camera is the pinhole behind the floor calibration (``config/camera_calibration.yaml``): a plane's
homography ``H ~ K [r1 r2 t]`` fixes the rotation, the position and, with square pixels and the principal
point at the image centre, the focal length (from ``r1 . r2 = 0`` and ``|r1| = |r2|``; give it in
``sim.camera.focal_length_px`` for a camera looking straight down). A frame is the textured
floor (drawn once) with the body painted over it as a tube of the skin radius along the simulated
backbone, far parts first, and a coloured band around the tail and the head, visible at any roll angle.
The bands' colours fit the camera tracker's colour mode (:func:`band_tracker_config`).
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from srs_ros.core.errors import ConfigurationError
from srs_ros.core.robot import config_file
from srs_ros.core.vision.camera_calibration import CameraCalibration, load_calibration
from srs_ros.core.vision.tracking import ColorRange, TrackerConfig
from srs_ros.sim.config import CameraConfig, SimConfig, load_sim_config
from srs_ros.sim.scene import floor_texture_bgr

#: Image size assumed when the calibration does not give one (width, height), pixels.
DEFAULT_IMAGE_SIZE_PX = (640, 480)
#: Spacing (m) of the tube's samples along the body: a few pixels at 1 m.
TUBE_STEP_M = 0.006
#: Supersampling of the static floor before it is area-averaged to the image size.
FLOOR_SUPERSAMPLE = 2
#: Precomputed noise images cycled through frame by frame (sensor noise without per-frame random draws).
NOISE_BANK_SIZE = 4


def pinhole_from_homography(homography_floor_to_image: np.ndarray, image_size_px: tuple[int, int],
                            focal_length_px: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Camera matrix ``K`` and pose (``R``, ``t``: floor -> camera) of the pinhole behind a floor homography.

    Assumes square pixels and the principal point at the image centre. ``focal_length_px`` 0 derives the
    focal length from the homography (impossible for a camera looking exactly straight down: then give it).
    Raises :class:`ConfigurationError` if the homography is not a camera above the floor.
    """
    h = np.asarray(homography_floor_to_image, dtype=np.float64)
    cx, cy = 0.5 * image_size_px[0], 0.5 * image_size_px[1]
    g = np.array([[1.0, 0.0, -cx], [0.0, 1.0, -cy], [0.0, 0.0, 1.0]]) @ h
    if focal_length_px > 0:
        focal = float(focal_length_px)
    else:
        # r1 . r2 = 0 and |r1| = |r2| with r_i ~ (g_ix / f, g_iy / f, g_iz): two equations a / f^2 + b = 0,
        # solved for 1 / f^2 by least squares (either alone can vanish, e.g. for a camera tilted about x).
        g1, g2 = g[:, 0], g[:, 1]
        a = np.array([g1[0] * g2[0] + g1[1] * g2[1], g1[0] ** 2 + g1[1] ** 2 - g2[0] ** 2 - g2[1] ** 2])
        b = np.array([g1[2] * g2[2], g1[2] ** 2 - g2[2] ** 2])
        inv_f2 = -float(a @ b) / float(a @ a) if float(a @ a) > 0.0 else -1.0
        f2 = 1.0 / inv_f2 if inv_f2 > 0 else -1.0
        if not (f2 > 0 and math.isfinite(f2)):
            raise ConfigurationError(
                "sim.camera.focal_length_px is 0 but the calibration's homography does not fix a focal length "
                "(the camera looks straight down); give focal_length_px in pixels.")
        focal = math.sqrt(f2)
    k = np.array([[focal, 0.0, cx], [0.0, focal, cy], [0.0, 0.0, 1.0]])
    m = np.linalg.inv(k) @ h
    scale = 2.0 / (np.linalg.norm(m[:, 0]) + np.linalg.norm(m[:, 1]))
    m *= scale if m[2, 2] * scale > 0 else -scale          # the floor origin lies in front of the camera
    r1, r2, t = m[:, 0], m[:, 1], m[:, 2]
    u, _, vt = np.linalg.svd(np.column_stack([r1, r2, np.cross(r1, r2)]))
    rotation = u @ vt
    centre = -rotation.T @ t
    if not centre[2] > 0:
        raise ConfigurationError(f"the calibration puts the camera at height {centre[2]:.3f} m; expected a camera "
                                 "above the floor (check the calibration file).")
    return k, rotation, t


def band_tracker_config(camera: CameraConfig, **fields) -> TrackerConfig:
    """The camera tracker's colour mode set for the simulated bands (an HSV box around each band colour).

    Hue +-10, saturation from half the band's, value from a third of it (the tube's darker rim);
    ``fields`` override other :class:`TrackerConfig` fields (e.g. ``velocity_window_s``).
    """
    def box(bgr) -> ColorRange:
        h, s, v = (int(c) for c in cv2.cvtColor(np.uint8([[bgr]]), cv2.COLOR_BGR2HSV)[0, 0])
        low = ((h - 10) % 180, max(s // 2, 1), max(v // 3, 1))
        high = ((h + 10) % 180, 255, 255)
        return ColorRange(low, high)

    return TrackerConfig(detector="color", tail_color=box(camera.tail_band_bgr), head_color=box(camera.head_band_bgr),
                         **fields)


class OverheadCamera:
    """Renders BGR frames of a simulated robot (its backbone nodes, floor frame) seen by the calibrated camera."""

    def __init__(self, config: SimConfig | None = None, calibration: CameraCalibration | None = None):
        """Recover the pinhole from ``calibration`` (default: ``sim.camera.calibration_file``) and draw the floor."""
        self.config = config or load_sim_config()
        cam = self.camera_config = self.config.camera
        self.calibration = calibration or load_calibration(config_file(cam.calibration_file) if cam.calibration_file
                                                           else None)
        self.size_px = tuple(self.calibration.image_size_px or DEFAULT_IMAGE_SIZE_PX)
        self.intrinsics, self.rotation, self.translation = pinhole_from_homography(
            self.calibration.homography_floor_to_image, self.size_px, cam.focal_length_px)
        self.projection = self.intrinsics @ np.column_stack([self.rotation, self.translation])
        self.radius_m = self.config.body.skin_radius_m
        self.focal_px = float(self.intrinsics[0, 0])
        s = FLOOR_SUPERSAMPLE
        scale = np.array([[s, 0.0, 0.5 * (s - 1.0)], [0.0, s, 0.5 * (s - 1.0)], [0.0, 0.0, 1.0]])
        big = floor_texture_bgr(scale @ self.floor_homography(0.0), (self.size_px[0] * s, self.size_px[1] * s),
                                cam.floor_seed)
        self.floor = cv2.resize(big, self.size_px, interpolation=cv2.INTER_AREA)
        self._noise = self._noise_bank(cam.noise_sigma, cam.floor_seed)
        self._frame_count = 0

    # ------------------------------------------------------------------ geometry
    @property
    def centre_m(self) -> np.ndarray:
        """The camera's optical centre in the floor frame (m)."""
        return -self.rotation.T @ self.translation

    def project(self, points_m) -> tuple[np.ndarray, np.ndarray]:
        """Pixels ``(..., 2)`` and depths ``(...,)`` (m along the optical axis) of floor-frame points ``(..., 3)``."""
        points = np.asarray(points_m, dtype=np.float64)
        camera = points @ self.rotation.T + self.translation
        depth = camera[..., 2]
        pixels = (camera @ self.intrinsics.T)[..., :2] / depth[..., None]
        return pixels, depth

    def floor_homography(self, height_m: float) -> np.ndarray:
        """Homography from the plane ``z = height_m`` (its x, y in metres) to image pixels."""
        r = self.rotation
        h = self.intrinsics @ np.column_stack([r[:, 0], r[:, 1], self.translation + height_m * r[:, 2]])
        return h / h[2, 2]

    def calibration_at_height(self, height_m: float) -> CameraCalibration:
        """The calibration a lab would make with its markers at ``height_m``: image -> (x, y) on that plane.

        The tracker assumes its markers lie in the calibrated plane (srs_ros.core.vision.tracking); the bands
        ride on the body's axis, one skin radius above the floor while it lies there.
        """
        to_image = self.floor_homography(height_m)
        to_plane = np.linalg.inv(to_image)
        return CameraCalibration(to_plane / to_plane[2, 2], image_size_px=self.size_px,
                                 frame_id=self.calibration.frame_id, source=f"simulated camera, plane z = {height_m} m")

    # ------------------------------------------------------------------ drawing
    def _noise_bank(self, sigma: float, seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
        if sigma <= 0:
            return []
        rng = np.random.default_rng(seed + 1)
        shape = (self.size_px[1], self.size_px[0], 3)
        bank = []
        for _ in range(NOISE_BANK_SIZE):
            noise = np.round(rng.normal(0.0, sigma, shape))
            bank.append((np.clip(noise, 0, 255).astype(np.uint8), np.clip(-noise, 0, 255).astype(np.uint8)))
        return bank

    def _tube_samples(self, nodes_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Points along the backbone polyline about every ``TUBE_STEP_M`` and at the bands' edges, with arc lengths."""
        chords = np.diff(nodes_m, axis=0)
        lengths = np.linalg.norm(chords, axis=1)
        arc = np.concatenate([[0.0], np.cumsum(lengths)])
        offset, half_band = self.config.body.marker_offset_m, 0.5 * self.camera_config.band_length_m
        edges = np.array([offset - half_band, offset + half_band, arc[-1] - offset - half_band,
                          arc[-1] - offset + half_band])
        even = np.linspace(0.0, arc[-1], max(2, int(math.ceil(arc[-1] / TUBE_STEP_M)) + 1))
        s = np.unique(np.concatenate([even, edges[(edges > 0.0) & (edges < arc[-1])]]))
        points = np.stack([np.interp(s, arc, nodes_m[:, i]) for i in range(3)], axis=-1)
        return points, s

    def render(self, nodes_m, frame_index: int | None = None) -> np.ndarray:
        """One BGR uint8 frame of the body whose backbone nodes are ``nodes_m`` ``(k, 3)`` (floor frame, m).

        ``None`` draws the empty floor. Pass e.g. ``state.nodes_m`` of a :class:`srs_ros.sim.world.SimState`.
        ``frame_index`` picks the noise pattern (default: the next one).
        """
        frame = self.floor.copy()
        if nodes_m is not None:
            self._draw_body(frame, np.asarray(nodes_m, dtype=np.float64))
        if self._noise:
            index = self._frame_count if frame_index is None else frame_index
            plus, minus = self._noise[index % len(self._noise)]
            cv2.add(frame, plus, dst=frame)
            cv2.subtract(frame, minus, dst=frame)
        self._frame_count += 1
        return frame

    def _draw_body(self, frame: np.ndarray, nodes_m: np.ndarray) -> None:
        """Paint the tube as a strip of quadrilaterals (one per sample interval), far ones first.

        Each quadrilateral spans the tube's projected width between two cross-sections, so a coloured band
        covers exactly its own stretch of body (round line caps would smear colours into the neighbours);
        half discs close the two ends. Three passes shade it: a dark rim, the colour, a highlight.
        """
        cam, radius = self.camera_config, self.radius_m
        points, s = self._tube_samples(nodes_m)
        pixels, depth = self.project(points)
        if np.any(depth <= 0.0) or not np.all(np.isfinite(pixels)):
            return                                     # behind the camera: nothing sensible to draw
        offset, half_band = self.config.body.marker_offset_m, 0.5 * cam.band_length_m
        mid = 0.5 * (s[1:] + s[:-1])
        colour = np.tile(np.array(cam.body_bgr, dtype=np.float64), (len(mid), 1))
        colour[np.abs(mid - offset) <= half_band] = cam.tail_band_bgr
        colour[np.abs(mid - (s[-1] - offset)) <= half_band] = cam.head_band_bgr
        half_width = radius * self.focal_px / depth                           # projected radius at each sample, px
        tangent = np.gradient(pixels, axis=0)
        tangent /= np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True), 1e-9)
        normal = np.column_stack([-tangent[:, 1], tangent[:, 0]])
        order = np.argsort(-0.5 * (depth[1:] + depth[:-1]))                  # far intervals first
        ends = ((0, -1.0), (len(pixels) - 1, 1.0))
        arc = np.linspace(0.0, math.pi, 9)
        order = order.tolist()
        for shade, fraction, lift in ((0.55, 1.0, 0.0), (1.0, 0.72, 0.0), (1.3, 0.22, 0.3)):
            # The highlight runs along the side facing the camera's image top (a light from above-behind).
            edge = normal * (half_width * fraction)[:, None]
            centre = pixels + normal * (half_width * lift)[:, None]
            left, right = centre + edge, centre - edge
            quads = np.stack([left[:-1], left[1:], right[1:], right[:-1]], axis=1)
            fixed = list(np.round(quads * 16).astype(np.int32))
            colours = np.minimum(colour * shade, 255.0).tolist()  # one BGR list per interval
            for i in order:
                cv2.fillConvexPoly(frame, fixed[i], colours[i], cv2.LINE_AA, shift=4)
            for index, sign in ends:
                i = min(index, len(colour) - 1)
                direction = sign * tangent[index]
                cap = centre[index] + half_width[index] * fraction * (
                    np.cos(arc)[:, None] * normal[index] + np.sin(arc)[:, None] * direction)
                cv2.fillConvexPoly(frame, np.round(cap * 16).astype(np.int32), colours[i], cv2.LINE_AA, shift=4)
