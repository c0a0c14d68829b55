"""Where goals may lie: the camera's calibrated floor area, shrunk by a margin so the body stays in view."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from srs_ros.core.errors import ConfigurationError
from srs_ros.core.vision.camera_calibration import CameraCalibration

#: Points per image edge when the border is mapped to the floor (a distorted lens bends it).
BORDER_POINTS_PER_EDGE = 16


@dataclass(frozen=True)
class FloorArea:
    """A floor polygon ``(k, 2)`` (m, counter-clockwise) and the margin a goal must keep from its edge."""

    polygon_m: np.ndarray
    margin_m: float
    source: str = "<polygon>"

    @classmethod
    def from_calibration(cls, calibration: CameraCalibration, margin_m: float) -> FloorArea:
        """The floor seen by the calibrated camera: its image border mapped to the floor.

        Without an image size, the hull of the calibration's floor points. Raises
        :class:`ConfigurationError` when the calibration gives neither.
        """
        if calibration.image_size_px:
            width, height = calibration.image_size_px
            t = np.linspace(0.0, 1.0, BORDER_POINTS_PER_EDGE, endpoint=False)
            border = np.concatenate([np.column_stack([t * width, np.zeros_like(t)]),
                                     np.column_stack([np.full_like(t, width), t * height]),
                                     np.column_stack([(1 - t) * width, np.full_like(t, height)]),
                                     np.column_stack([np.zeros_like(t), (1 - t) * height])])
            polygon = calibration.image_to_floor(border)
        elif len(calibration.floor_m) >= 3:
            polygon = _convex_hull(np.asarray(calibration.floor_m, dtype=np.float64))
        else:
            raise ConfigurationError(f"{calibration.source}: the calibration has no image_size_px and fewer than 3 "
                                     "floor points; the navigator cannot tell which floor the camera sees.")
        if _signed_area(polygon) < 0.0:
            polygon = polygon[::-1]
        return cls(np.asarray(polygon, dtype=np.float64), float(margin_m), calibration.source)

    @property
    def extent_text(self) -> str:
        """``x -1.43 .. 1.43 m, y -1.08 .. 1.08 m`` of the polygon."""
        low, high = self.polygon_m.min(axis=0), self.polygon_m.max(axis=0)
        return f"x {low[0]:.2f} .. {high[0]:.2f} m, y {low[1]:.2f} .. {high[1]:.2f} m"

    def _nearest_edge(self, x_m: float, y_m: float) -> tuple[int, float]:
        """Index of the polygon's edge nearest the point (from vertex i to i + 1) and the distance to it (m)."""
        point = np.array([x_m, y_m], dtype=np.float64)
        start, end = self.polygon_m, np.roll(self.polygon_m, -1, axis=0)
        edge = end - start
        t = np.clip(np.einsum("ij,ij->i", point - start, edge) / np.einsum("ij,ij->i", edge, edge), 0.0, 1.0)
        distances = np.linalg.norm(point - (start + t[:, None] * edge), axis=1)
        index = int(np.argmin(distances))
        return index, float(distances[index])

    def inside_distance_m(self, x_m: float, y_m: float) -> float:
        """Distance (m) from the point to the polygon's edge: positive inside, negative outside."""
        distance = self._nearest_edge(x_m, y_m)[1]
        return distance if self.contains_point(x_m, y_m) else -distance

    def inward_normal(self, x_m: float, y_m: float) -> np.ndarray:
        """Unit vector (2,) from the point's nearest edge into the area (either orientation of the polygon)."""
        index = self._nearest_edge(x_m, y_m)[0]
        edge = np.roll(self.polygon_m, -1, axis=0)[index] - self.polygon_m[index]
        along = edge / np.linalg.norm(edge)
        left = np.array([-along[1], along[0]])  # left of a counter-clockwise edge is inside
        return left if _signed_area(self.polygon_m) > 0.0 else -left

    def leaving_by_m(self, track: np.ndarray, within_m: float, closer_by_m: float) -> float | None:
        """How far inside (m) the track's last point lies when the track is leaving the area; else None.

        Leaving: the last point within ``within_m`` of the edge and at least ``closer_by_m`` closer to it than the
        first point. ``track``: rows of time_s, x_m, y_m (and more), oldest first (:meth:`PoseHistory.window`).
        """
        if len(track) < 2:
            return None
        inside_m = self.inside_distance_m(track[-1, 1], track[-1, 2])
        if inside_m >= within_m or self.inside_distance_m(track[0, 1], track[0, 2]) - inside_m < closer_by_m:
            return None
        return inside_m

    def contains_point(self, x_m: float, y_m: float) -> bool:
        """True when the point lies inside the polygon (edge ignored; ray casting)."""
        x, y = self.polygon_m[:, 0], self.polygon_m[:, 1]
        x2, y2 = np.roll(x, -1), np.roll(y, -1)
        crosses = (y > y_m) != (y2 > y_m)
        with np.errstate(divide="ignore", invalid="ignore"):
            at_x = x + (y_m - y) * (x2 - x) / (y2 - y)
        return bool(np.count_nonzero(crosses & (x_m < at_x)) % 2)

    def refusal(self, x_m: float, y_m: float) -> str:
        """'' if a goal at the point is allowed, else why not (for the person who sent it)."""
        if not (np.isfinite(x_m) and np.isfinite(y_m)):
            return f"goal ({x_m}, {y_m}) is not a finite floor position (m)"
        inside = self.inside_distance_m(x_m, y_m)
        if inside >= self.margin_m:
            return ""
        where = (f"{-inside:.2f} m outside the camera's calibrated floor area" if inside < 0 else
                 f"only {inside:.2f} m inside the camera's calibrated floor area")
        return (f"goal ({x_m:.3f}, {y_m:.3f}) m is {where} ({self.extent_text}, from {self.source}); a goal must "
                f"lie at least view_margin_m = {self.margin_m:g} m inside it so the whole body stays in view")


def _signed_area(polygon: np.ndarray) -> float:
    x, y = polygon[:, 0], polygon[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _convex_hull(points: np.ndarray) -> np.ndarray:
    """Counter-clockwise convex hull (monotone chain) of ``points`` (n, 2)."""
    pts = sorted(map(tuple, np.unique(points, axis=0)))

    def half(sequence):
        hull: list[tuple[float, float]] = []
        for p in sequence:
            while len(hull) >= 2 and _turn(hull[-2], hull[-1], p) <= 0.0:
                hull.pop()
            hull.append(p)
        return hull[:-1]

    return np.array(half(pts) + half(pts[::-1]), dtype=np.float64)


def _turn(a, b, c) -> float:
    """Z of (b - a) x (c - a): > 0 for a left turn."""
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
