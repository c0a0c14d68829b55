"""Setpoint checks, staleness and the e-stop latch of the hardware node, without ROS."""

import numpy as np
import pytest

from srs_ros.core.actuation.safety import (
    CommandGate,
    OutputReason,
    StampCheck,
    clamped_joints,
    min_setpoint_rate_hz,
    setpoint_age_s,
    setpoint_lengths_m,
    setpoint_velocities_m_per_s,
)
from srs_ros.core.errors import InvalidInputError
from srs_ros.core.robot import default_robot

ROBOT = default_robot()
NAMES = list(ROBOT.joint_names)


def test_setpoints_in_any_order_come_back_in_joint_order():
    lengths = setpoint_lengths_m(NAMES[::-1], np.arange(9.0)[::-1] / 100, ROBOT)
    assert lengths == pytest.approx(np.arange(9.0) / 100)


@pytest.mark.parametrize(("names", "positions", "match"), [
    (NAMES[:8], [0.01] * 8, "expected 9 names"),
    (NAMES, [0.01] * 8, "9 names but 8 positions"),
    (NAMES[:8] + ["m4_pma1"], [0.01] * 9, "unknown joint names"),
    (NAMES[:8] + [NAMES[0]], [0.01] * 9, "duplicate joint names"),
    (NAMES, [0.01] * 8 + [float("nan")], "finite"),
    (NAMES, [float("inf")] + [0.01] * 8, "finite"),
])
def test_bad_setpoints_are_rejected_with_the_reason(names, positions, match):
    with pytest.raises(InvalidInputError, match=match):
        setpoint_lengths_m(names, positions, ROBOT)


def test_lengths_the_clamp_changes_are_named_not_rejected():
    lengths = setpoint_lengths_m(NAMES, [-0.01, 0.07, 0.05, 0.04] + [0.01] * 5, ROBOT)
    # 0.05 m is within the muscles' stroke (0.065 m) but needs 5 bar with P = 100 l: limited to 4 bar
    assert clamped_joints(lengths, ROBOT) == ["m1_pma1", "m1_pma2", "m1_pma3"]
    assert clamped_joints(np.full(9, 0.04005), ROBOT) == []  # a 4 bar cycle's spline overshoot is no request


def test_gate_sends_fresh_commands_only_while_active():
    gate = CommandGate(joint_count=9, setpoint_timeout_s=0.2)
    command = np.full(9, 2.0)
    gate.accept(command, now_s=1.0)
    assert gate.decide(1.0)[1] is OutputReason.INACTIVE
    gate.set_active(True)
    assert gate.decide(1.0)[1] is OutputReason.NO_SETPOINT  # activation forgets older setpoints
    gate.accept(command, now_s=2.0)
    pressure, reason = gate.decide(2.1)
    assert reason is OutputReason.COMMANDING and pressure == pytest.approx(command)
    pressure, reason = gate.decide(2.3)
    assert reason is OutputReason.STALE and pressure == pytest.approx(np.zeros(9))
    gate.accept(command, now_s=3.0)  # fresh setpoints recover
    assert gate.decide(3.05)[1] is OutputReason.COMMANDING
    assert gate.setpoint_age_s(3.05) == pytest.approx(0.05)


def test_estop_latches_until_reset():
    gate = CommandGate(joint_count=9, setpoint_timeout_s=0.2, active=True)
    gate.latch_estop()
    gate.accept(np.full(9, 2.0), now_s=1.0)
    pressure, reason = gate.decide(1.0)
    assert reason is OutputReason.ESTOP and pressure == pytest.approx(np.zeros(9))
    assert gate.reset_estop() is True and gate.reset_estop() is False
    assert gate.decide(1.0)[1] is OutputReason.NO_SETPOINT
    gate.accept(np.full(9, 2.0), now_s=1.1)
    assert gate.decide(1.1)[1] is OutputReason.COMMANDING


def test_output_ramps_up_from_zero_whenever_it_restarts():
    gate = CommandGate(joint_count=9, setpoint_timeout_s=0.2, ramp_time_s=1.0, active=True)
    command = np.full(9, 4.0)
    gate.accept(command, now_s=0.0)
    pressure, reason = gate.decide(0.0)
    assert reason is OutputReason.RAMPING and pressure == pytest.approx(np.zeros(9))
    for t in (0.1, 0.2):
        gate.accept(command, now_s=t)
    pressure, reason = gate.decide(0.2)
    assert reason is OutputReason.RAMPING and 0.0 < pressure[0] < 1.0  # raised cosine: 0.1 * 4 bar at 20 %
    for t in np.arange(0.3, 1.01, 0.1):
        gate.accept(command, now_s=t)
        pressure, reason = gate.decide(t)
    assert reason is OutputReason.COMMANDING and pressure == pytest.approx(command)

    assert gate.decide(1.5)[1] is OutputReason.STALE  # vented for stale setpoints ...
    gate.accept(command, now_s=2.0)
    pressure, reason = gate.decide(2.0)  # ... and a resumed stream ramps up again
    assert reason is OutputReason.RAMPING and pressure == pytest.approx(np.zeros(9))
    gate.latch_estop()
    gate.reset_estop()
    gate.accept(command, now_s=2.5)
    assert gate.decide(2.5)[0] == pytest.approx(np.zeros(9))  # after an e-stop reset, too


