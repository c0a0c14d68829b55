"""Faults as tests: nodes killed, frozen and restarted, a backend that dies mid-gait, a file that blocks.

Each runs the nodes as processes over DDS and checks the safe outcome where it matters, at the backend
(the mock backend's ``record_file``, written by the hardware node's own process):

- gait_player SIGKILL or SIGSTOP: the valves vent within the setpoint timeout; on restart or SIGCONT the
  output ramps up from 0 bar, and the player's setpoints do not jump;
- trajectory_server SIGKILL or SIGSTOP: the gait plays on; a restarted server's trajectory takes over
  without a vent; ~/regenerate answers after SIGCONT;
- hardware_node SIGKILL and restart: nothing more is written (real hardware vents by itself); the
  restarted node opens the backend at 0 bar and ramps up;
- hardware_node SIGSTOP / SIGCONT: no command is carried on from before the freeze (a real board vented
  meanwhile): output restarts with a ramp from 0 bar;
- camera_tracker SIGKILL or SIGSTOP: a restarted or resumed tracker tracks again;
- a backend failure mid-gait: lifecycle error -> unconfigured, the reason on /diagnostics and in the
  log, the e-stop answers; reconfigure and activate recover with a ramp;
- a FIFO as rig_file: configure refused at once with the reason; the e-stop answers.

The CAN bus dying mid-run and the CAN board venting when the host dies are in test/backends/test_can_hardware_node.py.
"""

import os
import signal
import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState
from srs_testing import BackendRecord, fastdds_shm_clean, recorded_rig, ros_args

from srs_ros.core.vision.camera_calibration import save_calibration
from srs_ros.ros.interfaces import DIAGNOSTICS_TOPIC, SETPOINT_TOPIC, setpoint_qos
from srs_ros.sim.scene import (
    RobotAppearance,
    SyntheticCamera,
    SyntheticScene,
    constant_velocity_poses,
    write_video,
)

TIMEOUT_S = 0.2
HW = "/hardware_node"
SERVER = ["trajectory_server", ros_args({"gait": "inward_rolling", "samples": 16, "amplitude_bar": 3.0})]
PLAYER = ["gait_player", ros_args({"autostart": True, "rate_hz": 200.0, "ramp_time_s": 0.3})]


def hardware_args(rig) -> list[str]:
    return ros_args({"rig_file": str(rig), "autostart": True, "setpoint_timeout_s": TIMEOUT_S, "ramp_time_s": 0.5})


class Backend(BackendRecord):
    """What the backend was given, with the waits the fault tests need."""

    def __init__(self, path, client):
        super().__init__(path)
        self.client = client

    def wait(self, predicate, what: str, timeout_s: float = 20.0) -> float:
        """Spin until ``predicate()``; return the time it took (s)."""
        start = time.monotonic()
        self.client.spin_until(lambda: predicate() if len(self) else False, timeout_s, what)
        return time.monotonic() - start

    def commanding_above(self, bar: float) -> bool:
        return len(self) > 0 and float(self.pressures_bar[-1].max()) > bar

    def since(self, start: int) -> np.ndarray:
        self.update()
        return self.pressures_bar[start:]

    def ramped_from_zero(self, start: int) -> bool:
        """After row ``start``: output restarted at 0 bar and rose gradually (no step to the gait's pressure)."""
        peaks = self.since(start).max(axis=1)
        first = int(np.argmax(peaks > 0))
        rising, times_s = peaks[first:], self.times_s[start + first:]
        # Gradual: more than 10 rows, or, when the hardware node's ticks stalled mid-ramp (7 rows on the slow VM,
        # stop 60), 0.2 s or more of the 0.5 s ramp before 90 % of the pressure reached.
        top = int(np.argmax(rising >= 0.9 * rising.max())) if rising.size else 0
        gradual = rising.size > 10 or (rising.size > 2 and times_s[top] - times_s[0] >= 0.2)
        return bool(peaks.size and peaks[0] == 0.0 and gradual and rising[0] < 0.5)

    def mostly_commanding(self, start: int) -> bool:
        """After row ``start`` the gait kept playing: at most a stall's worth of vented rows (CPU load)."""
        return float(np.mean(self.since(start).max(axis=1) > 0.0)) > 0.8

    def commanding_time_s(self, start: int) -> float:
        """Time (s) after row ``start`` spent commanding pressure; a gap between rows counts 50 ms at most."""
        peaks = self.since(start).max(axis=1)
        steps_s = np.minimum(np.diff(self.times_s[start:]), 0.05)
        return float(np.sum(steps_s[peaks[1:] > 0.0])) if peaks.size > 1 else 0.0

    def safe(self) -> bool:
        self.update()
        return bool(np.all(np.isfinite(self.pressures_bar)) and np.all((self.pressures_bar >= 0)
                                                                       & (self.pressures_bar <= 4.0)))


def freeze(proc, seconds: float, client, backend: BackendRecord | None = None) -> int:
    """SIGSTOP ``proc`` for ``seconds``, then SIGCONT; return the backend's row count just before SIGCONT."""
    os.killpg(proc.process.pid, signal.SIGSTOP)
    try:
        client.spin_for(seconds)
        return len(backend) if backend is not None else 0
    finally:
        os.killpg(proc.process.pid, signal.SIGCONT)


