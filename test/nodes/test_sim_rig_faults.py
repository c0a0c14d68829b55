"""The simulated rig keeps running: sim_world paused, stopped for long, killed and restarted; the hardware node killed.

Separate processes over real DDS: sim_world (MuJoCo) and hardware_node on the sim rig; the test streams a
4 bar setpoint (0.04 m, P = 100 l) as gait_player would, and signals the processes as a busy machine, a
debugger or a crash would.
"""

import os
import signal
import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from sensor_msgs.msg import JointState
from srs_testing import ros_args
from std_msgs.msg import Float64MultiArray

from srs_ros.core.robot import config_dir, default_robot
from srs_ros.ros.interfaces import (
    SIM_BOARD_TIMEOUT_S,
    SIM_COMMAND_TOPIC,
    SIM_MONITOR_TOPIC,
    bus_qos,
    diagnostic_values,
    setpoint_qos,
    stamp_to_seconds,
)
from srs_ros.sim.config import load_sim_config

SIM_RIG = str(config_dir() / "rigs" / "sim.yaml")
NAMES = list(default_robot().joint_names)
WORLD_ARGS = ros_args({"camera_rate_hz": 0.0, "markers_rate_hz": 0.0})
HARDWARE_ARGS = ros_args({"autostart": True, "rig_file": SIM_RIG, "ramp_time_s": 0.2})
FULL_BAR = 3.9


class Rig:
    """The test's view of the rig: a 4 bar setpoint stream, the commands, the read-back and /diagnostics."""

    def __init__(self, client):
        self.client = client
        self.commanded = []  # (arrival monotonic s, largest commanded pressure bar)
        self.readback = []  # (arrival monotonic s, largest read-back pressure bar)
        self.diagnostics = client.subscribe(DiagnosticArray, "/diagnostics")
        node = client.node
        node.create_subscription(Float64MultiArray, "commanded_pressure_bar",
                                 lambda m: self.commanded.append((time.monotonic(), max(m.data))), 100)
        self.board_stamped = []  # (stamp s, largest pressure bar) of the commands on the bus, as sent
        self.readback_stamped = []  # (stamp s, largest read-back pressure bar), as sim_world sent them
        node.create_subscription(JointState, SIM_MONITOR_TOPIC, self._on_readback, bus_qos())
        node.create_subscription(JointState, SIM_COMMAND_TOPIC, lambda m: self.board_stamped.append(
            (stamp_to_seconds(m.header.stamp), max(m.effort))), bus_qos())
        publisher = node.create_publisher(JointState, "joint_setpoints", setpoint_qos())
        setpoint = JointState(name=NAMES, position=[0.04] * 9)
        node.create_timer(0.01, lambda: publisher.publish(setpoint))

    def _on_readback(self, msg: JointState) -> None:
        self.readback.append((time.monotonic(), max(msg.effort)))
        self.readback_stamped.append((stamp_to_seconds(msg.header.stamp), max(msg.effort)))

    def world_values(self) -> list[tuple[float, dict]]:
        """(wall stamp s, key values) of sim_world's diagnostics, in order."""
        return [(stamp_to_seconds(m.header.stamp), diagnostic_values(s))
                for m in self.diagnostics for s in m.status if s.name.startswith("sim_world")]

    def world_change(self, key: str, start_s: float, end_s: float) -> float:
        """How much sim_world's count ``key`` (e.g. ``slipped_s``) grew over the diagnostics around [start_s, end_s]."""
        samples = [(stamp_s, float(values[key])) for stamp_s, values in self.world_values()]
        before = [count for stamp_s, count in samples if stamp_s <= start_s]
        after = [count for stamp_s, count in samples if stamp_s >= end_s]
        return after[0] - (before[-1] if before else 0.0)  # the counts start at 0 with the world (this test's)

    def commanding(self, since_s: float = -np.inf) -> bool:
        """The last command received (after ``since_s``, monotonic s) is the full setpoint."""
        return bool(self.commanded) and self.commanded[-1][0] > since_s and self.commanded[-1][1] >= FULL_BAR

    def wait_commanding(self, timeout_s: float, what: str, since_s: float = -np.inf) -> None:
        self.client.spin_until(lambda: self.commanding(since_s), timeout_s, what)

    def hardware_status(self):
        statuses = [s for m in self.diagnostics for s in m.status if s.name.startswith("hardware_node")]
        return statuses[-1] if statuses else None

    def hardware_errors(self, since: int = 0) -> list[str]:
        return [s.message for m in self.diagnostics[since:] for s in m.status
                if s.name.startswith("hardware_node") and s.level == DiagnosticStatus.ERROR]

    def commanded_between(self, start_s: float, end_s: float) -> list[float]:
        return [bar for t, bar in self.commanded if start_s <= t <= end_s]


