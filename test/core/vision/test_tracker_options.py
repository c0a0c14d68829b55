"""The tracker's options through the one schema: defaults in one table, a bad value refused in the one format."""

import pytest

from srs_ros.core.errors import ConfigurationError
from srs_ros.core.vision.detectors import ColorRange
from srs_ros.core.vision.tracking import TrackerConfig


def test_the_table_gives_the_defaults_of_the_tracker():
    assert TrackerConfig.from_dict({}) == TrackerConfig()
    assert TrackerConfig().tail_color == ColorRange((100, 120, 70), (130, 255, 255))


def test_options_are_taken_from_node_parameters_and_others_left_alone():
    config = TrackerConfig.from_dict({"detector": "color", "head_color_hsv_low": [0, 100, 100],
                                      "head_color_hsv_high": [9, 255, 255], "position_ratio": 1, "frame_id": "map"})
    assert config.detector == "color" and config.position_ratio == 1.0
    assert config.head_color == ColorRange((0, 100, 100), (9, 255, 255))


@pytest.mark.parametrize(("options", "refusal"), [
    ({"detector": "laser"}, "camera_tracker: detector is 'laser'; expected one of ['aruco', 'color']."),
    ({"tail_color_hsv_low": [100, 120]},
     "camera_tracker: tail_color_hsv_low is [100, 120]; expected a list of 3 integers in [0, 255]."),
    ({"head_color_hsv_high": [10, 255, 300]},
     "camera_tracker: head_color_hsv_high is [10, 255, 300]; expected a list of 3 integers in [0, 255]."),
    ({"head_marker_id": 2000}, "camera_tracker: head_marker_id is 2000; expected an integer in [0, 1023]."),
    ({"position_ratio": 1.5}, "camera_tracker: position_ratio is 1.5; expected a number in [0, 1]."),
    ({"velocity_window_s": 0.0}, "camera_tracker: velocity_window_s is 0.0; expected a number in [0.01, 60]."),
    ({"tail_marker_id": 4, "head_marker_id": 4},
     "camera_tracker: head_marker_id is 4; expected an id other than tail_marker_id 4 (the two markers must differ)."),
])
def test_a_bad_option_is_refused_in_the_one_format(options, refusal):
    with pytest.raises(ConfigurationError) as refused:
        TrackerConfig.from_dict(options, "camera_tracker")
    assert str(refused.value) == refusal
