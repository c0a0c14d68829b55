"""Synthetic overhead-camera frames and videos of the robot from known poses, for tests, demos and benchmarks.

A pinhole camera above a textured floor sees the robot's body band with a head and a tail marker (ArUco
or coloured discs). Everything is drawn in floor metres and warped into the image through the camera's
exact floor -> image homography, supersampled, optionally bent by a lens's distortion (plumb_bob), then
area-averaged, blurred and noised, so the true pose of every frame is known. Occluders (floor polygons
drawn on top) hide parts of the scene.

The library of the simulated world's camera (:mod:`srs_ros.sim.camera`) and of the tracking tests; the
command ``python -m srs_ros.tools.synthetic_scene out.avi`` writes a demo video of a constant-speed run.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from srs_ros.core.vision.aruco import marker_image
from srs_ros.core.vision.camera_calibration import (
    CameraCalibration,
    CameraIntrinsics,
    apply_homography,
    calibration_from_pairs,
)
from srs_ros.core.vision.tracking import DEFAULT_ARUCO_DICTIONARY, aruco_dictionary


def floor_texture_bgr(homography_floor_to_image: np.ndarray, size_px: tuple[int, int], seed: int) -> np.ndarray:
    """A concrete-like floor (noise plus tile joints every 0.3 m, 4 m square) seen through a floor -> image homography.

    ``size_px`` is (width, height) of the returned BGR image; the same ``seed`` gives the same floor.
    """
    rng = np.random.default_rng(seed)
    mm_per_px = 2.0
    extent_m = 4.0
    n = int(extent_m * 1000 / mm_per_px)
    coarse = rng.normal(0.0, 1.0, (n // 16, n // 16)).astype(np.float32)
    fine = rng.normal(0.0, 1.0, (n, n)).astype(np.float32)
    tex = 150.0 + 18.0 * cv2.resize(coarse, (n, n), interpolation=cv2.INTER_CUBIC) + 10.0 * cv2.GaussianBlur(
        fine, (0, 0), 1.2)
    joints = (np.arange(n) * mm_per_px) % 300.0 < 4.0
    tex[joints, :] -= 45.0
    tex[:, joints] -= 45.0
    tex = np.clip(tex, 0, 255).astype(np.uint8)
    tex = cv2.merge([tex, (tex * 0.95).astype(np.uint8), (tex * 0.9).astype(np.uint8)])
    m = mm_per_px / 1000.0
    canvas_to_floor = np.array([[m, 0.0, -0.5 * extent_m], [0.0, -m, 0.5 * extent_m], [0.0, 0.0, 1.0]])
    return cv2.warpPerspective(tex, homography_floor_to_image @ canvas_to_floor, tuple(size_px),
                               flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)


@dataclass(frozen=True)
class SyntheticCamera:
    """A pinhole camera at ``height_m`` above the floor point ``(x_m, y_m)``, tilted by ``tilt_rad``.

    With zero tilt the image's u axis runs along floor +X and v along floor -Y (+Y up in the image).
    """

    width_px: int = 640
    height_px: int = 480
    horizontal_fov_rad: float = math.radians(60.0)
    x_m: float = 0.0
    y_m: float = 0.0
    height_m: float = 1.0
    tilt_rad: float = math.radians(12.0)
    pan_rad: float = math.radians(4.0)
    #: Lens distortion, plumb_bob coefficients (k1, k2, p1, p2, k3); empty = an ideal pinhole.
    distortion: tuple[float, ...] = ()

    @property
    def lens(self) -> CameraIntrinsics | None:
        """The camera's intrinsics with its lens distortion (None for an ideal pinhole)."""
        return CameraIntrinsics(self.intrinsics, np.array(self.distortion), "plumb_bob") if self.distortion else None

    def floor_to_image_px(self, points_m: Any) -> np.ndarray:
        """Exact pixels (..., 2) of floor points (..., 2) m, lens distortion included."""
        ideal = apply_homography(self.homography_floor_to_image, points_m)
        return self.lens.distort_px(ideal) if self.lens else ideal

    @property
    def intrinsics(self) -> np.ndarray:
        """Camera matrix K (square pixels, principal point at the image centre)."""
        f = 0.5 * self.width_px / math.tan(0.5 * self.horizontal_fov_rad)
        return np.array([[f, 0.0, 0.5 * self.width_px], [0.0, f, 0.5 * self.height_px], [0.0, 0.0, 1.0]])

    @property
    def homography_floor_to_image(self) -> np.ndarray:
        """Exact floor (x, y, 0) metres -> pixel homography ``K [r1 r2 t]``."""
        # Camera looking down: camera x = floor x, camera y = floor -y, camera z = floor -z; then tilt about
        # the camera's x axis and pan about its optical axis.
        down = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])
        ct, st = math.cos(self.tilt_rad), math.sin(self.tilt_rad)
        tilt = np.array([[1.0, 0.0, 0.0], [0.0, ct, -st], [0.0, st, ct]])
        cp, sp = math.cos(self.pan_rad), math.sin(self.pan_rad)
        pan = np.array([[cp, -sp, 0.0], [sp, cp, 0.0], [0.0, 0.0, 1.0]])
        rotation = pan @ tilt @ down  # floor -> camera
        centre = np.array([self.x_m, self.y_m + self.height_m * math.tan(self.tilt_rad), self.height_m])
        translation = -rotation @ centre
        h = self.intrinsics @ np.column_stack([rotation[:, 0], rotation[:, 1], translation])
        return h / h[2, 2]

    def calibration(self, columns: int = 5, rows: int = 4) -> CameraCalibration:
        """A calibration fitted from exact point pairs: a grid over the image, floor points rounded to mm.

        With lens distortion, the calibration carries the camera's intrinsics (as a real one would).
        """
        u = np.linspace(0.1, 0.9, columns) * self.width_px
        v = np.linspace(0.1, 0.9, rows) * self.height_px
        pixels = np.stack(np.meshgrid(u, v), axis=-1).reshape(-1, 2)
        ideal = self.lens.undistort_px(pixels) if self.lens else pixels
        floor = np.round(apply_homography(np.linalg.inv(self.homography_floor_to_image), ideal), 3)
        return calibration_from_pairs(self.floor_to_image_px(floor), floor, (self.width_px, self.height_px),
                                      intrinsics=self.lens)