def pause(process, seconds: float, client) -> tuple[float, float]:
    """SIGSTOP ``process`` for ``seconds`` while the client keeps spinning; the (start, end) monotonic times."""
    os.kill(process.process.pid, signal.SIGSTOP)
    start_s = time.monotonic()
    try:
        client.spin_for(seconds)
    finally:
        os.kill(process.process.pid, signal.SIGCONT)
    return start_s, time.monotonic()


@pytest.mark.slow(seconds=11)
def test_a_paused_simulator_holds_a_stopped_one_faults_and_recovers_and_a_restarted_one_is_picked_up(
        launch_node, ros_client):
    world = launch_node("sim_world", WORLD_ARGS)
    hardware = launch_node("hardware_node", HARDWARE_ARGS)
    rig = Rig(ros_client)
    rig.wait_commanding(60.0, "the sim rig commanding 4 bar")

    # 1. A pause of 0.5 s (a stall under load): hold at 0 bar, then ramp back by itself, no fault.
    errors_before = len(rig.diagnostics)
    for _ in range(3):
        start_s, end_s = pause(world, 0.5, ros_client)
        # A command received after the pause (a client starved through the pause still holds the last one before).
        rig.wait_commanding(5.0, "output ramping back in after a 0.5 s pause", since_s=end_s)
        # Everything commanded from late in the pause until the output is back: a client or a hardware node that
        # stalls as well receives or sends the hold after the pause's end; without the hold it never falls below 3.9.
        held = rig.commanded_between(start_s + 0.35, time.monotonic())
        # The hold is the hardware node's answer to a silence it sees: paused again when a busy machine starved
        # the node (or this client) through the end of the pause, so that no command came from it meanwhile.
        if len(rig.commanded_between(start_s + 0.35, end_s)) >= 3:
            break
    assert held and min(held) == 0.0, f"no hold at 0 bar while sim_world was stopped: {held[:5]}"
    assert rig.hardware_errors(errors_before) == [], rig.hardware_errors(errors_before)
    assert ros_client.lifecycle_state("/hardware_node") == "active"

    # 2. Stopped for 4 s: a hardware error is reported, and the sim rig recovers by itself after SIGCONT. The world
    # is lost after world_lost_timeout_s (2 s) and the vent's acknowledgement waited for 0.5 s: a second to spare
    # for a stalled hardware node, before a world woken up acknowledges the vent after all.
    errors_before = len(rig.diagnostics)
    start_s, end_s = pause(world, 4.0, ros_client)
    # The node reports the fault at once (and at 1 Hz while faulted); this client, stalled by a busy machine, may
    # take the report a little after the pause.
    try:
        ros_client.spin_until(lambda: any("sim_world silent" in e and "recovers by itself" in e
                                          for e in rig.hardware_errors(errors_before)), 3.0,
                              "the fault 'sim_world silent ... recovers by itself' on /diagnostics")
    except AssertionError as exc:  # what the node said instead, for the record (docs/testing.md)
        raise AssertionError(f"{exc}; errors on /diagnostics: {rig.hardware_errors(errors_before)}; the hardware "
                             f"node's output: {hardware.output()[-3000:]}") from None
    # said (the log may reach its file a moment after the report), and the board's own watchdog vents
    ros_client.spin_until(lambda: "did not acknowledge the vent" in hardware.output(), 3.0,
                          "the hardware node saying that sim_world did not acknowledge the vent")
    rig.wait_commanding(15.0, "the sim rig recovering by itself after SIGCONT (no command sent)", since_s=end_s)
    assert ros_client.lifecycle_state("/hardware_node") == "active"

    # 3. Killed: vent, fault reported, no traceback; a restarted sim_world is picked up.
    world.kill()
    killed_s = time.monotonic()
    ros_client.spin_until(lambda: rig.commanded[-1][1] == 0.0 and rig.commanded[-1][0] > killed_s, 5.0,
                          "the vent after sim_world was killed")
    errors_before = len(rig.diagnostics)
    ros_client.spin_until(lambda: any("sim_world" in e for e in rig.hardware_errors(errors_before)), 10.0,
                          "the fault on /diagnostics")
    launch_node("sim_world", WORLD_ARGS)
    rig.wait_commanding(60.0, "the restarted sim_world picked up")
    output = hardware.output()
    assert "Traceback" not in output and "unexpected error" not in output, output[-3000:]


