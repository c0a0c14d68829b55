"""The hardware node as a separate process, driven as `ros2 lifecycle set` / `ros2 topic pub` / `echo` would.

Most tests share one node process (srs_testing.hardware_rig; the calibrated map's, in
test_hardware_node_calibrated.py, another), each from a known state:
unconfigured, e-stop released, every configurable parameter set for the test as `ros2 param set` would
(they take effect at configure), counters read as growth during the test and the log from the test's
start. Tests of start-up-only behaviour (the read-only pressure limit, use_sim_time, the shipped params
file and the exit) start a process of their own.
"""

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from sensor_msgs.msg import JointState
from srs_testing import note_killed
from srs_testing.hardware_rig import (
    LENGTHS_M,
    NAMES,
    NODE,
    PRESSURES_BAR,
    ZEROS,
    setpoint,
)

from srs_ros.core.robot import config_dir


@pytest.mark.slow(seconds=3)
def test_setpoints_become_clamped_pressures_and_volts_and_deactivate_vents(hardware):
    proc, rig = hardware(extra_args=["--params-file", str(config_dir() / "hardware_node.yaml")], own_process=True)
    rig.start()
    good = setpoint(LENGTHS_M[::-1], NAMES[::-1])  # any order of names
    rig.stream(good, until=lambda: rig.commanded(PRESSURES_BAR), what="commanded pressures P = 100 l")
    assert rig.pressure[-1].layout.dim[0].label == ",".join(NAMES)
    rig.stream(good, until=lambda: rig.voltage and np.allclose(rig.voltage[-1].data, 10 * PRESSURES_BAR / 9),
               what="command volts V = 10 P / 9")
    assert rig.voltage[-1].data[5] == pytest.approx(4.444, abs=1e-3)  # ITV3050: 4 bar -> 4.444 V

    # the simulated muscles follow (lag, delay): measured pressure in effort, length in position
    rig.stream(good, until=lambda: rig.state and np.allclose(rig.state[-1].effort, PRESSURES_BAR, atol=0.05),
               what="measured pressures in actuator_state")
    assert rig.state[-1].name == NAMES

    rig.stream(good, until=lambda: rig.diagnostic("output") == "commanding", what="diagnostics while commanding")
    assert rig.diagnostic().level == DiagnosticStatus.OK
    assert rig.diagnostic("lifecycle_state") == "active" and rig.diagnostic("backend") == "mock"
    assert float(rig.diagnostic("command_rate_hz")) > 20.0  # 200 Hz on an idle machine; loose on a busy one
    assert float(rig.diagnostic("setpoint_age_s")) < 1.0

    assert rig.client.change_state(NODE, "deactivate")
    rig.stream(good, until=lambda: rig.commanded(ZEROS), what="vent on deactivate")
    assert rig.client.lifecycle_state(NODE) == "inactive"
    count = len(rig.pressure)
    rig.stream(good, timeout_s=0.5)
    inactive = rig.pressure[count:]
    assert inactive and all(np.allclose(msg.data, ZEROS) for msg in inactive)  # inactive sends 0 bar
    assert proc.stop() == 0  # Ctrl-C: vent, close, exit cleanly
    assert "hardware_node: stopped; every valve vented to 0 bar" in proc.output()
    assert "Traceback" not in proc.log_path.read_text()


