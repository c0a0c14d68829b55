"""Floor-plane calibration of a fixed overhead camera: the homography from image pixels to floor metres.

The paper tracked the robot "with image perspective projection" onto the floor (Sec. IV). A plane seen
by a pinhole camera maps to the image by a homography ``H`` (3 x 3, defined up to scale), so four or more
known floor points and their pixels fix it. This module fits ``H`` (:mod:`srs_ros.core.vision.homography`:
normalised DLT, then Gauss-Newton on the floor-side error, a step kept only when it lowers that error), maps
batches of points through it, reports the reprojection error in millimetres, and reads and writes the
calibration YAML (``config/camera_calibration.yaml``). Exactly four pairs fix ``H`` exactly: their reprojection
error is 0 by construction and says nothing about the fit's accuracy (a fifth pair or more gives an error
estimate). No ROS imports.

Lens distortion (wide-angle cameras): the file may hold the camera's intrinsics as ``sensor_msgs/CameraInfo``
names them (``distortion_model``, ``k`` the 3 x 3 camera matrix row by row, ``d`` the coefficients; what
the ROS ``camera_calibration`` tool writes). When present, pixels are undistorted first and the homography
maps *undistorted* pixels to the floor. Models: ``plumb_bob`` (k1, k2, p1, p2[, k3]), ``rational_polynomial``
(k1, k2, p1, p2, k3, k4, k5, k6) and ``equidistant`` (fisheye, k1..k4), as in OpenCV.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from srs_ros.core.errors import ConfigurationError, InvalidInputError
from srs_ros.core.files import write_atomically
from srs_ros.core.robot import config_dir, read_yaml
from srs_ros.core.schema import REQUIRED, Field, Table, document, missing, read_csv_rows, refusal
from srs_ros.core.vision.homography import (
    MIN_POINT_PAIRS,
    apply_homography,
    apply_homography_keeping_nan,
    fit_homography,
    reprojection_errors_mm,  # noqa: F401 (public here too, as before the homography had a module of its own)
)
from srs_ros.core.vision.homography import points_array as _points

#: Top-level key of the calibration YAML.
CALIBRATION_KEY = "camera_calibration"
#: Name of the default calibration file in ``config/``.
DEFAULT_CALIBRATION_FILE = "camera_calibration.yaml"
#: Largest error (normalised image coordinates, about 1e-6 px) of an undistorted point that counts as solved.
UNDISTORT_TOLERANCE = 1e-9
#: Distortion models (sensor_msgs/CameraInfo names) -> allowed numbers of coefficients.
DISTORTION_MODELS = {"plumb_bob": (4, 5), "rational_polynomial": (8,), "equidistant": (4,)}

#: A lens as sensor_msgs/CameraInfo names it: the calibration file's ``intrinsics:`` section.
INTRINSICS_TABLE = Table(f"{CALIBRATION_KEY}.intrinsics", (
    Field("distortion_model", str, "plumb_bob", choices=tuple(DISTORTION_MODELS), description="the lens model"),
    Field("k", list, REQUIRED, item=float, length=9,
          expected_text="9 numbers, the camera matrix row by row (fx 0 cx 0 fy cy 0 0 1, fx and fy > 0)"),
    Field("d", list, REQUIRED, item=float, nonempty=True, expected_text="a list of the distortion coefficients"),
), description="a mapping with distortion_model, k and d (sensor_msgs/CameraInfo names)")

#: One point pair of a calibration: a pixel and the floor point it shows.
POINT_PAIR_TABLE = Table(f"{CALIBRATION_KEY}.point_pairs", (
    Field("u_px", float, unit="px", description="pixel column"),
    Field("v_px", float, unit="px", description="pixel row"),
    Field("x_m", float, unit="m", description="floor x"),
    Field("y_m", float, unit="m", description="floor y"),
), description="a mapping with u_px, v_px, x_m, y_m")

#: The ``camera_calibration:`` section of a calibration file (``config/camera_calibration.yaml``).
#: The floor frame a calibration maps pixels into unless told otherwise (the frame every pose of the package is in).
DEFAULT_FRAME_ID = "floor"

CALIBRATION_TABLE = Table(CALIBRATION_KEY, (
    Field("frame_id", str, DEFAULT_FRAME_ID, nonempty=True, description="the floor frame the poses are given in"),
    Field("homography_image_to_floor", object, None, expected_text="a finite, invertible 3 x 3 list of rows"),
    Field("point_pairs", list, None, item=dict, expected_text="a list of {u_px, v_px, x_m, y_m} mappings"),
    Field("image_size_px", list, None, 1, 100_000, unit="px", item=int, length=2, description="[width, height]"),
    Field("intrinsics", dict, None, expected_text=INTRINSICS_TABLE.description),
    Field("reprojection_rms_mm", float, None, 0.0, unit="mm", description="written by srs_calibrate_camera"),
    Field("reprojection_max_mm", float, None, 0.0, unit="mm", description="written by srs_calibrate_camera"),
), description="a mapping with frame_id, homography_image_to_floor or point_pairs, image_size_px, intrinsics")


@dataclass(frozen=True, eq=False)
class CameraIntrinsics:
    """Camera matrix K (3 x 3, pixels) and lens distortion ``distortion`` of ``model`` (CameraInfo ``k``, ``d``).

    :meth:`distort_px` maps ideal (pinhole) pixels to the pixels a real lens gives, :meth:`undistort_px`
    the reverse; both batched over ``(..., 2)`` and equal to OpenCV's ``projectPoints`` / ``fisheye``
    (which assume zero skew, as camera calibrations give).
    """

    camera_matrix: np.ndarray
    distortion: np.ndarray
    model: str = "plumb_bob"

    def __post_init__(self):
        k = np.asarray(self.camera_matrix, dtype=np.float64).reshape(-1)
        d = np.asarray(self.distortion, dtype=np.float64).reshape(-1)
        if self.model not in DISTORTION_MODELS:
            raise ConfigurationError(f"distortion_model {self.model!r}; expected one of {sorted(DISTORTION_MODELS)}.")
        if k.size != 9 or not np.all(np.isfinite(k)) or k[0] <= 0 or k[4] <= 0:
            raise ConfigurationError(f"camera matrix k {k.tolist()}; expected 9 finite numbers: fx 0 cx 0 fy cy 0 0 1.")
        if d.size not in DISTORTION_MODELS[self.model] or not np.all(np.isfinite(d)):
            raise ConfigurationError(f"distortion d {d.tolist()}: {self.model} takes "
                                     f"{' or '.join(map(str, DISTORTION_MODELS[self.model]))} finite coefficients.")
        object.__setattr__(self, "camera_matrix", k.reshape(3, 3))
        object.__setattr__(self, "distortion", np.pad(d, (0, 8 - d.size)) if self.model != "equidistant" else d)

    def _to_normalised(self, pixels: np.ndarray) -> np.ndarray:
        k = self.camera_matrix
        return np.stack([(pixels[..., 0] - k[0, 2] - k[0, 1] * (pixels[..., 1] - k[1, 2]) / k[1, 1]) / k[0, 0],
                         (pixels[..., 1] - k[1, 2]) / k[1, 1]], axis=-1)

    def _to_pixels(self, normalised: np.ndarray) -> np.ndarray:
        k = self.camera_matrix
        x, y = normalised[..., 0], normalised[..., 1]
        return np.stack([k[0, 0] * x + k[0, 1] * y + k[0, 2], k[1, 1] * y + k[1, 2]], axis=-1)

    def _distort(self, xy: np.ndarray) -> np.ndarray:
        """Normalised ideal -> normalised distorted coordinates."""
        x, y = xy[..., 0], xy[..., 1]
        r2 = x * x + y * y
        if self.model == "equidistant":
            r = np.sqrt(r2)
            theta = np.arctan(r)
            t2 = theta * theta
            k1, k2, k3, k4 = self.distortion
            theta_d = theta * (1 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))
            ratio = np.where(r > 1e-12, theta_d / np.where(r > 1e-12, r, 1.0), 1.0)
            return xy * ratio[..., None]
        k1, k2, p1, p2, k3, k4, k5, k6 = self.distortion
        radial = (1 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (1 + r2 * (k4 + r2 * (k5 + r2 * k6)))
        return np.stack([x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
                         y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y], axis=-1)

    def distort_px(self, points_px: Any) -> np.ndarray:
        """Ideal pinhole pixels (..., 2) -> the pixels where the lens puts them."""
        return self._to_pixels(self._distort(self._to_normalised(_points("points_px", points_px))))

    def undistort_px(self, points_px: Any, iterations: int = 100) -> np.ndarray:
        """Observed pixels (..., 2) -> ideal pinhole pixels (Gauss-Newton on :meth:`distort_px`, to 1e-12).

        A pixel the lens model cannot give back comes out as NaN, never as a guess: where the model has no
        inverse (a pixel beyond the largest radius it reaches, e.g. a strong barrel k1 at the image's corners),
        the solver ends past the model's fold (radial factor <= 0, a mirrored point) or does not converge.
        """
        target = self._to_normalised(_points("points_px", points_px))
        xy = target.copy()
        step = 1e-7
        for _ in range(iterations):
            residual = self._distort(xy) - target
            if not np.any(np.abs(residual) >= 1e-12):  # NaN (a point already lost) counts as done
                break
            # 2 x 2 Jacobian by central differences (the maps are smooth), solved per point.
            jx, jy = self._jacobian(xy, step)
            det = jx[..., 0] * jy[..., 1] - jy[..., 0] * jx[..., 1]
            det = np.where(np.abs(det) > 1e-15, det, 1e-15)
            dx = (jy[..., 1] * residual[..., 0] - jy[..., 0] * residual[..., 1]) / det
            dy = (jx[..., 0] * residual[..., 1] - jx[..., 1] * residual[..., 0]) / det
            xy = xy - np.stack([dx, dy], axis=-1)
        return self._to_pixels(np.where(self._inverted(xy, target, step)[..., None], xy, np.nan))

    def _jacobian(self, xy: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
        """The lens model's derivatives along x and along y (..., 2) at normalised ``xy``, by central differences."""
        jx = (self._distort(xy + [step, 0.0]) - self._distort(xy - [step, 0.0])) / (2 * step)
        jy = (self._distort(xy + [0.0, step]) - self._distort(xy - [0.0, step])) / (2 * step)
        return jx, jy

    def _inverted(self, xy: np.ndarray, target: np.ndarray, step: float) -> np.ndarray:
        """Where ``xy`` is a valid undistortion of ``target``: converged, finite, on the lens model's unfolded side."""
        with np.errstate(invalid="ignore", over="ignore"):
            converged = np.all(np.abs(self._distort(xy) - target) < UNDISTORT_TOLERANCE, axis=-1)
            jx, jy = self._jacobian(xy, step)
            unfolded = jx[..., 0] * jy[..., 1] - jy[..., 0] * jx[..., 1] > 0
            if self.model != "equidistant":
                k1, k2, _, _, k3, k4, k5, k6 = self.distortion
                r2 = np.sum(xy * xy, axis=-1)
                radial = (1 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (1 + r2 * (k4 + r2 * (k5 + r2 * k6)))
                unfolded &= radial > 0
        return converged & unfolded & np.all(np.isfinite(xy), axis=-1)

    def to_dict(self) -> dict[str, Any]:
        """The ``intrinsics:`` mapping of the calibration file (CameraInfo names)."""
        d = self.distortion if self.model == "equidistant" else self.distortion[:8 if self.model != "plumb_bob" else 5]
        return {"distortion_model": self.model, "k": [float(v) for v in self.camera_matrix.ravel()],
                "d": [float(v) for v in d]}

    @classmethod
    def from_dict(cls, data: Any, source: str = "<intrinsics>", path: str = "") -> CameraIntrinsics:
        """From CameraInfo names (``k``, ``d``, ``distortion_model``) or the ROS camera_calibration YAML.

        The latter (``camera_matrix: {data: [...]}``, ``distortion_coefficients: {data: [...]}``,
        ``distortion_model``) is what ``ros2 run camera_calibration cameracalibrator`` saves. ``path`` is
        the mapping's dotted key in ``source`` ('' at the top); refusals are the schema's
        (:data:`INTRINSICS_TABLE`).
        """
        table = INTRINSICS_TABLE.at(path)
        if isinstance(data, Mapping) and ("k" in data or "d" in data or not data):
            values = table.read(data, source)
        else:
            if not isinstance(data, Mapping):
                raise refusal(source, path or "the content", data, table.description)
            values = {"distortion_model": table["distortion_model"].check(
                data.get("distortion_model", "plumb_bob"), source, table.key("distortion_model"))}
            for name, block in (("k", "camera_matrix"), ("d", "distortion_coefficients")):
                key, nested = table.key(f"{block}.data"), data.get(block)
                if not isinstance(nested, Mapping) or "data" not in nested:
                    raise missing(source, key, table[name].expected)
                values[name] = table[name].check(nested["data"], source, key)
        model, k, d = values["distortion_model"], values["k"], values["d"]
        if len(d) not in DISTORTION_MODELS[model]:
            counts = " or ".join(map(str, DISTORTION_MODELS[model]))
            raise refusal(source, table.key("d"), list(d), f"{counts} coefficients for {model}")
        if k[0] <= 0 or k[4] <= 0:
            raise refusal(source, table.key("k"), list(k), table["k"].expected)
        return cls(np.asarray(k, dtype=np.float64), np.asarray(d, dtype=np.float64), model)


def load_intrinsics(path: str | Path) -> CameraIntrinsics:
    """Intrinsics from a YAML file: a ROS camera_calibration file, CameraInfo fields, or a calibration file."""
    data = read_yaml(path)
    if isinstance(data, Mapping) and isinstance(data.get(CALIBRATION_KEY), Mapping):
        return CameraIntrinsics.from_dict(data[CALIBRATION_KEY].get("intrinsics"), str(path),
                                          CALIBRATION_TABLE.key("intrinsics"))
    return CameraIntrinsics.from_dict(data, str(path))


@dataclass(frozen=True)
class CameraCalibration:
    """Image -> floor homography of one camera, with the point pairs it came from and their error.

    With ``intrinsics`` the homography maps undistorted pixels; :meth:`image_to_floor` and
    :meth:`floor_to_image` take and give the camera's real (distorted) pixels either way.
    """

    homography_image_to_floor: np.ndarray
    image_px: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    floor_m: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    image_size_px: tuple[int, int] | None = None
    frame_id: str = DEFAULT_FRAME_ID
    source: str = field(default="<memory>", compare=False)
    intrinsics: CameraIntrinsics | None = field(default=None, compare=False)

    @property
    def homography_floor_to_image(self) -> np.ndarray:
        """Inverse homography (floor metres -> image pixels), scaled so that ``[2, 2] = 1``."""
        inv = np.linalg.inv(self.homography_image_to_floor)
        return inv / inv[2, 2]

    @property
    def reprojection_errors_mm(self) -> np.ndarray:
        """Per-pair floor-side error (mm) of the stored point pairs."""
        if len(self.image_px) == 0:
            return np.zeros(0)
        return 1000.0 * np.linalg.norm(self.image_to_floor(self.image_px) - self.floor_m, axis=-1)

    @property
    def rms_error_mm(self) -> float:
        """Root-mean-square reprojection error (mm) over the point pairs (0 with no pairs)."""
        errors = self.reprojection_errors_mm
        return float(np.sqrt(np.mean(errors**2))) if len(errors) else 0.0

    @property
    def max_error_mm(self) -> float:
        """Largest reprojection error (mm) over the point pairs (0 with no pairs)."""
        errors = self.reprojection_errors_mm
        return float(errors.max()) if len(errors) else 0.0

    def undistort_px(self, points_px: Any) -> np.ndarray:
        """The camera's pixels (..., 2) -> ideal pinhole pixels (unchanged without intrinsics)."""
        return self.intrinsics.undistort_px(points_px) if self.intrinsics else _points("points_px", points_px)

    def image_to_floor(self, points_px: Any) -> np.ndarray:
        """Pixels (..., 2) -> floor metres (..., 2); NaN for a pixel the lens model cannot undistort."""
        return apply_homography_keeping_nan(self.homography_image_to_floor, self.undistort_px(points_px))

    def floor_to_image(self, points_m: Any) -> np.ndarray:
        """Floor metres (..., 2) -> pixels (..., 2)."""
        ideal = apply_homography(self.homography_floor_to_image, points_m)
        return self.intrinsics.distort_px(ideal) if self.intrinsics else ideal


def calibration_from_pairs(image_px: Any, floor_m: Any, image_size_px: tuple[int, int] | None = None,
                           frame_id: str = DEFAULT_FRAME_ID, intrinsics: CameraIntrinsics | None = None
                           ) -> CameraCalibration:
    """Fit a :class:`CameraCalibration` from n >= 4 (pixel, floor metre) pairs (pixels undistorted first)."""
    image_px = _points("image_px", image_px).reshape(-1, 2)
    floor_m = _points("floor_m", floor_m).reshape(-1, 2)
    h = fit_homography(_ideal_pixels(image_px, intrinsics), floor_m)
    return CameraCalibration(h, image_px, floor_m, image_size_px, frame_id, intrinsics=intrinsics)


def _ideal_pixels(image_px: np.ndarray, intrinsics: CameraIntrinsics | None) -> np.ndarray:
    """The pairs' pixels undistorted (as given without intrinsics); a pixel the lens cannot undistort is refused."""
    if intrinsics is None:
        return image_px
    ideal = intrinsics.undistort_px(image_px)
    lost = np.flatnonzero(~np.all(np.isfinite(ideal), axis=-1))
    if len(lost):
        raise InvalidInputError(
            f"pixel {image_px[lost[0]].tolist()} (pair {lost[0] + 1}) cannot be undistorted: the lens model "
            f"({intrinsics.model}, d {intrinsics.to_dict()['d']}) has no inverse there; check the intrinsics "
            "or leave that pair out.")
    return ideal


def calibration_from_dict(data: Any, source: str = "<dict>") -> CameraCalibration:
    """Build a calibration from the parsed YAML; the stored homography wins, else it is fitted from the pairs.

    Checked by the schema (:data:`CALIBRATION_TABLE`, :data:`POINT_PAIR_TABLE`, :data:`INTRINSICS_TABLE`): a
    refusal names the file, the key, the value and what is expected.
    """
    values = CALIBRATION_TABLE.read(document(data, CALIBRATION_KEY, source, what=CALIBRATION_TABLE.description,
                                             sections=CALIBRATION_TABLE.names), source)
    pairs = [POINT_PAIR_TABLE.at(f"{POINT_PAIR_TABLE.path}[{i}]").read(pair, source)
             for i, pair in enumerate(values["point_pairs"] or ())]
    image_px, floor_m = _pair_arrays(pairs)
    intrinsics = None
    if values["intrinsics"] is not None:
        intrinsics = CameraIntrinsics.from_dict(values["intrinsics"], source, CALIBRATION_TABLE.key("intrinsics"))
    stored, key = values["homography_image_to_floor"], CALIBRATION_TABLE.key("homography_image_to_floor")
    try:
        if stored is not None:
            h = _stored_homography(stored, source, key)
        elif len(image_px) >= MIN_POINT_PAIRS:
            h = fit_homography(_ideal_pixels(image_px, intrinsics), floor_m)
        else:
            raise missing(source, key, f"{CALIBRATION_TABLE['homography_image_to_floor'].expected}, or at least "
                          f"{MIN_POINT_PAIRS} point_pairs to fit it from; run srs_calibrate_camera to create them")
    except InvalidInputError as exc:
        raise ConfigurationError(f"{source}: {exc}") from exc
    size = values["image_size_px"]
    return CameraCalibration(h, image_px, floor_m, tuple(size) if size else None, values["frame_id"], source,
                             intrinsics)


def _pair_arrays(pairs: list[dict[str, float]]) -> tuple[np.ndarray, np.ndarray]:
    """(image_px (n, 2), floor_m (n, 2)) of checked point pairs."""
    image_px = np.array([[p["u_px"], p["v_px"]] for p in pairs], dtype=np.float64).reshape(-1, 2)
    floor_m = np.array([[p["x_m"], p["y_m"]] for p in pairs], dtype=np.float64).reshape(-1, 2)
    return image_px, floor_m


def _stored_homography(stored: Any, source: str, key: str) -> np.ndarray:
    """The file's homography scaled so that ``[2, 2] = 1``; refused unless a finite, invertible 3 x 3."""
    expected = CALIBRATION_TABLE["homography_image_to_floor"].expected
    try:
        h = np.asarray(stored, dtype=np.float64)
    except (TypeError, ValueError):
        raise refusal(source, key, stored, expected) from None
    if h.shape != (3, 3) or not np.all(np.isfinite(h)) or abs(np.linalg.det(h)) < 1e-15 or h[2, 2] == 0.0:
        raise refusal(source, key, stored, expected)
    return h / h[2, 2]


def load_calibration(path: str | Path | None = None) -> CameraCalibration:
    """Read a calibration YAML (default: the package's ``config/camera_calibration.yaml``)."""
    path = Path(path) if path else config_dir() / DEFAULT_CALIBRATION_FILE
    return calibration_from_dict(read_yaml(path), source=str(path))


def calibration_to_dict(calibration: CameraCalibration) -> dict[str, Any]:
    """The YAML mapping of a calibration (plain floats and lists)."""
    section: dict[str, Any] = {
        "frame_id": calibration.frame_id,
        "homography_image_to_floor": [[float(v) for v in row] for row in calibration.homography_image_to_floor],
        "reprojection_rms_mm": round(calibration.rms_error_mm, 4),
        "reprojection_max_mm": round(calibration.max_error_mm, 4),
        "point_pairs": [
            {"u_px": float(u), "v_px": float(v), "x_m": float(x), "y_m": float(y)}
            for (u, v), (x, y) in zip(calibration.image_px, calibration.floor_m)
        ],
    }
    if calibration.image_size_px:
        section["image_size_px"] = [int(v) for v in calibration.image_size_px]
    if calibration.intrinsics is not None:
        section["intrinsics"] = calibration.intrinsics.to_dict()
    return {CALIBRATION_KEY: section}


def save_calibration(calibration: CameraCalibration, path: str | Path, comment: str = "") -> Path:
    """Write the calibration YAML to ``path`` (folders created); returns the path.

    The mapping is first read back through the schema (:func:`calibration_from_dict`): a calibration the loader would
    refuse (an image size of 0, an empty frame) is a :class:`ConfigurationError` and nothing is written, so a file
    that srs_track, camera_tracker and the navigator cannot load never replaces a good one.
    """
    path = Path(path)
    data = calibration_to_dict(calibration)
    calibration_from_dict(data, source=f"the calibration to be written to {path}")
    path.parent.mkdir(parents=True, exist_ok=True)
    header = "".join(f"# {line}\n" for line in comment.splitlines()) if comment else ""
    text = yaml.safe_dump(data, sort_keys=False, default_flow_style=None)
    write_atomically(path, header + text)  # a full disk mid-write left a good file cut short (a helper's review)
    return path


def read_point_pairs(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read (image_px (n, 2), floor_m (n, 2)) from a CSV (header u_px,v_px,x_m,y_m) or a YAML file.

    The YAML form is the ``point_pairs`` list of the calibration file, at top level or under
    ``camera_calibration:``. Both are checked by the schema (:data:`POINT_PAIR_TABLE`).
    """
    path = Path(path)
    if path.suffix.lower() == ".csv":
        return _pair_arrays(read_csv_rows(path, POINT_PAIR_TABLE))
    data = read_yaml(path)
    if isinstance(data, Mapping) and CALIBRATION_KEY in data:
        data = data[CALIBRATION_KEY]
    if not isinstance(data, Mapping) or "point_pairs" not in data:
        raise missing(str(path), "point_pairs", CALIBRATION_TABLE["point_pairs"].expected)
    calib = calibration_from_dict({CALIBRATION_KEY: {"point_pairs": data["point_pairs"],
                                                     "homography_image_to_floor": np.eye(3).tolist()}}, str(path))
    return calib.image_px, calib.floor_m
