"""ArUco through either OpenCV API (>= 4.7 classes, 4.6 functions); an unsupported OpenCV is refused with what to get.

test/test_opencv46.py runs this file, the tracking tests and srs_track again under OpenCV 4.6.
"""

import cv2
import numpy as np
import pytest

from srs_ros.core.errors import ConfigurationError
from srs_ros.core.vision import aruco


def test_a_drawn_marker_is_found_with_its_corners_and_id():
    marker = aruco.marker_image("DICT_4X4_50", 7, 120)
    image = np.full((300, 320), 255, np.uint8)
    image[90:210, 100:220] = marker
    detector = aruco.MarkerDetector("DICT_4X4_50", aruco.detector_parameters(
        cornerRefinementMethod=cv2.aruco.CORNER_REFINE_SUBPIX))
    corners, ids = detector.detect(image)
    assert ids.tolist() == [7] and corners.shape == (1, 4, 2)
    np.testing.assert_allclose(corners[0], [[100, 90], [219, 90], [219, 209], [100, 209]], atol=1.0)
    assert detector.detect(np.full((50, 50), 128, np.uint8))[1].shape == (0,)


def test_unknown_names_are_refused_with_the_choices():
    with pytest.raises(ConfigurationError, match="unknown ArUco dictionary 'DICT_NOPE'.*DICT_4X4_50"):
        aruco.dictionary("DICT_NOPE")
    with pytest.raises(ConfigurationError, match="'cornerRefinment' does not exist"):
        aruco.detector_parameters(cornerRefinment=1)


def test_an_old_opencv_is_refused_with_the_version_needed_and_how_to_get_it(monkeypatch):
    monkeypatch.setattr(cv2, "__version__", "4.5.5")
    with pytest.raises(ConfigurationError, match=r"needs OpenCV >= 4\.6; found OpenCV 4\.5\.5.*python3-opencv.*"
                                                 r"opencv-contrib-python-headless>=4\.7"):
        aruco.MarkerDetector("DICT_4X4_50")


def test_an_opencv_without_aruco_is_refused(monkeypatch):
    monkeypatch.delattr(cv2, "aruco")
    with pytest.raises(ConfigurationError, match=r"aruco module.*contrib"):
        aruco.detector_parameters()


def test_the_api_matches_the_version():
    assert aruco.has_class_api() == (aruco.opencv_version()[:2] >= (4, 7))
