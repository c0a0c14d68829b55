"""The homography fit and the lens model at their limits: degenerate four-pair fits, a refinement that must not
make the fit worse, pixels the lens model cannot undistort (a helper's review of the vision code)."""

import re

import numpy as np
import pytest

from srs_ros.core.errors import InvalidInputError
from srs_ros.core.vision import homography
from srs_ros.core.vision.camera_calibration import CameraIntrinsics, calibration_from_pairs, fit_homography
from srs_ros.tools.calibrate_camera import report

SQUARE_PX = [[0, 0], [100, 0], [100, 100], [0, 100]]
SQUARE_M = [[0, 0], [1, 0], [1, 1], [0, 1]]
ON_A_LINE_PX = [[0, 0], [50, 0], [100, 0], [0, 100]]  # pairs 1, 2, 3 on one line
ON_A_LINE_M = [[0, 0], [0.5, 0], [1, 0], [0, 1]]


@pytest.mark.parametrize(("pixels", "floor", "side"), [
    (ON_A_LINE_PX, ON_A_LINE_M, "source (image)"),          # both sides: was a fit with rms 1e-13 mm, 0.49 m off
    (ON_A_LINE_PX, [[0, 0], [0.5, 0.2], [1, 0], [0, 1]], "source (image)"),  # the pixels only: was 650 mm rms
    ([[0, 0], [50, 20], [100, 0], [0, 100]], ON_A_LINE_M, "target (floor)"),  # the floor points only
])
def test_four_pairs_with_three_on_a_line_are_refused(pixels, floor, side):
    """Four pairs with three on a line were fitted (the 8 x 9 system has 8 singular values, so the test read the
    7th): pixel (0, 50) went to (0, 0.99) m instead of (0, 0.5) m with a reported error of 0 mm."""
    with pytest.raises(InvalidInputError, match=rf"degenerate: the {re.escape(side)} points of pairs \d, \d, \d "
                                                r"\(of 4\) lie on one line"):
        fit_homography(pixels, floor)
    with pytest.raises(InvalidInputError, match="Move one point off the line or add pairs"):
        calibration_from_pairs(pixels, floor)


def test_four_pairs_in_general_position_fit_and_their_report_says_the_error_is_no_estimate():
    calibration = calibration_from_pairs(SQUARE_PX, SQUARE_M)
    np.testing.assert_allclose(calibration.image_to_floor([50, 50]), [0.5, 0.5], atol=1e-12)
    assert "4 point pairs fix the homography exactly, so the error is 0 by construction" in report(calibration)
    five = calibration_from_pairs([*SQUARE_PX, [50, 50]], [*SQUARE_M, [0.5, 0.5]])
    assert "by construction" not in report(five)


def test_the_refinement_never_leaves_the_fit_worse_than_the_linear_estimate(monkeypatch):
    """Undamped Gauss-Newton took these five pairs from 19.2 mm rms (the DLT) to 46.9 mm."""
    src = np.array([[505.1, 359.5], [328.6, 173.6], [300.5, 177.6], [529.6, 277.2], [381.2, 145.5]])
    dst = np.array([[0.3742, -0.2101], [-0.0064, 0.1084], [-0.0004, 0.0859], [0.3478, -0.0191], [0.1083, 0.1709]])
    refined = calibration_from_pairs(src, dst).rms_error_mm
    assert refined <= 19.23, f"refined {refined:.2f} mm rms, the DLT alone 19.23 mm"
    monkeypatch.setattr(homography, "_refine", lambda h, s, d, iterations=10: h)  # the DLT alone
    linear = calibration_from_pairs(src, dst).rms_error_mm
    assert linear == pytest.approx(19.23, abs=0.01) and refined <= linear


LENS = CameraIntrinsics(np.array([500, 0, 320, 0, 500, 240, 0, 0, 1.0]), np.array([-0.5, 0, 0, 0]), "plumb_bob")


def test_a_pixel_the_lens_model_cannot_undistort_is_nan_not_a_mirrored_point():
    """With k1 = -0.5 the model's radius peaks at 0.544 (272 px from the centre at f = 500 px): pixel (0, 0), 400 px
    out, has no ideal pixel, and was given as (1005, 754), a point mirrored through the centre."""
    ideal = LENS.undistort_px([[0.0, 0.0], [600.0, 240.0], [500.0, 240.0], [320.0, 240.0]])
    assert np.all(np.isnan(ideal[:2]))
    np.testing.assert_allclose(LENS.distort_px(ideal[2:]), [[500.0, 240.0], [320.0, 240.0]], atol=1e-9)
    with pytest.raises(InvalidInputError, match=r"pixel \[0.0, 0.0\] \(pair 1\) cannot be undistorted: the lens "
                                                r"model \(plumb_bob"):
        calibration_from_pairs([[0, 0], [500, 240], [320, 300], [400, 200]], SQUARE_M, intrinsics=LENS)
