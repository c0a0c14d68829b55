"""gait_player built in the test's own process: its parameters, its trajectory intake and its tick, without DDS peers.

Found by a helper's review (stop 59): a 10 Hz stream played every gait at half its frequency, a full 2049-point
trajectory was refused by the byte limit that should take it, and a stop phase in (-1, 0) was taken as "none".
"""

import re
import time

import pytest
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from srs_testing import rolling_cycle, trajectory

from srs_ros.core.errors import ConfigurationError, InvalidInputError
from srs_ros.core.gait.playback import MAX_TRAJECTORY_POINTS
from srs_ros.nodes.gait_player import MAX_TRAJECTORY_BYTES, GaitPlayer


@pytest.fixture
def player(ros_domain):
    context = Context()
    rclpy.init(context=context, domain_id=ros_domain)
    made = []

    def _make(**params) -> GaitPlayer:
        overrides = [Parameter(name, value=value) for name, value in params.items()]
        made.append(GaitPlayer(context=context, parameter_overrides=overrides))
        return made[-1]

    yield _make, context
    for node in made:
        node.destroy_node()
    rclpy.shutdown(context=context)


def full_trajectory(count: int):
    """``count`` points (a closed period of count - 1 samples) with positions, velocities, accelerations and effort."""
    msg = trajectory(rolling_cycle(count - 1), 1.0)
    for point in msg.points:
        point.velocities = point.accelerations = point.effort = [0.0] * 9
    return msg


def test_a_full_trajectory_of_the_most_points_with_every_array_is_taken_and_a_longer_one_is_not(player):
    make, _context = player
    node = make()
    largest = serialize_message(full_trajectory(MAX_TRAJECTORY_POINTS))
    assert len(largest) <= MAX_TRAJECTORY_BYTES, (len(largest), MAX_TRAJECTORY_BYTES)  # 672,204 against 659,776 before
    node._on_trajectory(largest)
    assert node._playback.has_cycle
    too_many = serialize_message(full_trajectory(MAX_TRAJECTORY_POINTS + 40))
    assert len(too_many) > MAX_TRAJECTORY_BYTES  # refused unread, before the 0.7 s a huge message would take


@pytest.mark.parametrize("rate_hz", [10.0, 15.0])
def test_a_slow_stream_plays_the_gait_at_its_own_frequency(player, rate_hz):
    """Each tick's phase step was capped at 0.05 s: at 10 Hz a 1 Hz gait played at 0.5 Hz (and a 1 s ramp-out
    took 2 s). The cap is now two tick periods where that is longer."""
    make, context = player
    node = make(rate_hz=rate_hz)
    node._on_trajectory(serialize_message(trajectory(rolling_cycle(), 1.0)))
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    node._playback.start()
    started_s = time.monotonic()
    while time.monotonic() - started_s < 2.5:
        executor.spin_once(timeout_sec=0.05)
    played, elapsed_s = node._playback.cycles_done, time.monotonic() - started_s
    executor.shutdown()
    # a 1 Hz gait: a cycle a second, less what a stall longer than two ticks loses on a loaded machine
    assert 0.8 * elapsed_s <= played <= elapsed_s + 0.15, (played, elapsed_s)


def test_rate_changes_move_the_largest_step_with_them(player):
    make, _context = player
    node = make(rate_hz=10.0)
    assert node._max_step_s == pytest.approx(0.2)
    assert node.set_parameters([Parameter("rate_hz", value=200.0)])[0].successful
    assert node._max_step_s == pytest.approx(0.05)  # a stalled process still resumes where it was


@pytest.mark.parametrize("value, taken", [(-0.5, False), (-1e-9, False), (-1.0, True), (0.0, True), (0.99, True)])
def test_a_stop_phase_between_minus_1_and_0_is_refused_not_taken_for_none(player, value, taken):
    make, _context = player
    node = make()
    result = node.set_parameters([Parameter("stop_at_phase", value=value)])[0]
    assert result.successful == taken, result.reason
    if not taken:
        assert "expected a phase in [0, 1], or -1 for none" in result.reason


@pytest.mark.parametrize("params, said", [
    ({"stop_at_phase": -0.5}, "stop_at_phase -0.5: expected a phase in [0, 1], or -1 for none"),
    ({"frequency_hz": 0.001}, "frequency_hz 0.001: expected 0 (the trajectory's own) or a frequency in [0.01, 5] Hz"),
])
def test_a_start_up_value_a_set_would_refuse_stops_the_node_with_the_reason(player, params, said):
    """``-p stop_at_phase:=-0.5`` started and meant nothing, as ``-p frequency_hz:=0.001`` froze the robot at a posture
    held at pressure (a helper's review): both are refused as a set refuses them."""
    make, _context = player
    with pytest.raises(ConfigurationError, match=re.escape(said)):
        make(**params)


def test_a_frequency_between_0_and_the_slowest_cycle_is_refused_live_and_by_the_playback(player):
    make, _context = player
    node = make()
    result = node.set_parameters([Parameter("frequency_hz", value=0.001)])[0]
    assert not result.successful and "below 0.01 Hz a cycle holds a posture at pressure for minutes" in result.reason
    assert node.set_parameters([Parameter("frequency_hz", value=0.01)])[0].successful
    assert node.set_parameters([Parameter("frequency_hz", value=0.0)])[0].successful
    with pytest.raises(InvalidInputError, match="frequency_hz 0.005"):
        node._playback.set_frequency_override(0.005)


def test_phase_rate_0_publishes_no_gait_phase_at_start_up_or_after_a_live_set(player):
    """``phase_rate_hz`` 0 ("none") still sent one gait_phase message at the first tick, and one after each set."""
    make, context = player
    node = make(phase_rate_hz=0.0)
    sent = []
    node._phase_publisher.publish = sent.append
    node._on_trajectory(serialize_message(trajectory(rolling_cycle(), 1.0)))
    node._playback.start()
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)

    def spin_for(duration_s):
        end_s = time.monotonic() + duration_s
        while time.monotonic() < end_s:
            executor.spin_once(timeout_sec=0.02)

    spin_for(0.5)
    assert node.set_parameters([Parameter("phase_rate_hz", value=0.0)])[0].successful
    spin_for(0.3)
    assert node.published_count > 10 and sent == []
    assert node.set_parameters([Parameter("phase_rate_hz", value=50.0)])[0].successful
    spin_for(0.3)
    executor.shutdown()
    assert len(sent) >= 3  # the rate back: messages again


def test_a_stop_phase_set_while_not_playing_is_said_to_be_ignored(player):
    make, _context = player
    node = make()
    warnings = []
    node.get_logger().warning = lambda text, **kwargs: warnings.append(text)
    assert node.set_parameters([Parameter("stop_at_phase", value=0.25)])[0].successful
    assert node._playback.pending_stop_phase is None
    assert warnings == ["stop_at_phase 0.25 ignored: the gait is idle; set it while playing (after ~/start)"]
