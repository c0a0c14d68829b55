"""One setpoint into the gate: checked, aged by its stamp, limited by the clamp, shaped and stored, or refused."""

import numpy as np
import pytest

from srs_ros.core.actuation.compensation import setpoint_shaper
from srs_ros.core.actuation.intake import NoteThrottle, Setpoint, Verdict, take_setpoint
from srs_ros.core.actuation.safety import CommandGate, OutputReason, StampCheck
from srs_ros.core.robot import default_robot

ROBOT = default_robot()
NAMES = list(ROBOT.joint_names)
NOW_NS = 1_700_000_000 * 10**9  # the receiver's clock (ns)
NOW_S = 50.0  # the gate's steady clock (s)


@pytest.fixture
def shaper():
    return setpoint_shaper(ROBOT, "paper")  # P = 100 l


@pytest.fixture
def gate():
    return CommandGate(joint_count=9, setpoint_timeout_s=0.2, active=True)


def test_an_unstamped_setpoint_in_any_order_is_commanded_in_joint_order(shaper, gate):
    decision = take_setpoint(Setpoint(NAMES[::-1], np.arange(9.0)[::-1] / 400), shaper, gate, NOW_NS, NOW_S)
    assert decision.accepted and decision.stamp is StampCheck.UNSTAMPED and decision.age_s == 0.0
    assert not (decision.rejection or decision.limit_note or decision.clock_note or decision.velocity_note)
    pressure_bar, reason = gate.decide(NOW_S)
    assert reason is OutputReason.COMMANDING and pressure_bar == pytest.approx(np.arange(9.0) / 4)


def test_an_invalid_setpoint_is_refused_and_the_previous_command_goes_on(shaper, gate):
    take_setpoint(Setpoint(NAMES, [0.02] * 9), shaper, gate, NOW_NS, NOW_S)
    decision = take_setpoint(Setpoint(NAMES[:8] + ["m4_pma1"], [0.03] * 9), shaper, gate, NOW_NS, NOW_S + 0.01)
    assert decision.verdict is Verdict.INVALID and decision.stamp is None  # the stamp was not looked at
    assert "rejected setpoint, not sent (the previous command continues until stale): " in decision.rejection
    assert "unknown joint names ['m4_pma1']" in decision.rejection
    assert gate.decide(NOW_S + 0.01)[0] == pytest.approx(np.full(9, 2.0))


def test_a_setpoint_stamped_longer_ago_than_the_timeout_is_stale_on_arrival(shaper, gate):
    decision = take_setpoint(Setpoint(NAMES, [0.02] * 9, stamp_ns=NOW_NS - 300_000_000), shaper, gate, NOW_NS, NOW_S)
    assert decision.verdict is Verdict.STALE and decision.stamp is StampCheck.STALE
    assert decision.age_s == pytest.approx(0.3) and decision.clock_offset_s == pytest.approx(0.3)
    assert "its stamp is 0.300 s old, more than setpoint_timeout_s 0.2 s" in decision.rejection
    assert gate.decide(NOW_S)[1] is OutputReason.NO_SETPOINT  # nothing stored


def test_a_setpoint_that_arrives_old_is_held_only_for_the_rest_of_its_timeout(shaper, gate):
    decision = take_setpoint(Setpoint(NAMES, [0.02] * 9, stamp_ns=NOW_NS - 150_000_000), shaper, gate, NOW_NS, NOW_S)
    assert decision.accepted and decision.age_s == pytest.approx(0.15) and decision.stamp_ns == NOW_NS - 150_000_000
    assert gate.decide(NOW_S + 0.04)[1] is OutputReason.COMMANDING
    assert gate.decide(NOW_S + 0.06)[1] is OutputReason.STALE


def test_a_setpoint_from_the_future_is_aged_from_its_arrival_and_the_clock_offset_said(shaper, gate):
    decision = take_setpoint(Setpoint(NAMES, [0.02] * 9, stamp_ns=NOW_NS + 10**9), shaper, gate, NOW_NS, NOW_S)
    assert decision.accepted and decision.stamp is StampCheck.FUTURE and decision.age_s == 0.0
    assert decision.clock_offset_s == pytest.approx(-1.0)
    assert decision.clock_note.startswith("setpoint stamped 1.000 s in the future: the sender's clock runs ahead")


