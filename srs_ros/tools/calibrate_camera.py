"""``srs_calibrate_camera``: compute and save the camera's image -> floor homography, and report its error.

Two ways in:

* ``--pairs pairs.csv|pairs.yaml``: four or more measured point pairs (CSV header ``u_px,v_px,x_m,y_m``,
  or a YAML ``point_pairs:`` list of ``{u_px, v_px, x_m, y_m}``);
* ``--image floor.png --markers layout.yaml``: a photo of ArUco markers laid at known floor positions.
  ``layout.yaml`` holds ``aruco_dictionary`` (default DICT_4X4_50), optionally ``marker_size_m`` (then all
  four corners of each marker are used, else only centres, so at least four markers) and
  ``markers: [{id, x_m, y_m, yaw_rad}]`` (marker centre on the floor; yaw 0 = the marker's top edge
  faces floor +Y).

``--intrinsics camera.yaml`` adds a wide-angle camera's lens model: the YAML that ROS's
``camera_calibration`` tool saves (``camera_matrix``, ``distortion_model``, ``distortion_coefficients``),
CameraInfo fields (``k``, ``d``, ``distortion_model``) or another calibration file with an ``intrinsics:``
section. Pixels are then undistorted before the fit, and the intrinsics are saved with the homography.

The result goes to ``--out`` (default ``config/camera_calibration.yaml``) with the reprojection error
(mm) of every point; with ``--max-rms-mm`` a poorer fit is rejected: nothing is written (the old file
stays) and the exit status is 1. Exactly four point pairs fix the homography exactly: their error is 0 by
construction and says nothing about the fit (no error estimate); five or more give one.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Mapping
from typing import Any

import cv2
import numpy as np

from srs_ros.core.errors import ConfigurationError, SrsError
from srs_ros.core.robot import config_dir, read_yaml
from srs_ros.core.schema import REQUIRED, Field, Table, refusal
from srs_ros.core.vision import aruco
from srs_ros.core.vision.camera_calibration import (
    CALIBRATION_TABLE,
    DEFAULT_CALIBRATION_FILE,
    DEFAULT_FRAME_ID,
    MIN_POINT_PAIRS,
    CameraCalibration,
    CameraIntrinsics,
    calibration_from_pairs,
    load_intrinsics,
    read_point_pairs,
    save_calibration,
)
from srs_ros.core.vision.tracking import DEFAULT_ARUCO_DICTIONARY, quad_centre
from srs_ros.tools.output import prepare_output_file


def marker_corners_floor_m(x_m: float, y_m: float, yaw_rad: float, size_m: float) -> np.ndarray:
    """Floor positions (4, 2) of a marker's corners in ArUco order (top-left, top-right, bottom-right, bottom-left).

    The marker's top edge faces its local +Y; ``yaw_rad`` turns the marker about the floor's +Z.
    """
    half = 0.5 * size_m
    local = np.array([[-half, half], [half, half], [half, -half], [-half, -half]])
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return local @ np.array([[c, s], [-s, c]]) + np.array([x_m, y_m])


#: The floor layout of ``--markers`` (the top level of its YAML), checked by the package's schema.
LAYOUT_TABLE = Table("", (
    Field("markers", list, REQUIRED, item=dict, expected_text="a non-empty list of {id, x_m, y_m, yaw_rad} mappings"),
    Field("marker_size_m", float, None, 0.0, 1.0, unit="m", above_minimum=True,
          description="the markers' side (then all four corners count, else only centres)"),
    Field("aruco_dictionary", str, DEFAULT_ARUCO_DICTIONARY, nonempty=True, description="the markers' dictionary"),
), "the floor layout of the markers")
#: One marker of the layout: its id and where its centre lies on the floor.
MARKER_TABLE = Table("markers[]", (
    Field("id", int, REQUIRED, 0, 1023, description="the marker's ArUco id"),
    Field("x_m", float, REQUIRED, -100.0, 100.0, unit="m", description="the marker's centre on the floor"),
    Field("y_m", float, REQUIRED, -100.0, 100.0, unit="m", description="the marker's centre on the floor"),
    Field("yaw_rad", float, 0.0, -2.0 * math.pi, 2.0 * math.pi, unit="rad",
          description="0: the marker's top edge faces floor +Y"),
), "a marker {id, x_m, y_m, yaw_rad}")


def read_layout(layout: Any, source: str) -> tuple[dict[int, tuple[float, float, float]], float | None, str]:
    """The checked layout: {id: (x_m, y_m, yaw_rad)}, the marker size (m, or None) and the dictionary's name."""
    values = LAYOUT_TABLE.read(layout, source)
    if not values["markers"]:
        raise refusal(source, "markers", [], LAYOUT_TABLE["markers"].expected)
    known: dict[int, tuple[float, float, float]] = {}
    for index, entry in enumerate(values["markers"]):
        marker = MARKER_TABLE.at(f"markers[{index}]").read(entry, source)
        if marker["id"] in known:
            raise refusal(source, f"markers[{index}].id", marker["id"], "an id not given to another marker")
        expected = aruco.expected_marker_id(values["aruco_dictionary"], marker["id"])
        if expected is not None:
            raise refusal(source, f"markers[{index}].id", marker["id"], expected)
        known[marker["id"]] = (marker["x_m"], marker["y_m"], marker["yaw_rad"])
    return known, values["marker_size_m"], values["aruco_dictionary"]


