"""The hardware node's timing rules at configure: command rate vs timeout, the hardware's own vent, the stall gap."""

import math

import pytest

from srs_ros.core.actuation.timing import CommandTiming, command_timing
from srs_ros.core.errors import ConfigurationError
from srs_ros.core.rig import load_rig


def test_zero_parameters_take_the_rigs_rate_and_timeout():
    rig = load_rig(None)  # the mock rig
    timing = command_timing(rig)
    assert (timing.command_rate_hz, timing.setpoint_timeout_s) == (rig.command_rate_hz, rig.setpoint_timeout_s)
    timing = command_timing(rig, command_rate_hz=500.0, setpoint_timeout_s=0.1)
    assert (timing.command_rate_hz, timing.setpoint_timeout_s, timing.period_s) == (500.0, 0.1, 0.002)


def test_a_command_rate_below_two_commands_per_timeout_is_refused_with_the_slowest_rate_allowed():
    assert CommandTiming(command_rate_hz=10.0, setpoint_timeout_s=0.2).period_s == 0.1  # exactly two per timeout
    with pytest.raises(ConfigurationError, match=r"command_rate_hz is 5 Hz .* expected at least 10 Hz"):
        CommandTiming(command_rate_hz=5.0, setpoint_timeout_s=0.2)


@pytest.mark.parametrize(("command_hz", "state_hz", "every"), [(200.0, 50.0, 4), (200.0, 1000.0, 1), (200.0, 60.0, 3),
                                                               (100.0, math.inf, 1)])
def test_the_actuator_state_is_read_every_so_many_commands_at_most_once_per_command(command_hz, state_hz, every):
    assert CommandTiming(command_hz, 0.2, state_publish_rate_hz=state_hz).state_every_ticks == every


def test_hardware_that_would_vent_between_commands_is_refused_with_the_rate_that_works():
    timing = CommandTiming(command_rate_hz=20.0, setpoint_timeout_s=0.2)  # 50 ms between commands
    with pytest.raises(ConfigurationError, match=r"the can hardware vents after 0.1 s .* at least 30 Hz"):
        timing.check_hardware("can", host_loss_timeout_s=0.1, drives_real_hardware=True)
    assert CommandTiming(30.0, 0.2).check_hardware("can", 0.1, drives_real_hardware=True) == ""  # three periods


def test_real_hardware_without_its_own_watchdog_is_allowed_with_a_warning():
    timing = CommandTiming(command_rate_hz=200.0, setpoint_timeout_s=0.2)
    assert "keeps its last command if this host dies" in timing.check_hardware("daq", None, drives_real_hardware=True)
    assert timing.check_hardware("mock", None, drives_real_hardware=False) == ""


def test_a_stall_longer_than_the_timeout_or_the_hardwares_own_vent_restarts_with_a_ramp():
    timing = CommandTiming(command_rate_hz=200.0, setpoint_timeout_s=0.2)
    assert timing.stall_gap_s(host_loss_timeout_s=None) == 0.2
    assert timing.stall_gap_s(host_loss_timeout_s=0.1) == 0.1  # the board vented before the watchdog would
    assert timing.stall_gap_s(host_loss_timeout_s=0.5) == 0.2
