"""Navigator settings, the identified turn map file and the camera's floor area where goals may lie."""

import numpy as np
import pytest

from srs_ros.core.errors import ConfigurationError
from srs_ros.core.navigation import FloorArea, load_navigation_settings, load_turning_map
from srs_ros.core.navigation.settings import DIRECTIONS, STOP_PHASES, turning_map_from_dict
from srs_ros.core.robot import config_file
from srs_ros.core.vision.camera_calibration import load_calibration


def test_the_package_turning_map_loads_with_both_directions():
    mapped = load_turning_map()
    for direction in DIRECTIONS:
        levels = len(mapped[direction].turn_phase_rad)
        assert mapped[direction].stop_offset_m.shape == (levels, len(STOP_PHASES), 2)  # measured per turn level
        assert len(mapped[direction].turn_phase_rad) == len(mapped[direction].turn_rate_deg_per_cycle)
    assert load_navigation_settings().goal_tolerance_m == 0.05


def test_a_bad_turning_map_is_refused_with_the_key():
    block = {"amplitude_bar": 4.0, "frequency_hz": 1.0}
    good = {"turn_phase_rad": [0.0, 0.2], "turn_rate_deg_per_cycle": [1.0, -3.0], "travel_m_per_cycle": [0.1, 0.1]}
    for direction in DIRECTIONS:
        block[direction] = dict(good)
    assert turning_map_from_dict({"turning_map": block}, "m.yaml")["inward_rolling"].rate_at(0.1) == pytest.approx(-1)
    block["outward_rolling"] = {**good, "turn_rate_deg_per_cycle": [1.0]}
    with pytest.raises(ConfigurationError, match=r"m.yaml: turning_map.outward_rolling.turn_rate_deg_per_cycle is "
                                                 r"\[1.0\]; expected 2 values"):
        turning_map_from_dict({"turning_map": block}, "m.yaml")
    block["outward_rolling"] = {**good, "turn_phase_rad": [0.2, 0.0]}
    with pytest.raises(ConfigurationError, match="increasing values"):
        turning_map_from_dict({"turning_map": block}, "m.yaml")


def test_a_direction_block_written_at_the_top_of_a_turning_map_is_refused_not_ignored():
    good = {"turn_phase_rad": [0.0, 0.2], "turn_rate_deg_per_cycle": [1.0, -3.0], "travel_m_per_cycle": [0.1, 0.1]}
    data = {"turning_map": {"amplitude_bar": 4.0, "frequency_hz": 1.0, **{d: dict(good) for d in DIRECTIONS}}}
    data["inward_rolling"] = dict(good)  # a second copy beside the block: which one would count?
    with pytest.raises(ConfigurationError, match=r"^m.yaml: the top-level key 'inward_rolling' is not known; expected "
                                                 r"only turning_map: at the top \('inward_rolling' belongs to the "
                                                 r"turning_map block: indent it under turning_map:\)"):
        turning_map_from_dict(data, "m.yaml")


def test_stop_offsets_per_turn_level_are_read_in_order_and_interpolated_between_levels():
    good = {"turn_phase_rad": [-0.4, 0.0, 0.4], "turn_rate_deg_per_cycle": [10.0, 0.0, -10.0],
            "travel_m_per_cycle": [0.1, 0.1, 0.1]}
    per_level = [[0.1, 0.2] * len(STOP_PHASES), [0.2, 0.0] * len(STOP_PHASES), [0.1, -0.2] * len(STOP_PHASES)]
    block = {"amplitude_bar": 4.0, "frequency_hz": 1.0,
             "inward_rolling": {**good, "stop_offset_m": sum(per_level, [])},
             "outward_rolling": {**good, "stop_offset_m": [0.03, 0.0] * len(STOP_PHASES)}}
    mapped = turning_map_from_dict({"turning_map": block}, "m.yaml")
    inward = mapped["inward_rolling"].stop_offset_at([-0.4, -0.2, 0.4])
    assert inward.shape == (3, len(STOP_PHASES), 2)
    np.testing.assert_allclose(inward[:, 0], [[0.1, 0.2], [0.15, 0.1], [0.1, -0.2]])
    outward = mapped["outward_rolling"].stop_offset_at([-0.4, 0.3])
    np.testing.assert_allclose(outward, np.tile([0.03, 0.0], (2, len(STOP_PHASES), 1)))
    block["outward_rolling"] = {**good, "stop_offset_m": [0.1] * 10}
    with pytest.raises(ConfigurationError, match=r"stop_offset_m is .*; expected 8 values \(every turn level\) "
                                                 r"or 24"):
        turning_map_from_dict({"turning_map": block}, "m.yaml")


def test_a_missing_turning_map_says_how_to_make_one(tmp_path):
    with pytest.raises(ConfigurationError, match="turning_cli --write-map"):
        load_navigation_settings({"turning_map_file": str(tmp_path / "none.yaml")})


def test_the_floor_area_is_the_simulated_cameras_view_less_the_margin():
    area = FloorArea.from_calibration(load_calibration(config_file("sim_camera_calibration.yaml")), 0.25)
    low, high = area.polygon_m.min(axis=0), area.polygon_m.max(axis=0)
    np.testing.assert_allclose([low[0], high[0], low[1], high[1]], [-1.61, 1.61, -1.22, 1.08], atol=0.01)
    assert area.refusal(0.0, 0.0) == "" and area.refusal(1.0, 0.6) == ""
    assert "0.48 m outside" in area.refusal(2.0, 0.0)
    assert "only 0.22 m inside" in area.refusal(1.3, 0.0) and "view_margin_m = 0.25 m" in area.refusal(1.3, 0.0)
    assert "not a finite floor position" in area.refusal(float("nan"), 0.0)


def test_a_track_leaving_the_area_is_told_from_one_near_the_edge_that_stays():
    area = FloorArea(np.array([[-1.4, -1.0], [1.4, -1.0], [1.4, 1.0], [-1.4, 1.0]]), 0.25)

    def track(*xs):  # rows of time_s, x_m, y_m, yaw_rad along the x axis
        return np.array([[i * 0.1, x, 0.0, 0.0] for i, x in enumerate(xs)])

    assert area.leaving_by_m(track(1.20, 1.25, 1.28), 0.2, 0.02) == pytest.approx(0.12)
    assert area.leaving_by_m(track(1.27, 1.28), 0.2, 0.02) is None   # near the edge but hardly moving out
    assert area.leaving_by_m(track(1.28, 1.20), 0.2, 0.02) is None   # moving in
    assert area.leaving_by_m(track(0.5, 1.0), 0.2, 0.02) is None     # moving out, still far inside
    assert area.leaving_by_m(track(1.28), 0.2, 0.02) is None         # one pose is no track


def test_the_inward_normal_points_into_the_area_from_the_nearest_edge():
    area = FloorArea(np.array([[-1.4, -1.0], [1.4, -1.0], [1.4, 1.0], [-1.4, 1.0]]), 0.25)
    np.testing.assert_allclose(area.inward_normal(0.3, -0.9), [0.0, 1.0], atol=1e-12)   # bottom edge
    np.testing.assert_allclose(area.inward_normal(1.3, 0.2), [-1.0, 0.0], atol=1e-12)   # right edge
    np.testing.assert_allclose(area.inward_normal(-0.2, 0.95), [0.0, -1.0], atol=1e-12)  # top edge
    clockwise = FloorArea(area.polygon_m[::-1].copy(), 0.25)
    np.testing.assert_allclose(clockwise.inward_normal(0.3, -0.9), [0.0, 1.0], atol=1e-12)
