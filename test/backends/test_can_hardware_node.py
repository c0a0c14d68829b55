"""End to end: the hardware node (its own process) on a CAN bus that fails and comes back, and a SIGKILL."""

import socket
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from backends.can_bus import (
    COMMAND_IDS,
    DBC,
    V_PER_BAR,
    board_applies,
    wait_for,
    write_can_rig,
)
from backends.reference_dac_board import BoardTicker, ReferenceDacBoard

from srs_ros.backends.can_backend import crc8_sae_j1850
from srs_ros.core.robot import default_robot


class FakeSocketcand:
    """A minimal socketcand daemon on loopback (python-can's `socketcand` interface connects to it over TCP).

    It plays the DAC board for a node in another process: records every `< send ... >` frame, answers
    with monitor read-back frames, and can drop the connection as a dead bus would.
    """

    def __init__(self, monitor_v: float = 3.0, board: ReferenceDacBoard | None = None):
        self.board = board
        self.server = socket.create_server(("127.0.0.1", 0))
        self.server.settimeout(0.1)
        self.port = self.server.getsockname()[1]
        self.frames: list[tuple[int, bytes]] = []
        self.connections = 0
        self.drop = threading.Event()
        self.stop = threading.Event()
        message = DBC.get_message_by_name("SRS_MON_A")
        data = message.encode({s.name: monitor_v for s in message.signals})
        self.monitor = f"< frame 180 0.0 {data.hex().upper()} >".encode()
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def close(self):
        self.stop.set()
        self.thread.join(5.0)
        self.server.close()

    def _serve(self):
        while not self.stop.is_set():
            try:
                connection, _ = self.server.accept()
            except TimeoutError:
                continue
            with connection:
                self.connections += 1
                self._session(connection)

    def _session(self, connection):
        connection.settimeout(2.0)
        for reply_to in (None, "< open", "< rawmode"):
            if reply_to is not None:
                assert connection.recv(256).decode().startswith(reply_to)
            connection.sendall(b"< hi >" if reply_to is None else b"< ok >")
        connection.settimeout(0.05)
        buffer = ""
        while not self.stop.is_set() and not self.drop.is_set():
            try:
                chunk = connection.recv(4096).decode()
            except TimeoutError:
                continue
            except OSError:  # reset by a killed client
                return
            if not chunk:
                return
            buffer += chunk
            *complete, buffer = buffer.split(">")
            for text in complete:
                parts = text.strip("< ").split()
                if parts[:1] == ["send"]:
                    frame_id, dlc = int(parts[1], 16), int(parts[2], 16)
                    self.frames.append((frame_id, bytes(int(b, 16) for b in parts[3:3 + dlc])))
                    if self.board is not None:
                        self.board.receive(*self.frames[-1], time.monotonic())
            connection.sendall(self.monitor)
        self.drop.clear()  # leaving the with block closes the socket: the node's next sends fail

    def last_write_mv(self) -> np.ndarray | None:
        frames = list(self.frames)
        for k in range(len(frames) - 3, -1, -1):
            window = frames[k:k + 3]
            if [f for f, _ in window] == COMMAND_IDS:
                signals = {}
                for frame_id, data in window:
                    signals.update(DBC.decode_message(frame_id, data))
                return np.round(np.array([signals[f"CMD_CH{i}"] for i in range(1, 10)]) * 1000.0)
        return None


def socketcand_rig(tmp_path, port: int, rate_hz: float, setpoint_timeout_s: float, **options) -> Path:
    """A rig file for the hardware node on python-can's socketcand interface, connected to FakeSocketcand;
    ``options``: more backend options (e.g. ``board_timeout_s``)."""
    bus = {"interface": "socketcand", "channel": "can0", "bus_options": {"host": "127.0.0.1", "port": port}, **options}
    return write_can_rig(tmp_path / "socketcand.yaml", "socketcand_dac", bus, rate_hz, setpoint_timeout_s)


