"""The simulated overhead camera: the pinhole behind the calibration, rendered bands, tracking against ground truth."""

import math

import cv2
import numpy as np
import pytest

from srs_ros.core.errors import ConfigurationError
from srs_ros.core.vision.camera_calibration import apply_homography
from srs_ros.core.vision.detectors import ColorBlobDetector, ColorRange
from srs_ros.core.vision.tracking import Tracker
from srs_ros.sim.camera import OverheadCamera, band_tracker_config, pinhole_from_homography
from srs_ros.sim.config import load_sim_config
from srs_ros.sim.experiment import run_experiment
from srs_ros.sim.scene import SyntheticCamera
from srs_ros.sim.world import SimWorld

CONFIG = load_sim_config()


@pytest.fixture(scope="module")
def camera():
    return OverheadCamera(CONFIG)


def test_the_pinhole_is_recovered_from_a_floor_homography():
    truth = SyntheticCamera(tilt_rad=math.radians(15.0), pan_rad=math.radians(-7.0), x_m=0.1, height_m=1.3)
    k, rotation, translation = pinhole_from_homography(truth.homography_floor_to_image, (640, 480))
    assert k[0, 0] == pytest.approx(truth.intrinsics[0, 0], rel=1e-6)
    centre = -rotation.T @ translation
    expected = [truth.x_m, truth.y_m + truth.height_m * math.tan(truth.tilt_rad), truth.height_m]
    np.testing.assert_allclose(centre, expected, atol=1e-6)
    np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-9)


def test_a_camera_looking_straight_down_needs_its_focal_length():
    straight = SyntheticCamera(tilt_rad=0.0, pan_rad=0.0)
    with pytest.raises(ConfigurationError, match="focal_length_px"):
        pinhole_from_homography(straight.homography_floor_to_image, (640, 480))
    k, _, _ = pinhole_from_homography(straight.homography_floor_to_image, (640, 480), focal_length_px=554.0)
    assert k[0, 0] == 554.0


def test_projection_agrees_with_the_calibration_on_the_floor_and_at_marker_height(camera):
    floor = np.array([[0.1, -0.2, 0.0], [-0.3, 0.25, 0.0], [0.4, 0.1, 0.0]])
    pixels, depth = camera.project(floor)
    assert np.all(depth > 0.5)
    np.testing.assert_allclose(camera.calibration.image_to_floor(pixels), floor[:, :2], atol=1e-9)
    raised = floor + [0.0, 0.0, 0.02]
    at_height = camera.calibration_at_height(0.02)
    np.testing.assert_allclose(at_height.image_to_floor(camera.project(raised)[0]), raised[:, :2], atol=1e-9)
    # The floor calibration misplaces a raised point by its parallax (the reason to calibrate at marker height).
    misplaced = camera.calibration.image_to_floor(camera.project(raised)[0]) - floor[:, :2]
    assert np.linalg.norm(misplaced, axis=1).max() > 4e-3


def test_the_bands_are_where_the_markers_are_at_any_roll_angle(camera):
    tracker_config = band_tracker_config(CONFIG.camera)
    for yaw in (0.0, 1.0, 2.5):
        world = SimWorld(CONFIG.replace("start", x_m=0.05, y_m=-0.05, yaw_rad=yaw))
        state = world.state()
        frame = camera.render(state.nodes_m)
        assert frame.shape == (camera.size_px[1], camera.size_px[0], 3) and frame.dtype == np.uint8
        result = Tracker(camera.calibration_at_height(CONFIG.body.skin_radius_m), tracker_config).process(frame, 0.0)
        assert result.tracked, result.message
        for key in ("tail", "head"):
            true_px = camera.project(getattr(state, f"{key}_marker_m"))[0]
            assert np.linalg.norm(result.markers_px[key] - true_px) < 1.0
    empty = camera.render(None)
    assert not Tracker(camera.calibration, tracker_config).process(empty, 0.0).tracked   # floor alone: no bands


def test_the_band_preset_holds_the_band_colours_and_not_the_body_or_floor():
    def inside(colour_range, bgr):
        hsv = cv2.cvtColor(np.uint8([[bgr]]), cv2.COLOR_BGR2HSV)[0, 0].astype(int)
        low, high = np.array(colour_range.low_hsv), np.array(colour_range.high_hsv)
        hue_ok = low[0] <= hsv[0] <= high[0] if low[0] <= high[0] else (hsv[0] >= low[0] or hsv[0] <= high[0])
        return hue_ok and np.all(hsv[1:] >= low[1:]) and np.all(hsv[1:] <= high[1:])

    preset = band_tracker_config(CONFIG.camera, velocity_window_s=0.3)
    assert preset.detector == "color" and preset.velocity_window_s == 0.3
    cam = CONFIG.camera
    for colour_range, band, other in ((preset.tail_color, cam.tail_band_bgr, cam.head_band_bgr),
                                      (preset.head_color, cam.head_band_bgr, cam.tail_band_bgr)):
        assert inside(colour_range, band) and inside(colour_range, tuple(int(0.55 * c) for c in band))  # rim
        assert not inside(colour_range, other) and not inside(colour_range, cam.body_bgr)
        assert not inside(colour_range, (150, 142, 135))                                              # floor


