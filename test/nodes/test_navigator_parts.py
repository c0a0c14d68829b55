"""The navigator's own small parts, without DDS: stamps onto the steady clock, yaw from a quaternion, the
progress fields, the JSON message and the gait driver's dead man's handle values."""

import json
import math

import numpy as np
import pytest

from srs_ros.core.navigation import NavigationProgress, NavigationState
from srs_ros.core.navigation.commands import GaitCommand
from srs_ros.core.vision.tracking import yaw_to_quaternion
from srs_ros.nodes.navigator import StampClock, progress_fields, yaw_from_quaternion
from srs_ros.ros.gait_driver import GaitDriver
from srs_ros.ros.interfaces import progress_fields as read_progress
from srs_ros.ros.interfaces import progress_message


def test_stamps_keep_their_spacing_on_the_steady_clock_and_a_jump_of_the_stamp_clock_rebases():
    clock = StampClock()
    # frames 1/15 s apart, delivered 30-120 ms late with jitter: the spacing of the stamps is kept
    delays = (0.05, 0.12, 0.03, 0.08, 0.03)
    times = [clock.steady_s(100.0 + i / 15, 5000.0 + i / 15 + delay) for i, delay in enumerate(delays)]
    assert times[3] - times[2] == pytest.approx(1 / 15) and times[4] - times[3] == pytest.approx(1 / 15)
    assert times[-1] <= 5000.0 + 4 / 15 + 0.03 + 1e-9  # never later than its arrival
    # a simulation restarted: its stamps start again near 0; the mapping follows at once
    assert clock.steady_s(1.0, 6000.0) == pytest.approx(6000.0)
    assert clock.steady_s(0.0, 6000.5) == 6000.5  # unstamped: its arrival


def test_one_stamp_from_the_future_does_not_move_the_times_of_the_poses_after_it():
    clock = StampClock()
    for i in range(60):  # 30 Hz frames delivered 30 ms late
        clock.steady_s(100.0 + i / 30, 5000.0 + i / 30 + 0.03)
    clock.steady_s(100.0 + 60 / 30 + 0.7, 5000.0 + 60 / 30 + 0.03)  # one frame stamped 0.7 s ahead
    later = [clock.steady_s(100.0 + i / 30, 5000.0 + i / 30 + 0.03) for i in range(61, 120)]
    assert later == pytest.approx([5000.0 + i / 30 + 0.03 for i in range(61, 120)])  # it shifted them 0.7 s back


def test_a_repeated_stamp_is_a_repeat_not_a_fresh_pose_but_a_clock_gone_back_a_jump_is_a_restart():
    """A frozen camera re-sends its last frame: each copy was re-based and dated at its arrival (a helper's review)."""
    clock = StampClock()
    for i in range(30):
        assert not clock.repeats(100.0 + i / 30)
        clock.steady_s(100.0 + i / 30, 5000.0 + i / 30 + 0.03)
    last = 100.0 + 29 / 30
    assert clock.repeats(last) and clock.repeats(last - 0.5)  # the same frame again, or one older than the last
    assert not clock.repeats(last + 1 / 30) and not clock.repeats(0.0)  # the next frame; unstamped
    assert not clock.repeats(1.0)  # a restarted simulation's clock: a jump back, taken (and re-based)


@pytest.mark.parametrize("rate", [0.6, 0.3, 2.0])
def test_stamps_on_a_simulated_clock_behind_or_ahead_of_real_time_keep_their_arrival_delay(rate):
    """A world on use_sim_time at 0.6x: its stamps gain 0.6 s a second, so the delay grows 0.4 s a second.
    Before the drift was followed, the poses were dated up to 1 s before they came: one stall then lost them."""
    clock = StampClock()
    rng = np.random.default_rng(3)
    lags = []
    for i in range(3000):  # 100 s of 30 Hz frames, 20-60 ms late, every 5 s a 0.3 s stall of the subscriber
        arrival = 5000.0 + i / 30
        stall = 0.3 - (i % 150) / 30 if i % 150 < 9 else 0.0
        delivered = arrival + rng.uniform(0.02, 0.06) + stall
        mapped = clock.steady_s(10.0 + rate * i / 30, delivered)
        assert mapped <= delivered  # never later than its arrival
        lags.append(delivered - mapped)
    lags = np.array(lags[300:])  # after the first 10 s
    assert np.median(lags) < 0.06 and np.percentile(lags, 99) < 0.36  # the old mapping: up to 0.95 s