def start_gait(launch_node, client, folder):
    """trajectory_server, hardware_node (recorded mock rig) and gait_player as processes, the gait playing."""
    rig, record_path = recorded_rig(folder)
    backend = Backend(record_path, client)
    server = launch_node(*SERVER)
    hardware = launch_node("hardware_node", hardware_args(rig))
    player = launch_node(*PLAYER)
    setpoints = client.subscribe(JointState, SETPOINT_TOPIC, setpoint_qos(depth=1000))
    backend.wait(lambda: backend.commanding_above(2.0) and len(setpoints) > 50, "the gait here and at the backend",
                 60.0)
    return rig, record_path, backend, (server, hardware, player), setpoints


@pytest.mark.quiet
@pytest.mark.slow(seconds=11)
def test_killing_and_restarting_each_node_of_the_gait(launch_node, ros_client, tmp_path):
    client = ros_client
    rig, record_path, backend, (server, hardware, player), _ = start_gait(launch_node, client, tmp_path)

    # gait_player dies: the valves vent within the timeout; a new player ramps the gait back in from 0 bar
    player.kill()
    vent_s = backend.wait(backend.vented, "the vent after gait_player died")
    assert vent_s < TIMEOUT_S + 0.3, vent_s
    start = len(backend)
    player = launch_node(*PLAYER)
    backend.wait(lambda: backend.commanding_above(2.0), "the gait from a restarted gait_player", 30.0)
    assert backend.ramped_from_zero(start)

    # trajectory_server dies: the player has the cycle and plays on; a restarted server's cycle takes over
    start = len(backend)
    server.kill()
    client.spin_for(0.5)  # the gait plays on without its server (checked below)
    server = launch_node(*SERVER)
    client.spin_until(lambda: "taking over" in player.output(), 30.0, "the restarted server's trajectory")
    client.spin_for(0.5)
    assert backend.mostly_commanding(start)  # played on (a player that stopped with its server would vent)

    # hardware_node dies: nothing more is written (the mock cannot vent; real hardware vents by itself);
    # a restarted node opens the backend at 0 bar and ramps up to the gait
    hardware.kill()
    last = len(backend)
    client.spin_for(0.5)
    assert len(backend) == last and record_path.read_text().count("# close") == 0
    fastdds_shm_clean()
    hardware = launch_node("hardware_node", hardware_args(rig))
    backend.wait(lambda: len(backend) > last + 50 and backend.commanding_above(2.0),
                 "the gait through a restarted hardware_node", 30.0)
    assert record_path.read_text().count("# open") == 2 and backend.ramped_from_zero(last)
    assert backend.safe()
    for proc in (server, hardware, player):
        assert proc.alive() and "Traceback" not in proc.output(), proc.output()[-3000:]


@pytest.mark.quiet
@pytest.mark.slow
def test_freezing_each_node_of_the_gait(launch_node, ros_client, tmp_path):
    client = ros_client
    _, _, backend, (server, hardware, player), setpoints = start_gait(launch_node, client, tmp_path)

    # gait_player frozen for 0.6 s: the valves vent; resumed, it goes on where it was and the output ramps up
    start, count = len(backend), len(setpoints)
    freeze(player, 0.6, client)
    backend.wait(lambda: backend.commanding_above(2.0), "the gait after SIGCONT")
    peaks = backend.since(start).max(axis=1)
    assert not peaks.all() and backend.ramped_from_zero(start + int(np.argmin(peaks)))
    before = np.array([m.position for m in setpoints[:count]])
    gait_in_50ms = np.abs(before[10:] - before[:-10]).max()  # 10 setpoints = 50 ms at 200 Hz
    across = np.abs(np.diff([m.position for m in setpoints[count - 1:]], axis=0)).max()
    assert across <= 1.2 * gait_in_50ms, (across, gait_in_50ms)  # a 50 ms phase step at most, not 0.6 s of gait

    # hardware_node frozen for 0.6 s (a real board vents meanwhile): it must not carry on at full pressure
    frozen_s = time.monotonic()
    start = freeze(hardware, 0.6, client, backend)
    backend.wait(lambda: len(backend) > start + 40 and backend.commanding_above(2.0), "commands after SIGCONT")
    # From the first row written after SIGCONT, by the rows' own monotonic stamps: a row the node wrote just before
    # SIGSTOP can reach the file after the count above. (A tick frozen between its decision and its write once
    # wrote the old command after SIGCONT, 2.01 then 0 and the ramp: now withdrawn, CommandGate.withdraw_if_late.)
    start = int(np.searchsorted(backend.update().times_s, frozen_s + 0.3))
    assert backend.ramped_from_zero(start), backend.since(start).max(axis=1)[:20]

    # trajectory_server frozen: the gait plays on, ~/regenerate waits, and answers after SIGCONT. Waited on the
    # commanding time, not read after a fixed span: a stalled player (CPU load) vents for a while, a player that
    # stopped with its server vents for good (0.2 s of commands, then none).
    start = len(backend)
    os.killpg(server.process.pid, signal.SIGSTOP)
    try:
        backend.wait(lambda: backend.commanding_time_s(start) >= 1.0, "1 s of the gait with trajectory_server frozen",
                     10.0)
    finally:
        os.killpg(server.process.pid, signal.SIGCONT)
    assert client.trigger("/trajectory_server/regenerate", timeout_s=30.0).success
    assert backend.safe()
    for proc in (server, hardware, player):
        assert proc.alive() and "Traceback" not in proc.output(), proc.output()[-3000:]