def pairs_from_marker_image(image: np.ndarray, layout: Mapping[str, Any], source: str = "<layout>",
                            intrinsics: CameraIntrinsics | None = None) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """Point pairs (image_px, floor_m) from ArUco markers laid at known floor positions; also the ids not found.

    Without ``marker_size_m`` each marker gives its centre: with ``intrinsics`` (a distorting lens) the centre of
    its undistorted corners (a square's centre is exact only in an undistorted image), put back through the lens,
    as the tracker takes it.
    """
    known, size_m, dictionary = read_layout(layout, source)
    detector = aruco.MarkerDetector(dictionary,
                                    aruco.detector_parameters(cornerRefinementMethod=cv2.aruco.CORNER_REFINE_SUBPIX))
    gray = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    corners, ids = detector.detect(gray)
    found = {int(i): q for q, i in zip(corners, ids)}
    image_px, floor_m = [], []
    for marker_id, (x, y, yaw) in known.items():
        if marker_id not in found:
            continue
        if size_m:
            image_px.append(found[marker_id])
            floor_m.append(marker_corners_floor_m(x, y, yaw, size_m))
        else:
            image_px.append(_marker_centre_px(found[marker_id], intrinsics)[None])
            floor_m.append(np.array([[x, y]]))
    missing = sorted(set(known) - set(found))
    if not image_px:
        raise ConfigurationError(f"{source}: none of the markers {sorted(known)} was found in the image.")
    return np.concatenate(image_px), np.concatenate(floor_m), missing


def _marker_centre_px(corners_px: np.ndarray, intrinsics: CameraIntrinsics | None) -> np.ndarray:
    """The camera pixel of a marker's centre: the diagonals' crossing of its undistorted corners."""
    if intrinsics is None:
        return quad_centre(corners_px)
    ideal = quad_centre(intrinsics.undistort_px(corners_px))
    if not np.all(np.isfinite(ideal)):
        raise ConfigurationError(f"marker corners {corners_px.round(1).tolist()} cannot be undistorted: the lens "
                                 "model has no inverse there; check the intrinsics.")
    return intrinsics.distort_px(ideal)


def report(calibration: CameraCalibration) -> str:
    """A table of every point pair's reprojection error and the summary (mm)."""
    lines = ["   u_px     v_px      x_m      y_m   error_mm"]
    for (u, v), (x, y), e in zip(calibration.image_px, calibration.floor_m, calibration.reprojection_errors_mm):
        lines.append(f"{u:8.2f} {v:8.2f} {x:8.4f} {y:8.4f} {e:9.3f}")
    lines.append(f"reprojection error over {len(calibration.image_px)} points: rms {calibration.rms_error_mm:.3f} mm, "
                 f"max {calibration.max_error_mm:.3f} mm")
    if len(calibration.image_px) == MIN_POINT_PAIRS:
        lines.append(f"note: {MIN_POINT_PAIRS} point pairs fix the homography exactly, so the error is 0 by "
                     "construction and gives no estimate of the fit's accuracy; add pairs (or markers) for one.")
    return "\n".join(lines)