@dataclass(frozen=True)
class RobotAppearance:
    """How the robot looks from above: marker kind, ids or colours, sizes and spacing."""

    marker_style: str = "aruco"
    aruco_dictionary: str = DEFAULT_ARUCO_DICTIONARY
    tail_marker_id: int = 0
    head_marker_id: int = 1
    tail_color_bgr: tuple[int, int, int] = (220, 90, 20)
    head_color_bgr: tuple[int, int, int] = (30, 30, 220)
    marker_size_m: float = 0.045
    marker_spacing_m: float = 0.40
    position_ratio: float = 0.5
    body_width_m: float = 0.05
    body_color_bgr: tuple[int, int, int] = (60, 70, 60)

    def marker_centres_m(self, pose: Sequence[float]) -> dict[str, np.ndarray]:
        """Floor centres of the tail and head markers for a pose (x_m, y_m, yaw_rad)."""
        x, y, yaw = (float(v) for v in pose)
        axis = np.array([math.cos(yaw), math.sin(yaw)])
        tail = np.array([x, y]) - self.position_ratio * self.marker_spacing_m * axis
        return {"tail": tail, "head": tail + self.marker_spacing_m * axis}


@dataclass
class SyntheticScene:
    """A camera, a floor texture and a robot; :meth:`render` draws one frame of a given pose."""

    camera: SyntheticCamera = field(default_factory=SyntheticCamera)
    robot: RobotAppearance = field(default_factory=RobotAppearance)
    supersample: int = 3
    blur_sigma_px: float = 0.7
    noise_sigma: float = 3.0
    floor_seed: int = 7

    def __post_init__(self):
        self._floor: np.ndarray | None = None
        self._markers: dict[int, np.ndarray] = {}
        self._lens_maps: tuple[np.ndarray, np.ndarray] | None = None
        self._margin_px = self._lens_margin_px()

    # -- drawing helpers -------------------------------------------------------------------------
    def _lens_margin_px(self) -> int:
        """Border (supersampled px) the ideal image needs so that the distorted image finds all it shows."""
        lens = self.camera.lens
        if lens is None:
            return 0
        w, h = self.camera.width_px, self.camera.height_px
        t = np.linspace(0.0, 1.0, 101)
        border = np.concatenate([np.column_stack([t * (w - 1), np.zeros_like(t)]),
                                 np.column_stack([t * (w - 1), np.full_like(t, h - 1)]),
                                 np.column_stack([np.zeros_like(t), t * (h - 1)]),
                                 np.column_stack([np.full_like(t, w - 1), t * (h - 1)])])
        ideal = lens.undistort_px(border)
        if np.max(np.abs(lens.distort_px(ideal) - border)) > 1e-3:
            raise ValueError(f"lens distortion {self.camera.distortion} folds over within the image; "
                             "use smaller coefficients or a narrower field of view.")
        overflow = max(0.0, -ideal.min(), ideal[:, 0].max() - (w - 1), ideal[:, 1].max() - (h - 1))
        return int(math.ceil((overflow + 2.0) * self.supersample))

    @property
    def _scale(self) -> np.ndarray:
        s, m = float(self.supersample), float(self._margin_px)
        return np.array([[s, 0.0, 0.5 * (s - 1.0) + m], [0.0, s, 0.5 * (s - 1.0) + m], [0.0, 0.0, 1.0]])

    @property
    def _h_floor_to_big(self) -> np.ndarray:
        """Floor -> supersampled ideal image (pixel centres aligned with the final image's after INTER_AREA)."""
        return self._scale @ self.camera.homography_floor_to_image

    def _big_size(self) -> tuple[int, int]:
        margin = 2 * self._margin_px
        return self.camera.width_px * self.supersample + margin, self.camera.height_px * self.supersample + margin

    def _through_lens(self, image: np.ndarray) -> np.ndarray:
        """The supersampled ideal image (with its margin) as the distorting lens shows it, at supersampled size."""
        if self._lens_maps is None:
            w, h = self.camera.width_px, self.camera.height_px
            pixels = np.stack(np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64)), axis=-1)
            ideal = self.camera.lens.undistort_px(pixels)
            s, m = self.supersample, self._margin_px
            big = ((ideal + 0.5) * s - 0.5 + m).astype(np.float32)
            size = (w * s, h * s)  # the map is smooth: bilinear upsampling keeps it exact to far below a pixel
            self._lens_maps = (cv2.resize(big[..., 0], size, interpolation=cv2.INTER_LINEAR),
                               cv2.resize(big[..., 1], size, interpolation=cv2.INTER_LINEAR))
        return cv2.remap(image, *self._lens_maps, interpolation=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)

    def _floor_image(self) -> np.ndarray:
        """The floor texture as seen by the camera, supersampled."""
        if self._floor is None:
            self._floor = floor_texture_bgr(self._h_floor_to_big, self._big_size(), self.floor_seed)
        return self._floor.copy()

    def _marker_texture(self, marker_id: int) -> np.ndarray:
        """Marker bits with a one-cell white quiet zone, 24 px per cell."""
        if marker_id not in self._markers:
            dictionary = aruco_dictionary(self.robot.aruco_dictionary)
            cells = dictionary.markerSize + 2
            cell_px = 24
            marker = marker_image(self.robot.aruco_dictionary, marker_id, cells * cell_px)
            self._markers[marker_id] = cv2.copyMakeBorder(marker, cell_px, cell_px, cell_px, cell_px,
                                                          cv2.BORDER_CONSTANT, value=255)
        return self._markers[marker_id]

    def _fill_floor_polygon(self, image: np.ndarray, polygon_m: np.ndarray, color: Sequence[int]) -> None:
        pts = apply_homography(self._h_floor_to_big, polygon_m)
        cv2.fillPoly(image, [np.round(pts * 16).astype(np.int32)], tuple(int(c) for c in color),
                     lineType=cv2.LINE_AA, shift=4)

    def _draw_aruco(self, image: np.ndarray, marker_id: int, centre_m: np.ndarray, yaw_rad: float,
                    size_m: float | None = None) -> None:
        tex = self._marker_texture(marker_id)
        cells = aruco_dictionary(self.robot.aruco_dictionary).markerSize + 2
        side_px = tex.shape[0]
        # Texture pixel -> floor: the black square (cells wide) spans the marker size; y of the texture points
        # along floor -normal so the marker reads upright when the robot heads along +X.
        m = (size_m or self.robot.marker_size_m) / (cells * side_px / (cells + 2))
        c, s = math.cos(yaw_rad), math.sin(yaw_rad)
        half = 0.5 * side_px
        tex_to_local = np.array([[m, 0.0, -m * half], [0.0, -m, m * half], [0.0, 0.0, 1.0]])
        local_to_floor = np.array([[c, -s, centre_m[0]], [s, c, centre_m[1]], [0.0, 0.0, 1.0]])
        h = self._h_floor_to_big @ local_to_floor @ tex_to_local
        # Warp into the marker's bounding box only, not the whole image: bilinear sampling reaches from texture
        # coordinate -1 to side_px, and two pixels to spare.
        low, high = -1.0, float(side_px)
        corners = apply_homography(h, np.array([[low, low], [high, low], [high, high], [low, high]]))
        size = self._big_size()
        x0, y0 = (max(0, int(math.floor(v)) - 2) for v in corners.min(axis=0))
        x1, y1 = (min(limit, int(math.ceil(v)) + 2) for v, limit in zip(corners.max(axis=0), size))
        if x1 <= x0 or y1 <= y0:
            return  # the marker lies outside the image
        h = np.array([[1.0, 0.0, -x0], [0.0, 1.0, -y0], [0.0, 0.0, 1.0]]) @ h
        box = (x1 - x0, y1 - y0)
        warped = cv2.warpPerspective(cv2.cvtColor(tex, cv2.COLOR_GRAY2BGR), h, box, flags=cv2.INTER_LINEAR)
        mask = cv2.warpPerspective(np.full(tex.shape, 255, np.uint8), h, box, flags=cv2.INTER_LINEAR)
        roi = (slice(y0, y1), slice(x0, x1))
        alpha = mask[..., None].astype(np.float32) / 255.0
        image[roi] = (alpha * warped + (1.0 - alpha) * image[roi]).astype(np.uint8)

    # -- public API ------------------------------------------------------------------------------
    def true_markers_px(self, pose: Sequence[float]) -> dict[str, np.ndarray]:
        """Exact image positions (px) of the marker centres for a pose."""
        return {k: self.camera.floor_to_image_px(c) for k, c in self.robot.marker_centres_m(pose).items()}

    def render_floor_markers(self, markers: Sequence[tuple[int, float, float, float]], size_m: float,
                             rng: np.random.Generator | None = None) -> np.ndarray:
        """A calibration frame: ArUco markers ``(id, x_m, y_m, yaw_rad)`` of side ``size_m`` laid on the floor."""
        image = self._floor_image()
        for marker_id, x, y, yaw in markers:
            self._draw_aruco(image, int(marker_id), np.array([x, y], dtype=np.float64), float(yaw), size_m)
        return self._finish(image, rng)

    def _finish(self, image: np.ndarray, rng: np.random.Generator | None) -> np.ndarray:
        """Area-average down to the camera's size, blur, add noise."""
        rng = rng if rng is not None else np.random.default_rng(0)
        size = (self.camera.width_px, self.camera.height_px)
        if self.camera.lens is not None:
            image = self._through_lens(image)
        frame = cv2.resize(image, size, interpolation=cv2.INTER_AREA) if self.supersample > 1 else image
        if self.blur_sigma_px > 0:
            frame = cv2.GaussianBlur(frame, (0, 0), self.blur_sigma_px)
        if self.noise_sigma > 0:
            noisy = frame.astype(np.float32) + rng.normal(0.0, self.noise_sigma, frame.shape).astype(np.float32)
            frame = np.clip(noisy, 0, 255).astype(np.uint8)
        return frame

    def render(self, pose: Sequence[float] | None, rng: np.random.Generator | None = None,
               occluders_m: Sequence[Any] = ()) -> np.ndarray:
        """One BGR uint8 frame of the robot at ``pose`` (x_m, y_m, yaw_rad), or of the empty floor (None).

        ``occluders_m`` are floor polygons (k, 2) in metres drawn on top in grey (a hand, a cable).
        """
        image = self._floor_image()
        robot = self.robot
        if pose is not None:
            centres = robot.marker_centres_m(pose)
            yaw = float(pose[2])
            axis = np.array([math.cos(yaw), math.sin(yaw)])
            normal = np.array([-axis[1], axis[0]])
            ends = (centres["tail"] - 0.06 * axis, centres["head"] + 0.04 * axis)
            half = 0.5 * robot.body_width_m * normal
            body = np.array([ends[0] - half, ends[1] - half, ends[1] + half, ends[0] + half])
            self._fill_floor_polygon(image, body, robot.body_color_bgr)
            for key in ("tail", "head"):
                if robot.marker_style == "aruco":
                    marker_id = robot.tail_marker_id if key == "tail" else robot.head_marker_id
                    self._draw_aruco(image, marker_id, centres[key], yaw)
                else:
                    angles = np.linspace(0.0, 2.0 * math.pi, 48, endpoint=False)
                    disc = centres[key] + 0.5 * robot.marker_size_m * np.column_stack([np.cos(angles), np.sin(angles)])
                    color = robot.tail_color_bgr if key == "tail" else robot.head_color_bgr
                    self._fill_floor_polygon(image, disc, color)
        for polygon in occluders_m:
            self._fill_floor_polygon(image, np.asarray(polygon, dtype=np.float64), (120, 125, 130))
        return self._finish(image, rng)