#: Trials of the kill below; a trial a busy machine disturbed (the world slipped or its executor stalled around the
#: hold) is run again, since its lower bound cannot tell a hold from a command that never reached the board.
KILL_TRIALS = 3


def _kill_trial(launch_node, ros_client, rig: "Rig") -> dict:
    """Command 4 bar through a fresh hardware node, SIGKILL it, and time the board's own vent (bus stamps, s)."""
    started_s = time.monotonic()
    hardware = launch_node("hardware_node", HARDWARE_ARGS)
    ros_client.spin_until(lambda: rig.readback and rig.readback[-1][0] > started_s and rig.readback[-1][1] > FULL_BAR,
                          60.0, "4 bar read back")
    hardware.kill()  # SIGKILL while commanding 4 bar: no vent from the host
    ros_client.spin_until(lambda: rig.readback[-1][1] < 0.05, 10.0, "the read-back falling to 0 bar")
    # The board's hold counts from the last command it got, which may come before the kill (a node stalled by a
    # busy machine just before it died): measure from the last command on the bus, by the stamps the hardware
    # node and sim_world put on them (this client, stalled by a busy machine, may take both late and together).
    last_command_s = rig.board_stamped[-1][0]
    vented_at_s = min(t for t, bar in rig.readback_stamped if t > last_command_s and bar < 0.05)
    # The board's timeout counts world time: a world starved by a busy machine runs late by its slips. Its own
    # diagnostics (1 Hz, stamped on the wall clock) say how much world time passed around the hold, and how often
    # its executor (which hears the commands) stalled.
    ros_client.spin_until(lambda: rig.world_values() and rig.world_values()[-1][0] > vented_at_s, 5.0,
                          "sim_world's diagnostics after the vent")
    # A SIGKILL may cut the delivery of the last command (this client got it, the board may not: as a kill cuts a set
    # of CAN frames): the lower bound counts from the command before it.
    return {"vented_s": vented_at_s - last_command_s,
            "vented_after_previous_s": vented_at_s - rig.board_stamped[-2][0],
            "slipped_s": rig.world_change("slipped_s", last_command_s - 1.0, vented_at_s),
            "stalls": rig.world_change("receiver_stalls", last_command_s - 1.0, vented_at_s),
            "gaps_s": np.round(np.diff([stamp_s for stamp_s, _ in rig.board_stamped[-4:]]), 3)}


@pytest.mark.slow(seconds=5)
def test_sim_world_vents_by_itself_when_the_hardware_node_dies(launch_node, ros_client):
    launch_node("sim_world", WORLD_ARGS)
    rig = Rig(ros_client)
    # The read-back decays from 4 to 0.05 bar in the muscles' delay + ln(80) lag time constants once it vents.
    muscles = load_sim_config().muscles
    decay_s = muscles.transport_delay_s + np.log(4.0 / 0.05) * muscles.pressure_time_constant_s
    for trial in range(1, KILL_TRIALS + 1):
        found = _kill_trial(launch_node, ros_client, rig)
        print(f"trial {trial}: hardware_node SIGKILLed at 4 bar: read-back < 0.05 bar {found['vented_s']:.2f} s after "
              f"the last command ({found['vented_after_previous_s']:.2f} s after the one before; the last commands "
              f"{found['gaps_s']} s apart); around it the world slipped {found['slipped_s']:.2f} s and its executor "
              f"stalled {found['stalls']:g} times (board timeout {SIM_BOARD_TIMEOUT_S:g} s + the muscles' decay "
              f"{decay_s:.2f} s)")
        # The upper bound is in world time (the wall time less the world's slips): before the board had a watchdog
        # it held 4 bar for ever. The exact timeout is unit-tested (test/sim/test_realtime.py).
        assert found["vented_s"] - found["slipped_s"] < SIM_BOARD_TIMEOUT_S + decay_s + 1.5
        held = found["vented_after_previous_s"] > 0.3 * SIM_BOARD_TIMEOUT_S + decay_s
        if held or not (found["slipped_s"] > 0.02 or found["stalls"] > 0):
            break  # a trial no stall disturbed decides
    # The board holds the last command for its timeout of world time, then vents; without the hold the read-back is
    # down within the decay alone, 0.38 s after the last command the board got (5 ms after the one before at 200
    # commands per second). The lower bound keeps 0.3 of the hold, on a trial no stall disturbed (or the last): a world
    # or an executor stalled just before the kill may not have taken the last commands this client saw (CI measured
    # 0.50 s after the one before, with 0.52 s slipped around it).
    assert held, f"no hold seen in {trial} trials: the board vented within the muscles' decay of the last command"