def commanding_gate(command: np.ndarray) -> tuple[CommandGate, np.ndarray, OutputReason]:
    """A gate (stall gap 0.1 s, ramp 1 s) fed ``command`` every 5 ms for 1.5 s: its last decision and reason."""
    gate = CommandGate(joint_count=9, setpoint_timeout_s=0.2, ramp_time_s=1.0, active=True, max_gap_s=0.1)
    for t in np.arange(0.0, 1.5, 0.005):
        gate.accept(command, now_s=t)
        pressure, reason = gate.decide(t)
    return gate, pressure, reason


def test_a_stall_of_the_caller_restarts_output_with_a_ramp():
    command = np.full(9, 4.0)
    gate, _, reason = commanding_gate(command)
    assert reason is OutputReason.COMMANDING and gate.stalls == 0
    gate.accept(command, now_s=1.65)  # the process was frozen 0.15 s; a fresh setpoint came in first
    pressure, reason = gate.decide(1.65)
    assert reason is OutputReason.RAMPING and pressure == pytest.approx(np.zeros(9)) and gate.stalls == 1
    gate.accept(command, now_s=1.66)
    assert 0.0 < gate.decide(1.66)[0][0] < 0.1  # rising again from 0 bar, not a step to 4 bar
    gate.restart_stall_watch()  # (re)configured after a pause: no stall
    gate.decide(9.0)
    assert gate.stalls == 1


def test_a_decision_sent_later_than_the_stall_gap_is_withdrawn_and_output_ramps_again():
    command = np.full(9, 4.0)
    gate, pressure, reason = commanding_gate(command)
    sent, why = gate.withdraw_if_late((pressure, reason), 1.495, 1.5)
    assert sent == pytest.approx(command) and why is OutputReason.COMMANDING  # sent at once: as decided
    sent, why = gate.withdraw_if_late((pressure, reason), 1.495, 1.8)
    assert sent == pytest.approx(np.zeros(9)) and why is OutputReason.STALE  # frozen in between
    assert gate.stalls == 1
    gate.accept(command, now_s=1.805)
    assert gate.decide(1.805)[0] == pytest.approx(np.zeros(9))
    gate.accept(command, now_s=1.81)
    assert 0.0 < gate.decide(1.81)[0][0] < 0.1 and gate.stalls == 1  # a ramp from 0 bar, the stall counted once


def test_a_rig_with_real_regulators_commands_nothing_until_armed():
    gate = CommandGate(joint_count=9, setpoint_timeout_s=0.2, requires_arm=True)
    assert "activate" in gate.arm() and not gate.armed  # inactive: refused with what to do
    gate.set_active(True)
    gate.accept(np.full(9, 2.0), now_s=1.0)
    pressure, reason = gate.decide(1.0)
    assert reason is OutputReason.NOT_ARMED and pressure == pytest.approx(np.zeros(9))
    assert gate.arm() == "" and gate.armed
    gate.accept(np.full(9, 2.0), now_s=1.1)
    assert gate.decide(1.1)[1] is OutputReason.COMMANDING
    gate.latch_estop()  # an e-stop disarms; the reset alone does not re-arm
    assert "reset" in gate.arm()
    gate.reset_estop()
    gate.accept(np.full(9, 2.0), now_s=1.2)
    assert gate.decide(1.2)[1] is OutputReason.NOT_ARMED
    assert gate.arm() == ""
    gate.set_active(False)  # deactivation disarms
    gate.set_active(True)
    gate.accept(np.full(9, 2.0), now_s=1.3)
    assert gate.decide(1.3)[1] is OutputReason.NOT_ARMED
    assert gate.disarm() is False