def constant_velocity_poses(duration_s: float, fps: float, start_pose: Sequence[float],
                            velocity_m_s: Sequence[float], yaw_rate_rad_s: float = 0.0
                            ) -> tuple[np.ndarray, np.ndarray]:
    """Times (n,) and poses (n, 3) of a run at constant floor velocity (vx, vy) m/s and yaw rate."""
    t = np.arange(int(round(duration_s * fps)) + 1) / fps
    x = start_pose[0] + velocity_m_s[0] * t
    y = start_pose[1] + velocity_m_s[1] * t
    yaw = start_pose[2] + yaw_rate_rad_s * t
    return t, np.column_stack([x, y, yaw])


def write_video(path: str | Path, scene: SyntheticScene, poses: np.ndarray, fps: float, seed: int = 0,
                fourcc: str = "MJPG", occluders_by_frame: Mapping[int, Sequence[Any]] | None = None) -> Path:
    """Render ``poses`` (n, 3) into a video file at ``fps`` (MJPG .avi by default); returns the path.

    ``occluders_by_frame`` maps frame indices to the floor polygons drawn over that frame (see :meth:`render`).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    size = (scene.camera.width_px, scene.camera.height_px)
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), float(fps), size)
    if not writer.isOpened():
        raise OSError(f"cannot open a {fourcc} video writer for {path}; try an .avi path with MJPG.")
    rng = np.random.default_rng(seed)
    try:
        for index, pose in enumerate(poses):
            writer.write(scene.render(pose, rng, (occluders_by_frame or {}).get(index, ())))
    finally:
        writer.release()
    return path