def test_bad_setpoints_never_reach_the_backend(hardware):
    proc, rig = hardware()
    rig.start()
    good = setpoint(LENGTHS_M)
    rig.stream(good, until=lambda: rig.commanded(PRESSURES_BAR), what="good command")
    bad = [
        setpoint([float("nan")] + [0.03] * 8),
        setpoint([float("inf")] + [0.03] * 8),
        setpoint([0.03] * 8, NAMES[:8]),  # wrong size
        setpoint([0.03] * 9, NAMES[:8] + ["m4_pma1"]),  # unknown name
        setpoint([0.03] * 9, NAMES[:8] + [NAMES[0]]),  # duplicate name
        JointState(name=NAMES, position=[0.03] * 8),  # names/positions mismatch
    ]
    count = len(rig.pressure)
    # the good one keeps the command fresh; every bad one is refused and counted (diagnostics come at 1 Hz)
    rig.stream([m for b in bad for m in (b, good)], until=lambda: rig.counted("rejected_setpoints") >= len(bad),
               what="rejections counted in diagnostics")
    after = rig.pressure[count:]
    # Only the good command reaches the valves, and it goes on; a vent may come between (a stall of this busy test
    # process leaves the good one stale for more than setpoint_timeout_s: the node vents, as it must; seen once).
    assert after and all(np.allclose(m.data, PRESSURES_BAR) or np.allclose(m.data, ZEROS) for m in after)
    assert sum(np.allclose(m.data, PRESSURES_BAR) for m in after) > len(after) // 2, [list(m.data) for m in after]
    assert "rejected setpoint" in proc.output()

    # only bad ones: the last good command goes stale -> vent within 1 s, never a bad value
    rig.stream(bad, until=lambda: rig.commanded(ZEROS), timeout_s=1.0, what="the vent on stale setpoints")
    assert all(np.allclose(m.data, PRESSURES_BAR) or np.allclose(m.data, ZEROS) for m in rig.pressure[count:])


SETPOINT_SOURCE = """
import sys, time, rclpy
from sensor_msgs.msg import JointState
from srs_ros.ros.interfaces import SETPOINT_TOPIC, setpoint_qos
rclpy.init()
node = rclpy.create_node('setpoint_source')
publisher = node.create_publisher(JointState, SETPOINT_TOPIC, setpoint_qos())
msg = JointState(name=sys.argv[1].split(','), position=[float(v) for v in sys.argv[2].split(',')])
while True:
    publisher.publish(msg)
    time.sleep(0.01)
"""


