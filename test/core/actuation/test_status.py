"""The hardware node's counters and /diagnostics report: values, the summary's level and message, latency."""

import numpy as np
import pytest

from srs_ros.core.actuation.compensation import setpoint_shaper
from srs_ros.core.actuation.intake import Setpoint, take_setpoint
from srs_ros.core.actuation.safety import VENT_FAILED, CommandGate, OutputReason
from srs_ros.core.actuation.status import (
    HardwareStatus,
    NodeSetup,
    configured_message,
    exit_message,
    latency_figures,
    output_message,
    stall_message,
)
from srs_ros.core.actuation.timing import CommandTiming
from srs_ros.core.rig import load_rig
from srs_ros.core.robot import default_robot

ROBOT = default_robot()
NAMES = list(ROBOT.joint_names)
NOW_NS = 1_700_000_000 * 10**9
CONFIGURED = NodeSetup(rig="mock", backend="mock", backend_open=True, lifecycle_state="active", configured=True)


@pytest.fixture
def gate():
    return CommandGate(joint_count=9, setpoint_timeout_s=0.2, active=True)


def test_each_kind_of_setpoint_is_counted_where_the_operator_looks(gate):
    shaper, status = setpoint_shaper(ROBOT, "paper"), HardwareStatus()
    for setpoint in (Setpoint(NAMES, [0.02] * 9, stamp_ns=NOW_NS - 10**7),       # fresh, 10 ms old
                     Setpoint(NAMES[:8], [0.02] * 8),                              # invalid
                     Setpoint(NAMES, [0.02] * 9, stamp_ns=NOW_NS - 3 * 10**8),    # stale on arrival
                     Setpoint(NAMES, [0.05] * 9, stamp_ns=NOW_NS + 10**9),        # limited, from the future
                     Setpoint(NAMES, [0.02] * 9, [1.0] * 8)):                      # velocities ignored
        status.setpoints_received += 1  # the node counts arrivals itself
        status.count_setpoint(take_setpoint(setpoint, shaper, gate, NOW_NS, 10.0))
    values = status.report(10.0, CONFIGURED, gate, shaper).values
    assert {key: values[key] for key in ("setpoints_received", "setpoints_accepted", "rejected_setpoints",
                                         "stale_on_arrival", "future_stamped", "limited_setpoints",
                                         "ignored_velocities", "clock_offset_s", "setpoint_arrival_age_max_ms")} == {
        "setpoints_received": "5", "setpoints_accepted": "3", "rejected_setpoints": "2", "stale_on_arrival": "1",
        "future_stamped": "1", "limited_setpoints": "1", "ignored_velocities": "1", "clock_offset_s": "-1.000",
        "setpoint_arrival_age_max_ms": "300.000"}
    assert status.report(10.5, CONFIGURED, gate, shaper).values["setpoint_arrival_age_max_ms"] == "0.000"  # per period


def test_output_changes_count_stale_vents_and_holds_and_are_said_once():
    status = HardwareStatus()
    assert status.note_reason(OutputReason.COMMANDING) and not status.note_reason(OutputReason.COMMANDING)
    assert status.note_reason(OutputReason.STALE) and status.stale_vents == 1
    status.note_reason(OutputReason.NO_SETPOINT)
    status.note_reason(OutputReason.STALE)  # not from commanding: no vent
    status.note_reason(OutputReason.HOLDING)
    assert (status.stale_vents, status.holds) == (1, 1)
    assert output_message(OutputReason.STALE, 0.2) == "output: setpoints stale (older than 0.2 s) -> 0 bar"
    assert output_message(OutputReason.HOLDING, 0.2, "paused") == ("output: hardware holding at 0 bar: paused; "
                                                                  "ramps back in when it answers")
    assert output_message(OutputReason.RAMPING, 0.2) == "output: ramping up from 0 bar"
    assert output_message(OutputReason.ESTOP, 0.2) == "output: e-stop latched -> 0 bar"


def test_the_latency_is_from_an_accepted_stamp_to_the_first_write_that_sends_it():
    status = HardwareStatus(pending_stamp_ns=NOW_NS)
    status.note_write(OutputReason.NOT_ARMED, "", NOW_NS + 10**6)  # 0 bar: not this setpoint's command
    assert not status.latency_ms and status.ticks == 1
    status.pending_stamp_ns = NOW_NS
    status.note_write(OutputReason.COMMANDING, "", NOW_NS + 3 * 10**6)
    status.note_write(OutputReason.COMMANDING, "", NOW_NS + 8 * 10**6)  # the same command again: no new figure
    assert list(status.latency_ms) == pytest.approx([3.0]) and status.ticks == 3
    assert latency_figures(status.latency_ms) == {"command_latency_p50_ms": "3.000", "command_latency_p99_ms": "3.000",
                                                  "command_latency_max_ms": "3.000", "command_latency_count": "1"}
    assert latency_figures([])["command_latency_p50_ms"] == "n/a"
    assert latency_figures(np.arange(1.0, 101.0))["command_latency_p99_ms"] == "99.010"


