"""Setpoint checks, staleness and the e-stop latch of the hardware node, without ROS."""

import numpy as np
import pytest

from srs_ros.core.errors import InvalidInputError
from srs_ros.core.robot import default_robot
from srs_ros.core.safety import CommandGate, OutputReason, out_of_range_joints, setpoint_lengths_m

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


def test_out_of_range_lengths_are_named_not_rejected():
    lengths = setpoint_lengths_m(NAMES, [-0.01, 0.07] + [0.01] * 7, ROBOT)
    assert out_of_range_joints(lengths, ROBOT) == ["m1_pma1", "m1_pma2"]


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