@pytest.mark.parametrize("yaw", [0.0, 1.0, -2.5, math.pi - 1e-6])
def test_yaw_from_the_trackers_quaternion(yaw):
    x, y, z, w = yaw_to_quaternion(yaw)
    assert yaw_from_quaternion(z, w, x, y) == pytest.approx(yaw)


def test_progress_is_one_json_object_with_plain_values_and_nan_as_null():
    rates = {"inward_rolling": [7.0, math.nan], "outward_rolling": [-1.5, 0.25]}  # a NaN inside the learned rates
    progress = NavigationProgress(NavigationState.DRIVING, (0.4, -0.4), 1, 4, math.nan, math.radians(12.0),
                                  "inward_rolling", 0.2, 3.5, "driving", turn_rates_deg_per_cycle=rates)
    fields = progress_fields(progress, refused="", loop=True)
    msg = progress_message(fields)
    data = json.loads(msg.data, parse_constant=lambda name: pytest.fail(f"{name} is not JSON"))
    assert data["state"] == "driving" and data["goal_xy_m"] == [0.4, -0.4] and data["distance_to_go_m"] is None
    assert data["heading_error_deg"] == pytest.approx(12.0) and data["loop"] is True
    assert data["turn_rates_deg_per_cycle"] == {"inward_rolling": [7.0, None], "outward_rolling": [-1.5, 0.25]}
    assert read_progress(msg) == data


def test_the_dead_mans_handle_sets_cycles_for_keepalive_s_at_the_commanded_frequency():
    driver = GaitDriver.__new__(GaitDriver)  # only its arithmetic here; the calls are tested over DDS
    driver.keepalive_s = 2.0
    assert driver._player_values(GaitCommand("inward_rolling", 0.2, 4.0, 1.0)) == (1.0, False, 2, -1.0)
    # at 0.3 Hz 1 cycle (ceil(0.6)) ran out before a stop at a phase set a cycle ahead: 2 (floor(0.6 / 4) + 2)
    assert driver._player_values(GaitCommand("outward_rolling", 0.2, 4.0, 0.3)) == (0.3, True, 2, -1.0)
    assert driver._player_values(GaitCommand("outward_rolling", 0.2, 4.0, 1.6)) == (1.6, True, 4, -1.0)
    driver.keepalive_s = 0.0
    assert driver._player_values(GaitCommand("inward_rolling", 0.2, 4.0, 1.0)) == (1.0, False, 0, -1.0)  # off


def test_the_gait_phase_at_a_camera_frames_stamp_is_extrapolated_from_the_sample_before_it():
    from collections import deque
    from types import SimpleNamespace

    from srs_ros.nodes.navigator import Navigator

    node = SimpleNamespace(_phases=deque([(10.00, 0.90, 1.0), (10.02, 0.92, 1.0), (10.04, 0.10, -2.0)]))
    assert Navigator.gait_phase_at(node, 10.03) == pytest.approx(0.93)  # 10 ms after the 10.02 sample, 1 Hz
    assert Navigator.gait_phase_at(node, 10.10) == pytest.approx(0.98)  # 60 ms after 10.04 at -2 Hz: wrapped
    assert Navigator.gait_phase_at(node, 9.99) == pytest.approx(0.89)  # just before the first sample
    assert Navigator.gait_phase_at(node, 10.5) is None  # no sample within 0.25 s: the player stopped
    assert Navigator.gait_phase_at(SimpleNamespace(_phases=deque()), 10.0) is None