@pytest.mark.ros
@pytest.mark.slow(seconds=4)
def test_hardware_node_can_fault_goes_to_error_and_recovers(launch_node, ros_client, tmp_path):
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from sensor_msgs.msg import JointState
    from srs_testing import ros_args

    from srs_ros.ros.interfaces import ACTUATOR_STATE_TOPIC, DIAGNOSTICS_TOPIC, SETPOINT_TOPIC, setpoint_qos

    daemon = FakeSocketcand(monitor_v=3.0)  # 3 V on the ITV monitor output = (3 - 1) / 4 * 9 = 4.5 bar
    try:
        rig = socketcand_rig(tmp_path, daemon.port, rate_hz=50.0, setpoint_timeout_s=1.0)
        node = launch_node("hardware_node", ros_args({"rig_file": str(rig)}))
        client = ros_client
        publisher = client.node.create_publisher(JointState, SETPOINT_TOPIC, setpoint_qos())
        states = client.subscribe(JointState, ACTUATOR_STATE_TOPIC)
        diagnostics = client.subscribe(DiagnosticArray, DIAGNOSTICS_TOPIC)
        names = list(default_robot().joint_names)

        def stream_until(lengths_m, predicate, what, timeout_s=15.0):
            msg = JointState(name=names, position=[float(v) for v in lengths_m])
            end = time.monotonic() + timeout_s
            while not predicate():
                assert time.monotonic() < end, f"timed out waiting for {what}; node output:\n{node.output()}"
                publisher.publish(msg)
                client.executor.spin_once(timeout_sec=0.01)

        def commanding(millivolts):
            return lambda: (last := daemon.last_write_mv()) is not None and np.allclose(last, millivolts)

        client.spin_until(lambda: client.lifecycle_state("/hardware_node") == "unconfigured", what="node up")
        for transition in ("configure", "activate"):
            assert client.change_state("/hardware_node", transition), node.output()
        # real regulators: nothing above 0 bar until the operator arms the node
        sent_before = len(daemon.frames)
        stream_until(np.full(9, 0.02), lambda: len(daemon.frames) > sent_before + 3 * 25, "0.5 s of frames")
        assert all(not any(DBC.decode_message(frame_id, data)[f"CMD_CH{i}"] for i in range(1, 10)
                           if f"CMD_CH{i}" in DBC.decode_message(frame_id, data))
                   for frame_id, data in list(daemon.frames)[sent_before:] if frame_id in COMMAND_IDS)
        assert client.trigger("/hardware_node/arm").success
        stream_until(np.full(9, 0.02), commanding(np.full(9, 2222.0)), "2 bar = 2.222 V on the bus")
        client.spin_until(lambda: states and len(states[-1].effort) == 9 and states[-1].effort[0] == pytest.approx(
            4.5, abs=0.01), what="monitor read-back as effort")

        daemon.drop.set()  # the bus dies
        stream_until(np.full(9, 0.02), lambda: client.lifecycle_state("/hardware_node") == "unconfigured",
                     "the CAN send failure to take the node through ErrorProcessing")
        client.spin_until(lambda: diagnostics and diagnostics[-1].status[0].level == DiagnosticStatus.ERROR,
                          what="the fault on /diagnostics")
        assert "CAN send" in diagnostics[-1].status[0].message and "HardwareError" in diagnostics[-1].status[0].message

        sent_before = len(daemon.frames)
        for transition in ("configure", "activate"):  # the bus is back: recover without restarting the process
            assert client.change_state("/hardware_node", transition), node.output()
        assert daemon.connections == 2
        assert client.trigger("/hardware_node/arm").success  # the fault disarmed: the operator arms again
        stream_until(np.full(9, 0.03), commanding(np.full(9, 3333.0)), "3 bar = 3.333 V after recovery")
        reopened = DBC.decode_message(*daemon.frames[sent_before])
        assert reopened == {"CMD_CH1": 0, "CMD_CH2": 0, "CMD_CH3": 0, "ALIVE": 0, "CRC8": reopened["CRC8"]}
        assert reopened["CRC8"] == crc8_sae_j1850(daemon.frames[sent_before][1][:7])  # re-opened: vented, count 0
        assert client.change_state("/hardware_node", "deactivate")
        client.spin_until(commanding(np.zeros(9)), what="vent frames on deactivate")
        assert node.alive()
    finally:
        daemon.close()


@pytest.mark.ros
@pytest.mark.slow
def test_sigkill_of_the_hardware_node_lets_the_board_vent_by_itself(launch_node, ros_client, tmp_path):
    """The node (its own process) commands 2 bar through socketcand; SIGKILL sends no vent: the board vents alone."""
    from sensor_msgs.msg import JointState
    from srs_testing import ros_args

    from srs_ros.ros.interfaces import SETPOINT_TOPIC, setpoint_qos

    timeout_s = 0.1
    board = ReferenceDacBoard(timeout_s=timeout_s)
    ticker = BoardTicker(board)
    daemon = FakeSocketcand(board=board)
    try:
        rig = socketcand_rig(tmp_path, daemon.port, rate_hz=100.0, setpoint_timeout_s=5.0, board_timeout_s=timeout_s)
        node = launch_node("hardware_node", ros_args({"rig_file": str(rig), "autostart": True}))
        assert ros_client.trigger("/hardware_node/arm", repeatable=True).success  # real regulators: the operator's go
        publisher = ros_client.node.create_publisher(JointState, SETPOINT_TOPIC, setpoint_qos())
        setpoint = JointState(name=list(default_robot().joint_names), position=[0.02] * 9)  # 2 bar
        applied = board_applies(board, 2.0 * V_PER_BAR)
        end = time.monotonic() + 20.0
        while not applied():
            assert time.monotonic() < end, f"the board never applied 2 bar; node output:\n{node.output()}"
            publisher.publish(setpoint)
            ros_client.executor.spin_once(timeout_sec=0.01)
        ros_client.spin_for(0.3)  # the node keeps commanding 2 bar at 100 Hz without new setpoints
        assert not board.snapshot()[0]

        node.kill()
        killed_s = time.monotonic()
        wait_for(lambda: board.snapshot()[0], "the board to vent after the node died")
        vented_at_s, reason = board.snapshot()[2][-1]
        assert reason.startswith("no valid command frame") and board.snapshot()[1] == [0.0] * 9
        # it died commanding 2 bar: no vent sent. The kill can cut a set of three frames, so the last three frames
        # may end one set and begin the next: each of the three command frames, each still at 2 bar
        tail = list(daemon.frames)[-3:]
        assert sorted(frame_id for frame_id, _ in tail) == COMMAND_IDS
        for frame_id, data in tail:
            channels = [v for name, v in DBC.decode_message(frame_id, data).items() if name.startswith("CMD_CH")]
            assert np.round(np.array(channels) * 1000.0) == pytest.approx(np.full(3, 2222.0)), (frame_id, channels)
        assert daemon.last_write_mv() == pytest.approx(np.full(9, 2222.0))
        assert timeout_s <= vented_at_s - board.oldest_valid_s() < timeout_s + 0.25
        assert vented_at_s - killed_s < timeout_s + 0.25
        assert board.invalid == {}  # across processes: every frame's counter and CRC in sequence
    finally:
        daemon.close()
        ticker.close()