def test_killed_setpoint_source_vents_within_the_timeout_and_fresh_setpoints_recover(hardware):
    proc, rig = hardware()
    rig.start()
    source = subprocess.Popen([sys.executable, "-c", SETPOINT_SOURCE, ",".join(NAMES),
                               ",".join(str(v) for v in LENGTHS_M)], env=rig.env, start_new_session=True,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        rig.client.spin_until(lambda: rig.commanded(PRESSURES_BAR), what="commands from the setpoint source")
        note_killed()  # its Fast DDS shared memory stays behind
        os.killpg(source.pid, signal.SIGKILL)
        source.wait(5.0)
        rig.wait_vented("vent after the source died")  # how fast: test_the_watchdog_runs_on_the_steady_clock...
    finally:
        if source.poll() is None:
            os.killpg(source.pid, signal.SIGKILL)
            source.wait(5.0)
    rig.client.spin_until(lambda: rig.diagnostic("output") == "setpoints stale", what="stale in diagnostics")
    assert rig.diagnostic().level == DiagnosticStatus.WARN
    rig.stream(setpoint(LENGTHS_M), until=lambda: rig.commanded(PRESSURES_BAR), what="recovery on fresh setpoints")


def test_emergency_stop_latches_until_reset(hardware):
    proc, rig = hardware()
    rig.start()
    good = setpoint(LENGTHS_M)
    rig.stream(good, until=lambda: rig.commanded(PRESSURES_BAR), what="good command")
    response = rig.client.trigger(f"{NODE}/emergency_stop")
    assert response.success and "latched" in response.message
    rig.stream(good, until=lambda: rig.commanded(ZEROS), what="vent on e-stop")
    count = len(rig.pressure)
    rig.stream(good, timeout_s=0.7)  # fresh setpoints keep coming: still vented
    assert len(rig.pressure) > count and all(np.allclose(m.data, ZEROS) for m in rig.pressure[count:])
    rig.stream(good, until=lambda: rig.diagnostic("estop_latched") == "True", what="e-stop in diagnostics")
    assert rig.diagnostic().level == DiagnosticStatus.WARN

    response = rig.client.trigger(f"{NODE}/reset")
    assert response.success and "released" in response.message
    rig.stream(good, until=lambda: rig.commanded(PRESSURES_BAR), what="commands after reset")
    assert "not latched" in rig.client.trigger(f"{NODE}/reset").message


def test_a_transition_not_valid_now_is_refused_and_the_node_keeps_commanding(hardware):
    """A transition by id alone (launch_ros's ChangeState event, `ros2 service call .../change_state`), not valid in
    the current state: refused, as rclcpp refuses it. rclpy's state machine raised, and the node vented and exited."""
    proc, rig = hardware()
    rig.start()
    good = setpoint(LENGTHS_M)
    rig.stream(good, until=lambda: rig.commanded(PRESSURES_BAR), what="commands while active")
    assert not rig.client.change_state(NODE, "configure")  # id 1 from active
    assert not rig.client.change_state(NODE, "cleanup")  # id 2 from active
    assert rig.client.lifecycle_state(NODE) == "active" and proc.alive(), proc.output()[-2000:]
    count = len(rig.pressure)
    rig.stream(good, until=lambda: len(rig.pressure) > count + 5, what="commands after the refusals")
    assert np.allclose(rig.pressure[-1].data, PRESSURES_BAR)
    assert "~/change_state refused transition id 1" in proc.output()


def test_the_backend_parameter_runs_a_rig_file_on_another_backend_without_its_options(hardware):
    """`backend:=mock` with the sim rig's file: the rig's own options (the sim board's topics) went to the mock
    backend, which refused them at configure (a helper's review); the tools already left them out."""
    proc, rig = hardware({"rig_file": str(config_dir() / "rigs" / "sim.yaml"), "backend": "mock"})
    rig.start()
    rig.stream(setpoint(LENGTHS_M), until=lambda: rig.commanded(PRESSURES_BAR), what="the mock backend commanding")
    assert "configured: rig 'sim', backend 'mock'" in proc.output(), proc.output()[-2000:]


def test_pressure_limit_is_read_only_and_can_be_lowered_at_start_up(hardware):
    proc, rig = hardware({"autostart": True, "max_pressure_bar": 2.0}, own_process=True)
    rig.client.spin_until(lambda: rig.client.lifecycle_state(NODE) == "active", what="autostart to active")
    result, = rig.client.set_parameters(NODE, {"max_pressure_bar": 4.0})
    assert not result.successful and "read-only" in result.reason
    result, = rig.client.set_parameters(NODE, {"setpoint_timeout_s": 9.0})
    assert not result.successful and result.reason
    result, = rig.client.set_parameters(NODE, {"backend": "pcan"})
    assert not result.successful and "unknown backend 'pcan'" in result.reason
    assert rig.client.get_parameters(NODE, ["max_pressure_bar"]) == {"max_pressure_bar": 2.0}
    rig.stream(setpoint(np.full(9, 0.065)), until=lambda: rig.commanded(np.full(9, 2.0)), what="limited to 2 bar")
    rig.client.spin_until(lambda: rig.voltage and np.allclose(rig.voltage[-1].data, 20 / 9), what="2 bar in volts")


def test_backend_fault_goes_to_the_error_state_and_reconfigure_recovers(hardware, tmp_path):
    broken = tmp_path / "broken.yaml"
    broken.write_text("rig: {name: broken, backend: mock, command_rate_hz: 200.0, setpoint_timeout_s: 0.2,\n"
                      "      backend_options: {pressure_time_constant: 0.1}}\n")
    faulty = tmp_path / "faulty.yaml"
    faulty.write_text("rig: {name: faulty, backend: mock, command_rate_hz: 200.0, setpoint_timeout_s: 0.2,\n"
                      "      backend_options: {fail_after_writes: 100}}\n")
    proc, rig = hardware({"rig_file": str(broken)})
    rig.start(transitions=())
    assert not rig.client.change_state(NODE, "configure")  # unknown option: stays unconfigured, nothing sent
    assert rig.client.lifecycle_state(NODE) == "unconfigured"
    assert "mock backend_options: pressure_time_constant is not a known key" in proc.output()

    assert rig.client.set_parameters(NODE, {"rig_file": str(faulty)})[0].successful
    rig.start(transitions=("configure", "activate"))
    rig.stream(setpoint(LENGTHS_M), until=lambda: rig.client.lifecycle_state(NODE) == "unconfigured",
               what="the injected HardwareError to take the node through ErrorProcessing to unconfigured")
    rig.client.spin_until(lambda: rig.diagnostic() and rig.diagnostic().level == DiagnosticStatus.ERROR,
                          what="the fault on /diagnostics")
    assert "HardwareError" in rig.diagnostic().message
    assert rig.diagnostic("backend_open") == "False"
    assert "VENT FAILED: shut off the air supply" in proc.output()  # the dead backend could not vent either

    assert rig.client.set_parameters(NODE, {"rig_file": ""})[0].successful
    rig.start(transitions=("configure", "activate"))
    rig.stream(setpoint(LENGTHS_M), until=lambda: rig.commanded(PRESSURES_BAR), what="commands after recovery")
    rig.stream(setpoint(LENGTHS_M), until=lambda: rig.diagnostic().level == DiagnosticStatus.OK,
               what="diagnostics OK after recovery")
    assert proc.alive()


def test_setpoints_stamped_before_the_timeout_are_stale_on_arrival(hardware):
    proc, rig = hardware()
    rig.start()
    clock = rig.client.node.get_clock()
    old = setpoint(LENGTHS_M)
    old.header.stamp = (clock.now() - rclpy_duration(2.0)).to_msg()  # queued behind a stall
    rig.stream(old, until=lambda: rig.counted("rejected_setpoints") >= 3, what="stale rejections")
    assert all(np.allclose(m.data, ZEROS) for m in rig.pressure) and rig.pressure
    def fresh():
        msg = setpoint(LENGTHS_M)
        msg.header.stamp = clock.now().to_msg()
        return msg

    rig.stream(fresh, until=lambda: rig.commanded(PRESSURES_BAR), what="a freshly stamped setpoint commanded")
    assert "its stamp is" in proc.output()


def test_a_command_rate_too_slow_for_the_timeout_is_refused_at_configure(hardware):
    proc, rig = hardware({"command_rate_hz": 2.0, "setpoint_timeout_s": 0.2})
    rig.client.spin_until(lambda: rig.client.lifecycle_state(NODE) == "unconfigured", what="hardware_node up")
    assert not rig.client.change_state(NODE, "configure")
    assert rig.client.lifecycle_state(NODE) == "unconfigured"
    rig.client.spin_until(lambda: "expected at least 10 Hz" in proc.output(), what="the reason in the log")


def rclpy_duration(seconds: float):
    from rclpy.duration import Duration

    return Duration(seconds=seconds)


def vent_delays_s(rig, trials: int) -> list[float]:
    """Seconds from the last published setpoint to the first all-zero command, once per trial."""
    delays = []
    for _ in range(trials):
        rig.stream(setpoint(LENGTHS_M), until=lambda: rig.commanded(PRESSURES_BAR), what="commanding")
        stopped_s = rig.last_publish_s
        rig.client.spin_until(lambda: rig.commanded(ZEROS), 5.0, "the vent after the stream stopped")
        delays.append(time.monotonic() - stopped_s)
    return delays


def test_the_watchdog_runs_on_the_steady_clock_with_sim_time_and_no_clock(hardware):
    # use_sim_time without /clock: ROS time stands still at 0; the watchdog must not.
    proc, rig = hardware({"use_sim_time": True, "ramp_time_s": 0.0, "setpoint_timeout_s": 0.2}, own_process=True)
    rig.start()
    delays = vent_delays_s(rig, trials=5)
    print(f"vent after the stream stopped (use_sim_time, no /clock): median {np.median(delays) * 1e3:.0f} ms, "
          f"trials {[round(d * 1e3) for d in delays]} ms")
    # timeout 0.2 s + one 5 ms command period + DDS; a watchdog 1.5x too slow fails
    assert np.median(delays) < 0.2 + 0.08, delays


def test_output_ramps_up_from_zero_at_activation_and_after_an_estop_reset(hardware):
    # a 1 s setpoint timeout: a stall of this client or of the node on a busy machine (> 0.2 s) must not vent
    # mid-ramp and restart it (that restart is test_a_stall_of_the_caller_restarts_output_with_a_ramp's point)
    proc, rig = hardware({"ramp_time_s": 0.5, "setpoint_timeout_s": 1.0})
    rig.start()
    good = setpoint(LENGTHS_M)
    for when in ("activation", "e-stop reset"):
        count = len(rig.pressure)
        rig.stream(good, until=lambda: rig.commanded(PRESSURES_BAR), what=f"full command after the {when}")
        rising = np.array([max(m.data) for m in rig.pressure[count:] if max(m.data) > 0.0])
        assert rising[0] < 0.5, when  # starts near 0 bar, not at the 4 bar command
        assert len(rising) > 20 and np.all(np.diff(rising) >= -1e-9), when  # rises over ~0.5 s at 200 Hz
        assert rig.client.trigger(f"{NODE}/emergency_stop").success
        rig.stream(good, until=lambda: rig.commanded(ZEROS), what="vent on e-stop")
        assert rig.client.trigger(f"{NODE}/reset").success


@pytest.mark.slow(seconds=3)
def test_the_backend_is_written_at_the_command_rate_whatever_the_setpoint_rate(hardware):
    # 25 Hz, a quarter of the stream a loaded client still sends: at 100 Hz, 146 setpoints/s seen beside another
    # test process left a margin of 2-12 % over the bound (a review of the harness).
    proc, rig = hardware({"command_rate_hz": 25.0})
    rig.start()
    good = setpoint(LENGTHS_M)
    received_before, written_before = rig.counted("setpoints_received"), rig.counted("backend_writes")
    end = time.monotonic() + 3.0
    while time.monotonic() < end:  # as fast as the client can: several hundred setpoints per second
        for _ in range(5):
            rig.publisher.publish(good)
        rig.client.executor.spin_once(timeout_sec=0.001)
    received = float(rig.diagnostic("setpoint_rate_hz"))
    written = float(rig.diagnostic("command_rate_hz"))
    print(f"setpoints received {received:.0f}/s, backend writes {written:.0f}/s (command rate 25 Hz)")
    # The stream is faster than the command rate, over the whole three seconds ...
    received_count = rig.counted("setpoints_received") - received_before
    written_count = rig.counted("backend_writes") - written_before
    assert received_count > 2 * written_count, (received_count, written_count)
    # ... and the backend gets commands at the timer's rate, not the stream's. Its lower bound only asks that it is
    # written on: the rate itself is a throughput goal (at 100 Hz, 34/s was seen beside the suite's other workers).
    assert 5.0 < written <= 27.5, written


def test_a_setpoint_that_arrives_old_is_held_only_for_the_rest_of_its_timeout(hardware):
    # 0.3 s old on arrival against a 0.4 s timeout: 0.1 s left, for a delivery that a busy machine slows (a full
    # suite run once saw a setpoint stamped 0.15 s old against 0.2 s arrive stale, 10 s running). Each try is
    # stamped 0.3 s before it is sent, every 0.5 s (past the timeout) until one is held: a stalled delivery only
    # costs a try (a fresh clone's suite failed when the one message, sent again, was 0.8 s old and more).
    proc, rig = hardware({"ramp_time_s": 0.0, "setpoint_timeout_s": 0.4})
    rig.start()
    held = []

    def old():
        message = setpoint(LENGTHS_M)
        message.header.stamp = (rig.client.node.get_clock().now() - rclpy_duration(0.3)).to_msg()
        return message

    for _ in range(3):
        before = len(rig.pressure)
        rig.stream(old, until=lambda start=before: any(max(m.data) > 0 for m in rig.pressure[start:]),
                   what="an old setpoint held", period_s=0.5)
        rig.client.spin_until(lambda: rig.commanded(ZEROS), what="the vent after it")
        held.append(sum(max(m.data) > 0 for m in rig.pressure[before:]))
    print(f"a setpoint 0.3 s old on arrival was commanded {held} times at 200 Hz (median {np.median(held):g})")
    # 0.1 s left of its timeout = about 20 commands at 200 Hz; a watchdog timed from the arrival holds it 0.4 s (80)
    assert np.median(held) <= 30, held


def test_clock_offsets_and_limited_setpoints_are_reported_not_hidden(hardware, ros_client):
    # a process of its own: the clamp's warning it reads is throttled to one per 5 s, and every test sends LENGTHS_M
    proc, rig = hardware({"ramp_time_s": 0.0}, own_process=True)
    rig.start()

    def future():
        msg = setpoint(np.full(9, 0.05))  # 5 bar asked: limited to 4 bar
        msg.header.stamp = (ros_client.node.get_clock().now() + rclpy_duration(1.0)).to_msg()
        return msg

    rig.stream(future, until=lambda: rig.commanded(np.full(9, 4.0)), what="a future-stamped setpoint commanded")
    rig.stream(future, until=lambda: rig.diagnostic() is not None and int(rig.diagnostic("future_stamped")) > 0
               and "clock" in rig.diagnostic().message, what="the clock offset on /diagnostics")
    assert rig.diagnostic().level == DiagnosticStatus.WARN
    assert float(rig.diagnostic("clock_offset_s")) == pytest.approx(-1.0, abs=0.2)
    assert int(rig.diagnostic("limited_setpoints")) > 0
    assert "limited by the clamp" in proc.output() and "in the future" in proc.output()


def test_a_huge_finite_setpoint_is_limited_and_the_node_lives(hardware):
    proc, rig = hardware({"ramp_time_s": 0.0})
    rig.start()
    huge = setpoint([1e307, -1e307, np.finfo(float).max, 0.02, 0.02, 0.02, 0.02, 0.02, 0.02])
    expected = np.array([4.0, 0.0, 4.0, 2.0, 2.0, 2.0, 2.0, 2.0, 2.0])
    rig.stream(huge, until=lambda: rig.commanded(expected), what="huge lengths limited to 4 bar")
    assert proc.alive() and "Traceback" not in proc.output()


def test_hardware_that_would_vent_between_commands_is_refused_at_configure(hardware, tmp_path):
    rig_file = tmp_path / "fast_board.yaml"  # a CAN board that vents after 20 ms of silence, fed at 100 Hz
    rig_file.write_text("rig: {name: fast_board, backend: can, command_rate_hz: 100.0, setpoint_timeout_s: 0.2,\n"
                        "      backend_options: {interface: virtual, channel: srs_fast, board_timeout_s: 0.02}}\n")
    proc, rig = hardware({"rig_file": str(rig_file)})
    rig.client.spin_until(lambda: rig.client.lifecycle_state(NODE) == "unconfigured", what="hardware_node up")
    assert not rig.client.change_state(NODE, "configure")
    rig.client.spin_until(lambda: "would vent between commands" in proc.output(), what="the reason in the log")


# -- the calibrated map and the lag compensation (docs/identification.md) -----------------------------