@pytest.mark.slow
def test_camera_tracker_killed_frozen_and_restarted_tracks_again(launch_node, ros_client, tmp_path):
    scene = SyntheticScene(camera=SyntheticCamera(width_px=320, height_px=240, height_m=0.6),
                           robot=RobotAppearance(marker_spacing_m=0.25))
    _, truth = constant_velocity_poses(1.0, 10.0, (-0.05, 0.0, -0.4), np.array([0.05, 0.02]))
    video = write_video(tmp_path / "run.avi", scene, truth, 10.0)
    calibration = save_calibration(scene.camera.calibration(), tmp_path / "cal.yaml")
    args = ros_args({"calibration_file": str(calibration), "source": str(video), "source_rate_hz": 20.0,
                     "loop": True})
    poses = ros_client.subscribe(PoseStamped, "/robot_pose")
    tracker = launch_node("camera_tracker", args)
    ros_client.spin_until(lambda: len(poses) >= 5, 30.0, "poses")
    freeze(tracker, 0.5, ros_client)
    count = len(poses)
    ros_client.spin_until(lambda: len(poses) >= count + 5, 10.0, "poses after SIGCONT")
    tracker.kill()
    fastdds_shm_clean()
    count = len(poses)
    tracker = launch_node("camera_tracker", args)
    ros_client.spin_until(lambda: len(poses) >= count + 5, 30.0, "poses from the restarted tracker")
    assert tracker.alive() and "Traceback" not in tracker.output()


@pytest.mark.slow(seconds=8)
def test_a_backend_that_fails_mid_gait_vents_reports_and_recovers(launch_node, ros_client, tmp_path):
    # 5 s at 200 Hz: the node finds the streaming player and ramps in well before, even on a busy machine
    failing, failing_record = recorded_rig(tmp_path, "failing", fail_after_writes=1000)
    good, good_record = recorded_rig(tmp_path, "good")
    client = ros_client
    diagnostics = client.subscribe(DiagnosticArray, DIAGNOSTICS_TOPIC)
    setpoints = client.subscribe(JointState, SETPOINT_TOPIC, setpoint_qos(depth=1000))
    launch_node(*SERVER)
    launch_node(*PLAYER)
    # the gait streams before the hardware node starts: its writes fall in the gait, not in the gait's start-up
    client.spin_until(lambda: len(setpoints) > 50, 60.0, "the gait streaming")
    hardware = launch_node("hardware_node", hardware_args(failing))
    client.spin_until(lambda: client.lifecycle_state(HW) == "unconfigured" and "backend fault" in hardware.output(),
                      60.0, "the failing backend to take the node to unconfigured")
    assert "VENT FAILED" in hardware.output()  # the dead backend could not vent either: said loudly

    def reported() -> bool:
        status = diagnostics[-1].status[0] if diagnostics else None
        return status is not None and status.level == DiagnosticStatus.ERROR and "HardwareError" in status.message

    client.spin_until(reported, 10.0, "the fault on /diagnostics")
    assert client.trigger(f"{HW}/emergency_stop").success and client.trigger(f"{HW}/reset").success
    dead = BackendRecord(failing_record)
    assert len(dead) == 1000 and float(dead.pressures_bar.max()) > 2.0  # it died mid-gait, commanding
    assert client.set_parameters(HW, {"rig_file": str(good)})[0].successful
    assert client.change_state(HW, "configure") and client.change_state(HW, "activate")
    backend = Backend(good_record, client)
    backend.wait(lambda: backend.commanding_above(2.0), "the gait on the recovered backend")
    assert backend.ramped_from_zero(0) and backend.safe() and hardware.alive()


def test_a_fifo_as_rig_file_is_refused_at_once_and_the_estop_answers(launch_node, ros_client, tmp_path):
    fifo = tmp_path / "rig.yaml"
    os.mkfifo(fifo)  # a file that blocks whoever opens it for reading
    hardware = launch_node("hardware_node", ros_args({"rig_file": str(fifo)}))
    client = ros_client
    client.spin_until(lambda: client.lifecycle_state(HW) == "unconfigured", 20.0, "hardware_node up")
    start = time.monotonic()
    assert not client.change_state(HW, "configure", timeout_s=5.0)
    assert time.monotonic() - start < 5.0
    client.spin_until(lambda: "not a regular file" in hardware.output(), 5.0, "the reason in the log")
    assert client.trigger(f"{HW}/emergency_stop", timeout_s=5.0).success
    assert client.lifecycle_state(HW) == "unconfigured" and hardware.alive()