def test_tracking_the_rendered_robot_while_it_rolls_recovers_the_reference_point(camera):
    # A fixed camera as in the lab (paper Sec. IV): markers on the body's axis, calibrated at their height.
    tracker = Tracker(camera.calibration_at_height(CONFIG.body.skin_radius_m), band_tracker_config(CONFIG.camera))
    errors, missed = [], []

    def on_frame(state):
        result = tracker.process(camera.render(state.nodes_m), state.time_s)
        if result.tracked:
            errors.append(np.linalg.norm(result.pose[:2] - state.reference_xy_m))
        else:
            missed.append(state.time_s)

    result = run_experiment("inward_rolling", 3.0, 1.0, 3.0, CONFIG.replace("start", y_m=-0.15), on_frame=on_frame)
    assert result.velocity.speed_cm_s > 2.0                     # it does roll, across a good part of the view
    assert len(missed) <= 0.05 * (len(errors) + len(missed)), missed
    assert 1000 * np.median(errors) < 5.0, 1000 * np.percentile(errors, [50, 90, 100])


def test_the_colour_window_search_finds_what_the_whole_frame_gives_and_follows_a_jump(camera):
    """The colour detector's ROI search (``roi_margin_px``) against the whole-frame search on the rolling robot."""
    bands = band_tracker_config(CONFIG.camera)
    colors = {"tail": bands.tail_color, "head": bands.head_color}
    windowed = ColorBlobDetector(colors, bands.min_blob_area_px, roi_margin_px=40)
    whole = ColorBlobDetector(colors, bands.min_blob_area_px, roi_margin_px=0)
    frames = []
    run_experiment("inward_rolling", 4.0, 1.0, 2.0, CONFIG.replace("start", y_m=-0.15),
                   on_frame=lambda state: frames.append(camera.render(state.nodes_m)))
    for frame in frames:
        a, b = windowed.detect(frame), whole.detect(frame)
        assert a.keys() == b.keys() == {"tail", "head"}
        for key in a:
            np.testing.assert_array_equal(a[key].centre_px, b[key].centre_px)
            np.testing.assert_array_equal(a[key].corners_px, b[key].corners_px)
    searched_whole = 1 + len(frames) // ColorBlobDetector.WHOLE_FRAME_EVERY  # the first frame, then every 15th
    assert windowed.roi_hits == 2 * (len(frames) - searched_whole), (windowed.roi_hits, len(frames))
    assert whole.roi_hits == 0
    # The robot seen 0.3 m away in the next frame (a pushed robot, a lost second): found by the whole-frame search.
    last = whole.detect(frames[-1])
    elsewhere = run_experiment("inward_rolling", 4.0, 1.0, 0.2, CONFIG.replace("start", y_m=0.35)).final_state
    jumped, hits = camera.render(elsewhere.nodes_m), windowed.roi_hits
    a, b = windowed.detect(jumped), whole.detect(jumped)
    assert a.keys() == b.keys() == {"tail", "head"} and windowed.roi_hits == hits  # not in the windows
    for key in a:
        np.testing.assert_array_equal(a[key].centre_px, b[key].centre_px)
        assert np.linalg.norm(a[key].centre_px - last[key].centre_px) > 50.0  # beyond the 40 px margin


RED = ColorRange((170, 120, 70), (10, 255, 255))


def _red_frame(*boxes):
    """A 320x240 black frame with red rectangles (x0, y0, x1, y1), px."""
    frame = np.zeros((240, 320, 3), np.uint8)
    for x0, y0, x1, y1 in boxes:
        frame[y0:y1, x0:x1] = (0, 0, 255)
    return frame


def test_a_blob_cut_by_the_colour_window_is_taken_from_the_whole_frame():
    windowed, whole = ColorBlobDetector({"m": RED}, 20.0, roi_margin_px=20), ColorBlobDetector({"m": RED}, 20.0)
    windowed.detect(_red_frame((100, 100, 110, 110)))  # the next window: x 80-130, y 80-130
    for box in ((112, 100, 160, 110), (112, 100, 130, 110), (100, 112, 110, 131)):  # reaching the window's edge
        frame, hits = _red_frame(box), windowed.roi_hits
        a, b = windowed.detect(frame)["m"], whole.detect(frame)["m"]
        assert windowed.roi_hits == hits, box  # not taken from the window
        np.testing.assert_array_equal(a.centre_px, b.centre_px)
        windowed.detect(_red_frame((100, 100, 110, 110)))  # back where it was: the same window again
    frame = _red_frame((112, 100, 126, 110))  # inside: taken from the window, as the whole frame gives it
    hits = windowed.roi_hits
    np.testing.assert_array_equal(windowed.detect(frame)["m"].centre_px, whole.detect(frame)["m"].centre_px)
    assert windowed.roi_hits == hits + 1


def test_a_wrong_blob_taken_while_the_marker_hid_is_let_go():
    marker, distractor = (200, 100, 214, 114), (40, 180, 47, 187)  # 196 px and 49 px
    windowed = ColorBlobDetector({"m": RED}, 20.0, roi_margin_px=20)
    assert windowed.detect(_red_frame(marker, distractor))["m"].centre_px[0] > 200
    assert windowed.detect(_red_frame(distractor))["m"].centre_px[0] < 50  # the marker hidden: the other is taken
    seen = [windowed.detect(_red_frame(marker, distractor))["m"].centre_px[0] > 200 for _ in range(20)]
    first = seen.index(True)
    assert first < ColorBlobDetector.WHOLE_FRAME_EVERY and all(seen[first:]), seen  # back on the marker for good
    windowed.detect(_red_frame(distractor))
    windowed.forget()  # what a tracker does when it rejects a frame
    assert windowed.detect(_red_frame(marker, distractor))["m"].centre_px[0] > 200


def test_the_floor_homography_round_trips(camera):
    to_image = camera.floor_homography(0.0)
    points = np.array([[0.0, 0.0], [0.2, -0.1]])
    np.testing.assert_allclose(apply_homography(to_image, points), camera.calibration.floor_to_image(points), atol=1e-6)