def test_unusable_velocities_are_dropped_and_the_lengths_used(shaper, gate):
    decision = take_setpoint(Setpoint(NAMES, [0.02] * 9, [float("nan")] * 9), shaper, gate, NOW_NS, NOW_S)
    assert decision.accepted and decision.velocity_note.startswith("setpoint velocities ignored (the lengths are used)")
    assert gate.decide(NOW_S)[0] == pytest.approx(np.full(9, 2.0))


def test_lengths_beyond_the_pressure_limit_are_limited_and_said_not_refused(shaper, gate):
    decision = take_setpoint(Setpoint(NAMES, [0.05, -0.01] + [0.02] * 7), shaper, gate, NOW_NS, NOW_S)
    assert decision.accepted
    assert decision.limit_note.startswith("setpoint limited by the clamp: ['m1_pma1', 'm1_pma2'] ask [0.05, -0.01] m")
    assert gate.decide(NOW_S)[0] == pytest.approx([4.0, 0.0] + [2.0] * 7)  # [0, 4] bar, always


def test_a_lead_the_clamp_cuts_is_said(gate):
    shaper = setpoint_shaper(ROBOT, "paper", delay_s=0.03, time_constant_s=0.08, compensation=True)
    decision = take_setpoint(Setpoint(NAMES, [0.039] * 9, [0.5] * 9), shaper, gate, NOW_NS, NOW_S)
    assert decision.accepted and decision.compensation_note.startswith("lag compensation: the lead asked for more "
                                                                       "than [0, 4] bar")
    assert gate.decide(NOW_S)[0] == pytest.approx(np.full(9, 4.0))
    calm = take_setpoint(Setpoint(NAMES, [0.02] * 9, [0.0] * 9), shaper, gate, NOW_NS, NOW_S + 0.01)
    assert calm.accepted and not calm.compensation_note


def test_each_kind_of_note_has_its_severity_and_is_throttled_on_its_own(shaper, gate):
    invalid = take_setpoint(Setpoint(NAMES[:8], [0.02] * 8), shaper, gate, NOW_NS, NOW_S)
    stale = take_setpoint(Setpoint(NAMES, [0.02] * 9, stamp_ns=NOW_NS - 300_000_000), shaper, gate, NOW_NS, NOW_S)
    limited = take_setpoint(Setpoint(NAMES, [0.05] * 9, [float("nan")] * 9, NOW_NS + 10**9), shaper, gate, NOW_NS,
                            NOW_S)
    assert [(n.kind, n.severity) for n in invalid.notes()] == [("invalid", "error")]
    assert [(n.kind, n.severity) for n in stale.notes()] == [("stale", "error")]
    assert [(n.kind, n.severity, n.throttle_s) for n in limited.notes()] == [
        ("velocity", "warning", 1.0), ("clock", "warning", 1.0), ("limit", "warning", 5.0)]
    assert limited.notes()[2].text == limited.limit_note
    assert take_setpoint(Setpoint(NAMES, [0.02] * 9), shaper, gate, NOW_NS, NOW_S).notes() == ()
    throttle = NoteThrottle()
    assert throttle.due(invalid.notes() + limited.notes(), 10.0) == [*invalid.notes(), *limited.notes()]  # first: said
    assert throttle.due(stale.notes() + invalid.notes(), 10.5) == list(stale.notes())  # a kind of its own
    assert throttle.due(invalid.notes() + limited.notes(), 11.0) == [*invalid.notes(), *limited.notes()[:2]]
    assert throttle.due(limited.notes(), 11.5) == []
    assert throttle.due(limited.notes(), 14.9) == list(limited.notes()[:2])  # the limit note: 5 s since 10.0
    assert throttle.due(limited.notes(), 15.0) == list(limited.notes()[2:])