def test_a_disarm_holds_0_bar_until_arm_also_on_a_rig_that_needs_no_arm():
    gate = CommandGate(joint_count=9, setpoint_timeout_s=0.2, ramp_time_s=0.5, active=True)  # mock, sim
    command = np.full(9, 2.0)
    for t in np.arange(1.0, 1.6, 0.005):
        gate.accept(command, now_s=t)
        gate.decide(t)
    assert gate.decide(1.6)[1] is OutputReason.COMMANDING and gate.has_go  # no arm needed to start
    assert gate.disarm() is True and not gate.has_go
    for t in np.arange(1.6, 3.0, 0.005):  # fresh setpoints keep coming: 0 bar, every tick
        gate.accept(command, now_s=t)
        pressure, reason = gate.decide(t)
        assert reason is OutputReason.NOT_ARMED and not pressure.any(), t
    gate.set_active(False)  # neither deactivation nor activation gives the go back
    gate.set_active(True)
    gate.accept(command, now_s=3.0)
    assert gate.decide(3.0)[1] is OutputReason.NOT_ARMED and gate.disarm() is False
    assert gate.arm() == "" and gate.has_go
    gate.accept(command, now_s=3.1)
    pressure, reason = gate.decide(3.1)
    assert reason is OutputReason.RAMPING and not pressure.any()  # resumes with the usual ramp from 0 bar
    gate.accept(command, now_s=3.35)
    assert 0.0 < gate.decide(3.35)[0][0] < 2.0
    gate.accept(command, now_s=3.65)
    assert gate.decide(3.65) == (pytest.approx(command), OutputReason.COMMANDING)


def test_a_setpoint_that_arrives_old_vents_by_its_stamp_not_a_full_timeout_later():
    gate = CommandGate(joint_count=9, setpoint_timeout_s=0.2, active=True)
    gate.accept(np.full(9, 2.0), now_s=10.0, age_s=0.19)  # made at 9.81 s
    assert gate.decide(10.005)[1] is OutputReason.COMMANDING
    assert gate.decide(10.011)[1] is OutputReason.STALE  # 0.2 s after it was made, not at 10.2 s


@pytest.mark.parametrize(("stamp_ns", "now_ns", "age_s", "check"), [
    (0, 5 * 10**9, 0.0, StampCheck.UNSTAMPED),  # aged from arrival
    (5 * 10**9, 5 * 10**9 + 50 * 10**6, 0.05, StampCheck.OK),
    (5 * 10**9 + 10**6, 5 * 10**9, 0.0, StampCheck.OK),  # 1 ms ahead: clock jitter, not an offset
    (6 * 10**9, 5 * 10**9, 0.0, StampCheck.FUTURE),  # 1 s ahead: the sender's clock runs ahead
    (4 * 10**9, 5 * 10**9, 1.0, StampCheck.STALE),  # 1 s old: stale on arrival
])
def test_setpoint_age_from_the_stamp_or_the_arrival(stamp_ns, now_ns, age_s, check):
    assert setpoint_age_s(stamp_ns, now_ns, timeout_s=0.2) == (pytest.approx(age_s), check)


def test_the_slowest_stream_that_keeps_the_watchdog_fed():
    assert min_setpoint_rate_hz(0.2) == pytest.approx(10.0)


def test_setpoint_velocities_follow_the_names_order_and_are_optional():
    names = list(ROBOT.joint_names)[::-1]
    assert setpoint_velocities_m_per_s(names, [], ROBOT) is None  # a sender without rates
    assert setpoint_velocities_m_per_s(names, list(range(9)), ROBOT) == pytest.approx(np.arange(9)[::-1])
    with pytest.raises(InvalidInputError, match="9 names but 8 velocities"):
        setpoint_velocities_m_per_s(names, [0.0] * 8, ROBOT)
    with pytest.raises(InvalidInputError, match="finite"):
        setpoint_velocities_m_per_s(names, [float("nan")] + [0.0] * 8, ROBOT)


def test_a_hold_sends_0_bar_keeps_the_setpoint_and_ramps_back_in_when_it_clears():
    gate = CommandGate(joint_count=9, setpoint_timeout_s=1.0, ramp_time_s=0.5, active=True)
    gate.accept(np.full(9, 2.0), now_s=0.0)
    gate.decide(0.0)
    pressure, reason = gate.decide(0.6)
    assert reason is OutputReason.COMMANDING and pressure == pytest.approx(np.full(9, 2.0))
    pressure, reason = gate.decide(0.7, holding="sim_world silent for 0.25 s")
    assert reason is OutputReason.HOLDING and not pressure.any()
    pressure, reason = gate.decide(0.8)  # the hold clears; the kept setpoint (0.8 s old) ramps back in from 0
    assert reason is OutputReason.RAMPING and 0.0 <= pressure.max() < 0.2
    gate.accept(np.full(9, 2.0), now_s=1.2)
    assert gate.decide(1.31)[1] is OutputReason.COMMANDING