def test_rates_are_measured_over_the_period_since_the_previous_report(gate):
    status = HardwareStatus()
    status.start_rate_window(100.0)
    for _ in range(400):
        status.note_write(OutputReason.COMMANDING, "", NOW_NS)
    status.setpoints_received = 100
    report = status.report(102.0, CONFIGURED, gate, None)
    assert (report.values["command_rate_hz"], report.values["setpoint_rate_hz"]) == ("200.0", "50.0")
    assert report.values["pressure_map"] == "none" and report.values["output"] == "inactive"
    assert status.report(103.0, CONFIGURED, gate, None).values["command_rate_hz"] == "0.0"
    unconfigured = status.report(104.0, NodeSetup(), gate, None)
    assert unconfigured.values["output"] == "not configured" and unconfigured.values["command_rate_hz"] == "0.0"


def test_the_summary_puts_a_fault_first_then_the_estop_a_slow_stream_clock_trouble_a_vent_and_a_hold(gate):
    status = HardwareStatus(fault="HardwareError: bus gone", recovers_by_itself=True)
    assert status.summary(CONFIGURED, gate, 200.0, 0) == (
        "ERROR", "backend fault: HardwareError: bus gone; the simulated rig recovers by itself")
    status.recovers_by_itself = False
    assert status.summary(CONFIGURED, gate, 200.0, 0)[1].endswith("configure and activate to recover")
    status.fault = ""
    gate.latch_estop()
    assert status.summary(CONFIGURED, gate, 200.0, 0) == ("WARN", "e-stop latched: venting until ~/reset")
    gate.reset_estop()
    assert status.summary(NodeSetup(), gate, 0.0, 0) == ("OK", "unconfigured: backend closed, nothing sent")
    level, message = status.summary(CONFIGURED, gate, 5.0, 0)
    assert level == "WARN" and "fewer than two per setpoint_timeout_s (0.2 s)" in message
    assert "raise the player's rate_hz to at least 10 Hz" in message
    status.reason, status.clock_offset_s = OutputReason.COMMANDING, 0.3
    level, message = status.summary(CONFIGURED, gate, 200.0, 2)
    assert level == "WARN" and message.startswith("commanding; 2 setpoint stamps") and "+0.300 s" in message
    status.reason = OutputReason.STALE
    assert status.summary(CONFIGURED, gate, 0.0, 0) == ("WARN", "setpoints stale: venting to 0 bar")
    status.reason, status.holding = OutputReason.HOLDING, "simulator paused"
    assert status.summary(CONFIGURED, gate, 0.0, 0)[1].startswith("holding at 0 bar: simulator paused")
    status.reason = OutputReason.COMMANDING
    assert status.summary(CONFIGURED, gate, 200.0, 0) == ("OK", "commanding")


def test_a_fault_is_said_with_what_recovers_it_and_a_recovery_counted():
    status = HardwareStatus()
    status.note_fault("HardwareError: bus gone", recovers_by_itself=False, was_active=True)
    assert status.error_processed(1.0) == ("error processing done: backend closed, node unconfigured; configure and "
                                           "activate to recover (fault: HardwareError: bus gone)")
    status.note_fault("SimulatorLost: silent", recovers_by_itself=True, was_active=True)
    assert status.error_processed(1.0).endswith("the simulated rig recovers by itself: configure + activate in 1 s")
    status.reactivate = False
    assert status.error_processed(2.0).endswith("recovers by itself: configure in 2 s")
    assert status.recovered("active").startswith("recovered by itself after a fault: active, holding 0 bar")
    assert (status.recoveries, status.recovers_by_itself, status.reactivate) == (1, False, False)
    assert HardwareStatus(last_error="configure failed").error_processed(1.0).endswith("(fault: configure failed)")


def test_what_the_node_says_at_configure_at_a_stall_and_at_exit(gate):
    rig = load_rig(None)
    timing = CommandTiming(200.0, 0.2)
    message = configured_message(rig, "mock", gate, timing, setpoint_shaper(ROBOT, "paper"))
    assert message.startswith(f"configured: rig {rig.name!r}, backend 'mock' (simulated: no arm needed), 200 Hz, "
                              "setpoint timeout 0.2 s, limit 4 bar, ")
    assert message.endswith("lag compensation off")
    real = CommandGate(joint_count=9, setpoint_timeout_s=0.2, requires_arm=True)
    assert "(real regulators: nothing above 0 bar until an operator calls ~/arm)" in configured_message(
        rig, "can", real, timing, setpoint_shaper(ROBOT, "paper"))
    gate.disarm()
    assert "(simulated, disarmed: 0 bar until ~/arm)" in configured_message(rig, "mock", gate, timing,
                                                                           setpoint_shaper(ROBOT, "paper"))
    assert stall_message(0.1).startswith("command ticks stalled longer than 0.1 s")
    assert exit_message("hardware_node", True, True) == "hardware_node: stopped; every valve vented to 0 bar"
    assert exit_message("srs_bringup", True, False) == "srs_bringup: stopped; no backend was open, nothing to vent"
    assert exit_message("hardware_node", False, True) == f"hardware_node: stopped; {VENT_FAILED}"