def check_flags(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Refuse (``parser.error``, exit status 2) a flag the saved calibration could not hold, before any work."""
    if args.max_rms_mm is not None and not (math.isfinite(args.max_rms_mm) and args.max_rms_mm > 0.0):
        parser.error(f"--max-rms-mm {args.max_rms_mm}: expected a finite error above 0 mm")
    for flag, key, value in (("--image-size", "image_size_px", args.image_size), ("--frame-id", "frame_id",
                                                                                 args.frame_id)):
        field = CALIBRATION_TABLE[key]
        if value is not None and not field.convert(value)[0]:
            shown = " ".join(map(str, value)) if isinstance(value, list) else repr(value)
            parser.error(f"{flag} {shown}: expected {field.expected}")
    if args.image and not args.markers:
        parser.error("--image needs --markers (the floor layout YAML)")
    for flag, given, needs in (("--markers", args.pairs and args.markers, "--image"),
                               ("--image-size", args.image and args.image_size, "--pairs")):
        if given:  # ignored without a word before (the image gives its own size; pairs have no markers)
            parser.error(f"{flag} goes with {needs} only; leave it out")


def point_pairs(args: argparse.Namespace, intrinsics: CameraIntrinsics | None
                ) -> tuple[np.ndarray, np.ndarray, tuple[int, int] | None, str, list[int]]:
    """(image_px, floor_m, image size or None, where they came from, marker ids not found) of the flags."""
    if args.pairs:
        image_px, floor_m = read_point_pairs(args.pairs)
        if args.image_size:  # a pair outside the image is a typo or another camera's: it was saved as given
            width, height = args.image_size
            outside = np.flatnonzero((image_px[:, 0] < 0) | (image_px[:, 0] > width) | (image_px[:, 1] < 0)
                                     | (image_px[:, 1] > height))
            if outside.size:
                u, v = image_px[outside[0]]
                raise ConfigurationError(f"{args.pairs}: pair {outside[0] + 1} at ({u:g}, {v:g}) px lies outside "
                                         f"--image-size {width} {height}; expected pixels within the image.")
        return image_px, floor_m, tuple(args.image_size) if args.image_size else None, args.pairs, []
    image = cv2.imread(args.image, cv2.IMREAD_COLOR)
    if image is None:
        raise ConfigurationError(f"{args.image}: cannot be read as an image (missing file or unknown format).")
    image_px, floor_m, missing = pairs_from_marker_image(image, read_yaml(args.markers), args.markers, intrinsics)
    return image_px, floor_m, (image.shape[1], image.shape[0]), f"{args.image} + {args.markers}", missing


def main(argv: list[str] | None = None) -> int:
    """Console script ``srs_calibrate_camera``."""
    parser = argparse.ArgumentParser(prog="srs_calibrate_camera", description=__doc__.splitlines()[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--pairs", help="CSV or YAML file of point pairs (u_px, v_px, x_m, y_m)")
    group.add_argument("--image", help="image of ArUco markers laid on the floor (needs --markers)")
    parser.add_argument("--markers", help="YAML layout of the floor markers (with --image)")
    parser.add_argument("--image-size", type=int, nargs=2, metavar=("W", "H"), help="image size, px (with --pairs)")
    parser.add_argument("--frame-id", default=DEFAULT_FRAME_ID,
                        help=f"frame of the floor coordinates (default {DEFAULT_FRAME_ID})")
    parser.add_argument("--out", help=f"output YAML (default config/{DEFAULT_CALIBRATION_FILE})")
    parser.add_argument("--intrinsics", help="camera intrinsics YAML (K, D; ROS camera_calibration format)")
    parser.add_argument("--max-rms-mm", type=float, help="exit with status 1 if the rms error is above this, mm")
    args = parser.parse_args(argv)
    check_flags(parser, args)
    try:
        out = prepare_output_file(args.out or config_dir() / DEFAULT_CALIBRATION_FILE, "--out")
        intrinsics = load_intrinsics(args.intrinsics) if args.intrinsics else None
        image_px, floor_m, size, source, missing = point_pairs(args, intrinsics)
        calibration = calibration_from_pairs(image_px, floor_m, size, args.frame_id, intrinsics)
    except SrsError as exc:
        print(f"srs_calibrate_camera: {exc}", file=sys.stderr)
        return 2
    if missing:
        print(f"warning: markers not found in the image: {missing}", file=sys.stderr)
    print(report(calibration))
    if args.max_rms_mm is not None and calibration.rms_error_mm > args.max_rms_mm:
        print(f"rms error {calibration.rms_error_mm:.3f} mm is above --max-rms-mm {args.max_rms_mm}: not saved, "
              f"{out} is unchanged; re-measure the points or re-take the image.", file=sys.stderr)
        return 1
    try:
        save_calibration(calibration, out, f"srs_calibrate_camera from {source}\n"
                                           "homography_image_to_floor maps pixels (u, v, 1) to floor metres (x, y, 1).")
    except (ConfigurationError, OSError) as exc:
        print(f"srs_calibrate_camera: not saved, {out} is unchanged: {exc}", file=sys.stderr)
        return 2
    print(f"saved {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
