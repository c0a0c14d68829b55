"""ArUco markers through either OpenCV API: the classes of OpenCV >= 4.7 or the functions of 4.6.

OpenCV 4.7 replaced ``cv2.aruco``'s functions (``DetectorParameters_create``, ``detectMarkers``,
``drawMarker``) by classes (``DetectorParameters()``, ``ArucoDetector``, ``generateImageMarker``).
Ubuntu 24.04's ``python3-opencv`` (the rosdep key) is 4.6, where ``DetectorParameters()`` builds an
empty object that crashes the interpreter on first use; so every ArUco call of srs_ros goes through
this module, which picks the API that the installed OpenCV has. :func:`require_aruco` refuses, with
what to install, an OpenCV without ``cv2.aruco`` or older than 4.6.
"""

from __future__ import annotations

import re

import cv2
import numpy as np

from srs_ros.core.errors import ConfigurationError

#: Oldest OpenCV whose ArUco API srs_ros supports (Ubuntu 24.04's python3-opencv).
MIN_OPENCV_VERSION = (4, 6)
#: What to install for a supported OpenCV with ArUco, printed when it is missing.
INSTALL_HINT = ("on Ubuntu 24.04 / ROS 2 Jazzy: `sudo apt install python3-opencv` (4.6, rosdep key python3-opencv); "
                "with pip: `pip install 'opencv-contrib-python-headless>=4.7'` (the contrib build has cv2.aruco)")


def opencv_version() -> tuple[int, ...]:
    """The installed OpenCV's version as numbers, e.g. (4, 6, 0)."""
    return tuple(int(part) for part in re.findall(r"\d+", cv2.__version__)[:3])


def has_class_api() -> bool:
    """True for OpenCV >= 4.7 (``cv2.aruco.ArucoDetector``), False for 4.6's function API."""
    return hasattr(cv2.aruco, "ArucoDetector")


def require_aruco() -> None:
    """Raise :class:`ConfigurationError` unless OpenCV >= 4.6 with ``cv2.aruco`` is installed, saying what to get."""
    found = f"found OpenCV {cv2.__version__}"
    if opencv_version()[:2] < MIN_OPENCV_VERSION:
        raise ConfigurationError(f"ArUco tracking needs OpenCV >= {'.'.join(map(str, MIN_OPENCV_VERSION))}; "
                                 f"{found}. Install it: {INSTALL_HINT}.")
    aruco = getattr(cv2, "aruco", None)
    if aruco is None or not (has_class_api() or hasattr(aruco, "DetectorParameters_create")):
        raise ConfigurationError(f"ArUco tracking needs OpenCV's aruco module (cv2.aruco); {found} without it "
                                 f"(opencv-python instead of the contrib build?). Install it: {INSTALL_HINT}.")


def dictionary(name: str):
    """The predefined ``cv2.aruco`` dictionary called ``name`` (e.g. ``DICT_4X4_50``)."""
    require_aruco()
    value = getattr(cv2.aruco, name, None) if name.startswith("DICT_") else None
    if not isinstance(value, int):
        known = sorted(n for n in dir(cv2.aruco) if n.startswith("DICT_"))
        raise ConfigurationError(f"unknown ArUco dictionary {name!r}; expected one of {', '.join(known)}.")
    return cv2.aruco.getPredefinedDictionary(value)


def marker_count(name: str) -> int:
    """How many markers the predefined dictionary ``name`` holds: its ids are 0 .. count - 1 (DICT_4X4_50: 50)."""
    return int(dictionary(name).bytesList.shape[0])


def expected_marker_id(name: str, marker_id: int) -> str | None:
    """None when ``marker_id`` is one of dictionary ``name``'s ids, else what is expected (for a refusal)."""
    count = marker_count(name)
    return None if 0 <= marker_id < count else f"an id of {name}, 0..{count - 1} (it holds {count} markers)"


def detector_parameters(**fields):
    """Detector parameters with OpenCV's defaults, then ``fields`` (e.g. ``cornerRefinementMethod=...``) set."""
    require_aruco()
    params = cv2.aruco.DetectorParameters() if has_class_api() else cv2.aruco.DetectorParameters_create()
    for name, value in fields.items():
        if not hasattr(params, name):
            raise ConfigurationError(f"ArUco detector parameter {name!r} does not exist in OpenCV {cv2.__version__}.")
        setattr(params, name, value)
    return params


class MarkerDetector:
    """``detect(gray) -> (corners (k, 4, 2) float64, ids (k,))`` with one dictionary and parameter set."""

    def __init__(self, dictionary_name: str, params=None):
        """``params`` from :func:`detector_parameters` (default: OpenCV's defaults)."""
        self.dictionary = dictionary(dictionary_name)
        self.params = params if params is not None else detector_parameters()
        self._detector = cv2.aruco.ArucoDetector(self.dictionary, self.params) if has_class_api() else None

    def detect(self, gray: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Markers in a single-channel 8-bit image: corners in ArUco order (top-left first, clockwise) and ids."""
        if self._detector is not None:
            corners, ids, _ = self._detector.detectMarkers(gray)
        else:
            corners, ids, _ = cv2.aruco.detectMarkers(gray, self.dictionary, parameters=self.params)
        if ids is None or len(ids) == 0:
            return np.zeros((0, 4, 2)), np.zeros(0, dtype=int)
        return np.array(corners, dtype=np.float64).reshape(-1, 4, 2), ids.ravel().astype(int)


def marker_image(dictionary_name: str, marker_id: int, side_px: int) -> np.ndarray:
    """The image (side_px x side_px, uint8) of marker ``marker_id``, black border included, no quiet zone."""
    chosen = dictionary(dictionary_name)
    if hasattr(cv2.aruco, "generateImageMarker"):
        return cv2.aruco.generateImageMarker(chosen, int(marker_id), int(side_px))
    return cv2.aruco.drawMarker(chosen, int(marker_id), int(side_px))
