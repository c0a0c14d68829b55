"""The message helpers every node shares: stamps and durations, diagnostics (images: test_camera_tracker)."""

import pytest
from builtin_interfaces.msg import Duration, Time
from diagnostic_msgs.msg import DiagnosticStatus

from srs_ros.core.errors import InvalidInputError
from srs_ros.ros.interfaces import (
    diagnostic_array,
    diagnostic_status,
    diagnostic_values,
    nanoseconds_to_duration,
    nanoseconds_to_stamp,
    seconds_to_stamp,
    stamp_to_nanoseconds,
    stamp_to_seconds,
)


def test_stamps_and_durations_convert_to_seconds_and_exact_nanoseconds():
    stamp = Time(sec=1_700_000_000, nanosec=250_000_001)
    assert stamp_to_nanoseconds(stamp) == 1_700_000_000_250_000_001
    assert stamp_to_seconds(stamp) == pytest.approx(1_700_000_000.25)
    assert nanoseconds_to_stamp(1_700_000_000_250_000_001) == stamp
    assert nanoseconds_to_duration(2_500_000_000) == Duration(sec=2, nanosec=500_000_000)
    assert stamp_to_seconds(Duration(sec=2, nanosec=500_000_000)) == 2.5
    assert stamp_to_nanoseconds(Time()) == 0  # unstamped


def test_seconds_become_the_nearest_nanosecond_and_carry_into_the_next_second():
    assert seconds_to_stamp(12.5) == Time(sec=12, nanosec=500_000_000)
    assert seconds_to_stamp(0.9999999999) == Time(sec=1, nanosec=0)
    assert seconds_to_stamp(-0.25) == Time(sec=-1, nanosec=750_000_000)  # Time's own convention below zero


def test_a_diagnostic_status_takes_the_level_by_name_and_every_value_as_text():
    status = diagnostic_status("hardware_node: actuators", "mock", "WARN", "setpoints stale",
                               {"setpoints_received": 3, "output": "setpoints stale"})
    assert status.level == DiagnosticStatus.WARN and status.hardware_id == "mock"
    assert diagnostic_values(status) == {"setpoints_received": "3", "output": "setpoints stale"}
    array = diagnostic_array([status], Time(sec=5))
    assert array.header.stamp.sec == 5 and array.status == [status]
    with pytest.raises(InvalidInputError, match="diagnostic level 'FINE'; expected one of"):
        diagnostic_status("x", "y", "FINE", "", {})
