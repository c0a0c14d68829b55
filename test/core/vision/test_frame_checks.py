"""Frames and options the tracker cannot use are refused with the reason, never tracked into wrong poses or raw
OpenCV errors (a helper's review of the vision code)."""

import dataclasses

import cv2
import numpy as np
import pytest

from srs_ros.core.errors import ConfigurationError, InvalidInputError
from srs_ros.core.vision.camera_calibration import CameraIntrinsics
from srs_ros.core.vision.detectors import ColorRange
from srs_ros.core.vision.tracking import Tracker, TrackerConfig, TrackResult
from srs_ros.core.vision.view import ViewState, ViewWatch

COLOR = {"detector": "color"}


def test_a_frame_of_another_size_than_the_calibration_is_refused_naming_both(scene, calibration):
    """A 2x frame was tracked at (0.78, -0.51) m for a robot at (0.05, -0.02) m, without a word."""
    frame = scene.render((0.05, -0.02, 0.7))
    assert Tracker(calibration).process(frame, 0.0).tracked
    big = cv2.resize(frame, None, fx=2, fy=2)
    with pytest.raises(InvalidInputError, match=r"image is 1280 x 960 px but the calibration .* is for 640 x 480 px "
                                                r"\(image_size_px\); set the camera to 640 x 480 or calibrate it"):
        Tracker(calibration).process(big, 0.0)
    # A calibration without image_size_px cannot tell: the frame is tracked as before.
    sizeless = dataclasses.replace(calibration, image_size_px=None)
    assert Tracker(sizeless).process(frame, 0.0).tracked


@pytest.mark.parametrize(("shape", "options"), [
    ((0, 0, 3), {}), ((0, 0), {}), ((0, 0, 3), COLOR), ((480, 640, 1), COLOR), ((480, 640), COLOR),
])
def test_an_empty_or_single_channel_frame_is_refused_naming_its_shape(calibration, shape, options):
    """These raised cv2.error from cvtColor or detectMarkers (an empty image, one channel for the colour detector)."""
    tracker = Tracker(calibration, TrackerConfig.from_dict(options))
    with pytest.raises(InvalidInputError, match=rf"image has shape \({shape[0]}, {shape[1]}"):
        tracker.process(np.zeros(shape, np.uint8), 0.0)


@pytest.mark.parametrize(("options", "refusal"), [
    ({"tail_marker_id": 77}, "camera_tracker: tail_marker_id is 77; expected an id of DICT_4X4_50, 0..49"),
    ({"aruco_dictionary": "DICT_5X5_100", "head_marker_id": 100},
     "camera_tracker: head_marker_id is 100; expected an id of DICT_5X5_100, 0..99 (it holds 100 markers)"),
])
def test_an_aruco_id_the_dictionary_does_not_hold_is_refused(options, refusal):
    """DICT_4X4_50 holds ids 0..49; id 77 was accepted and then never seen."""
    with pytest.raises(ConfigurationError) as refused:
        TrackerConfig.from_dict(options, "camera_tracker")
    assert str(refused.value).startswith(refusal)
    with pytest.raises(ConfigurationError, match="the tracker settings: tail_marker_id is 50; expected an id of"):
        TrackerConfig(tail_marker_id=50)
    # The colour detector has no ids to check.
    assert TrackerConfig.from_dict({**COLOR, "tail_marker_id": 77}).tail_marker_id == 77


@pytest.mark.parametrize(("options", "refusal"), [
    ({"tail_color_hsv_low": [200, 0, 0], "tail_color_hsv_high": [250, 255, 255]},
     "camera_tracker: tail_color_hsv_low is [200, 0, 0]; expected a hue in 0..179"),
    ({"head_color_hsv_high": [180, 255, 255]},
     "camera_tracker: head_color_hsv_high is [180, 255, 255]; expected a hue"),
    ({"tail_color_hsv_low": [100, 200, 70], "tail_color_hsv_high": [130, 150, 255]},
     "camera_tracker: tail_color_hsv_high is [130, 150, 255]; expected a saturation at least the low bound's 200"),
    ({"head_color_hsv_low": [170, 120, 90], "head_color_hsv_high": [10, 255, 80]},
     "camera_tracker: head_color_hsv_high is [10, 255, 80]; expected a value at least the low bound's 90"),
])
def test_a_hue_beyond_179_or_a_saturation_or_value_box_upside_down_is_refused(options, refusal):
    """OpenCV's hue runs 0..179: 200..250 matched no pixel; a low S or V above the high one neither."""
    with pytest.raises(ConfigurationError) as refused:
        TrackerConfig.from_dict({**COLOR, **options}, "camera_tracker")
    assert str(refused.value).replace("(", "[").replace(")", "]").startswith(refusal)
    with pytest.raises(ConfigurationError, match=r"high_hsv is \(130, 150, 255\); expected a saturation"):
        ColorRange((100, 200, 70), (130, 150, 255))
    assert ColorRange((170, 120, 70), (10, 255, 255)).low_hsv[0] == 170  # the hue alone wraps through red


def test_a_marker_the_lens_model_cannot_undistort_is_not_seen(scene, calibration):
    """With k1 = -0.5 (f 500 px) the head's pixel 250 px from the centre has no ideal pixel: it was mirrored through
    the centre, 2 m away, instead of counting as not seen."""
    lens = CameraIntrinsics(np.array([500, 0, 320, 0, 500, 240, 0, 0, 1.0]), np.array([-0.5, 0, 0, 0]), "plumb_bob")
    result = Tracker(dataclasses.replace(calibration, intrinsics=lens)).process(scene.render((0.3, 0.2, 0.6)), 0.0)
    assert (result.tracked, result.message) == (False, "not seen: head")
    assert set(result.markers_m) == {"tail"} and np.all(np.isfinite(result.markers_m["tail"]))


def test_refused_images_are_not_a_silent_camera():
    """camera_tracker said "camera silent" while images arrived and were refused (a wrong size, an encoding)."""
    watch = ViewWatch(lost_after_s=0.5, image_timeout_s=1.0, start_s=0.0, source="/image_raw")
    for now_s in np.arange(0.1, 3.0, 0.1):
        watch.refused(float(now_s), "image is 1280 x 960 px but the calibration is for 640 x 480 px.")
    refused = watch.status(3.0)
    assert (refused.state, refused.level) == (ViewState.IMAGES_REFUSED, "ERROR") and not refused.pose_current
    assert refused.message == ("images refused: image is 1280 x 960 px but the calibration is for 640 x 480 px; "
                               "no pose published")
    assert watch.status(4.5).state is ViewState.CAMERA_SILENT  # and when they stop, the camera is silent
    watch.frame(4.6, TrackResult(4.6, np.array([0.1, 0.2, 0.0]), None, message="tracked"))
    assert watch.status(4.6).state is ViewState.TRACKING
