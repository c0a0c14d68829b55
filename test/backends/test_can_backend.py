"""CAN backend on real python-can buses: a second `virtual` bus on the same channel plays the DAC board."""

import os
import socket
import textwrap
import threading
import time
import uuid
from pathlib import Path

import can
import cantools
import numpy as np
import pytest
from backends.reference_dac_board import BoardTicker, ReferenceDacBoard

from srs_ros.backends import create_backend
from srs_ros.backends.can_backend import CanBackend, crc8_sae_j1850
from srs_ros.core.errors import BackendUnavailableError, ConfigurationError, HardwareError
from srs_ros.core.rig import load_rig
from srs_ros.core.robot import config_dir, default_robot

DBC = cantools.database.load_file(str(config_dir() / "srs_dac.dbc"))
COMMAND_IDS = [0x100, 0x101, 0x102]
MONITOR_IDS = [0x180, 0x181, 0x182]
V_PER_BAR = 10.0 / 9.0  # ITV3050


def expected_mv(pressure_bar):
    return np.round(np.clip(pressure_bar, 0.0, 4.0) * V_PER_BAR * 1000.0)


@pytest.fixture
def channel():
    return f"srs_test_{uuid.uuid4().hex[:8]}"


@pytest.fixture
def board(channel):
    """The DAC board's side of the virtual bus: receives every frame the backend sends."""
    bus = can.Bus(interface="virtual", channel=channel, receive_own_messages=False)
    yield bus
    bus.shutdown()


def backend_on(channel, **options) -> CanBackend:
    return CanBackend(options={"interface": "virtual", "channel": channel, **options})


def receive(bus, count, timeout_s=5.0) -> list:
    """The next `count` frames (fails if they do not arrive), then check nothing else is queued."""
    frames, end = [], time.monotonic() + timeout_s
    while len(frames) < count:
        message = bus.recv(timeout=max(end - time.monotonic(), 0.0))
        assert message is not None, f"received {len(frames)} of {count} frames"
        frames.append(message)
    return frames


def decode_write(frames) -> np.ndarray:
    """Nine command voltages (mV) from the three frames of one write, checking IDs and order."""
    assert [f.arbitration_id for f in frames] == COMMAND_IDS
    assert all(not f.is_extended_id and f.dlc == 8 for f in frames)
    signals = {}
    for frame in frames:
        signals.update(DBC.decode_message(frame.arbitration_id, frame.data))
    return np.round(np.array([signals[f"CMD_CH{i}"] for i in range(1, 10)]) * 1000.0)


def assert_nothing_more(bus):
    extra = bus.recv(timeout=0.05)
    assert extra is None, f"unexpected frame {extra}"


def test_open_vents_and_every_write_sends_the_nine_commands(board, channel):
    pressure = np.array([0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 7.5])  # 7.5 bar: above the limit
    with backend_on(channel) as backend:
        assert decode_write(receive(board, 3)) == pytest.approx(np.zeros(9))  # open -> 0 V everywhere
        sent = backend.write_pressures(pressure)
        assert sent[-1] == 4.0
        millivolts = decode_write(receive(board, 3))
        assert millivolts == pytest.approx(expected_mv(pressure))
        assert millivolts[7] == 4444 and millivolts[8] == 4444  # 4 bar on an ITV3050 = 4.444 V, never more
        backend.write_pressures(np.full(9, 1.5))
        raw = receive(board, 3)
        assert int.from_bytes(raw[0].data[0:2], "little") == 1667  # little-endian millivolts: 1.5 bar
    assert decode_write(receive(board, 3)) == pytest.approx(np.zeros(9))  # close vents
    assert_nothing_more(board)


def test_channel_mapping_follows_the_rig(board, channel):
    channels = [9, 8, 7, 6, 5, 4, 3, 2, 1]
    with backend_on(channel, channels=channels) as backend:
        receive(board, 3)
        pressure = np.linspace(0.5, 4.0, 9)
        backend.write_pressures(pressure)
        by_channel = decode_write(receive(board, 3))
        assert by_channel == pytest.approx(expected_mv(pressure)[::-1])
        assert backend.channel_labels()[0] == "CMD_CH9 in SRS_CMD_C (0x102)"


def test_a_burst_at_the_command_rate_arrives_complete_and_in_order(board, channel):
    rate_hz, writes = 200.0, 100
    with backend_on(channel) as backend:
        receive(board, 3)
        start = time.perf_counter()
        for k in range(writes):
            target = start + k / rate_hz
            while (left_s := target - time.perf_counter()) > 0.0:  # (read once: a busy host can pass it between)
                time.sleep(min(left_s, 0.002))
            backend.write_pressures(np.full(9, (k % 40) / 10.0))
        frames = receive(board, 3 * writes)
    for k in range(writes):
        assert decode_write(frames[3 * k:3 * k + 3]) == pytest.approx(expected_mv(np.full(9, (k % 40) / 10.0)))
    stamps = np.array([f.timestamp for f in frames[::3]])
    measured_hz = (writes - 1) / (stamps[-1] - stamps[0])
    assert 0.3 * rate_hz < measured_hz < 2.0 * rate_hz  # loose: the machine may be busy


def test_vent_sends_zero_frames_and_close_is_idempotent(board, channel):
    backend = backend_on(channel)
    backend.open()
    receive(board, 3)
    backend.write_pressures(np.full(9, 3.0))
    assert decode_write(receive(board, 3)) == pytest.approx(expected_mv(np.full(9, 3.0)))
    backend.vent()
    assert decode_write(receive(board, 3)) == pytest.approx(np.zeros(9))
    backend.close()
    assert decode_write(receive(board, 3)) == pytest.approx(np.zeros(9))
    backend.close()
    assert_nothing_more(board)
    with pytest.raises(HardwareError, match="not open"):
        backend.write_pressures(np.ones(9))


def test_send_failure_raises_hardware_error_and_the_backend_reopens(board, channel, monkeypatch):
    backend = backend_on(channel)
    backend.open()
    receive(board, 3)

    def dead_bus(message, timeout=None):
        raise can.CanOperationError("Transmit buffer full (bus-off?)")

    first_bus = backend._bus
    monkeypatch.setattr(first_bus, "send", dead_bus)
    with pytest.raises(HardwareError, match=r"0x100.*Transmit buffer full") as failure:
        backend.write_pressures(np.full(9, 2.0))
    assert isinstance(failure.value.__cause__, can.CanOperationError)
    with pytest.raises(HardwareError):  # close still tries to vent, which fails on the dead bus ...
        backend.close()
    assert not backend.is_open  # ... and releases it anyway
    assert_nothing_more(board)

    backend.open()  # recovery: a fresh bus
    assert backend._bus is not first_bus
    assert decode_write(receive(board, 3)) == pytest.approx(np.zeros(9))
    backend.write_pressures(np.full(9, 2.0))
    assert decode_write(receive(board, 3)) == pytest.approx(expected_mv(np.full(9, 2.0)))
    backend.close()


class RefusingBus(can.BusABC):
    """A bus whose controller is bus-off: every send raises CanOperationError."""

    def __init__(self, channel=None, **kwargs):
        self.channel_info = "refusing"
        self.shut_down = False
        super().__init__(channel=channel, **kwargs)

    def send(self, msg, timeout=None):
        raise can.CanOperationError("bus-off", error_code=0x40)

    def _recv_internal(self, timeout):
        return None, False

    def shutdown(self):
        self.shut_down = True
        super().shutdown()


def test_open_on_a_refusing_bus_fails_and_leaves_nothing_open(monkeypatch):
    created = []

    def make_bus(**kwargs):
        created.append(RefusingBus(**kwargs))
        return created[-1]

    monkeypatch.setattr(can, "Bus", make_bus)
    backend = CanBackend(options={"interface": "virtual", "channel": "unused"})
    with pytest.raises(HardwareError, match="bus-off") as failure:
        backend.open()
    assert isinstance(failure.value.__cause__, can.CanOperationError)
    assert not backend.is_open and backend._bus is None and created[0].shut_down


def monitor_frames(volts):
    values = {f"MON_CH{i + 1}": v for i, v in enumerate(volts)}
    frames = []
    for frame_id in MONITOR_IDS:
        message = DBC.get_message_by_frame_id(frame_id)
        data = message.encode({s.name: values[s.name] for s in message.signals})
        frames.append(can.Message(arbitration_id=frame_id, is_extended_id=False, data=data))
    return frames


def test_monitor_readback_becomes_measured_pressure(board, channel):
    with backend_on(channel) as backend:
        receive(board, 3)
        state = backend.read_state()
        assert state.measured_pressure_bar is None  # nothing heard yet
        volts = np.linspace(1.0, 5.0, 9)  # ITV monitor: 1 V = 0 bar, 5 V = 9 bar
        for frame in monitor_frames(volts):
            board.send(frame)
        board.send(can.Message(arbitration_id=0x7FF, is_extended_id=False, data=b"\xff" * 8))  # not ours
        board.send(can.Message(arbitration_id=MONITOR_IDS[0], is_extended_id=False, data=b"\x01"))  # malformed
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline:
            state = backend.read_state()
            if state.measured_pressure_bar is not None and not np.isnan(state.measured_pressure_bar).any() \
                    and state.details["readback_decode_errors"] == 1:
                break
        assert state.measured_pressure_bar == pytest.approx((volts - 1.0) / 4.0 * 9.0, abs=0.01)
        assert state.details["readback_decode_errors"] == 1
        assert max(state.details["readback_age_s"]) < 5.0


def test_readback_can_be_switched_off(board, channel):
    with backend_on(channel, readback=False) as backend:
        for frame in monitor_frames(np.full(9, 3.0)):
            board.send(frame)
        assert backend.read_state().measured_pressure_bar is None


OTHER_BOARD_DBC = """VERSION ""
NS_ :
BS_:
BU_: HOST DAC
BO_ {cmd_a} OTHER_DAC_1: 8 HOST
 SG_ OUT_3 : 7|12@0+ (0.002442,0) [0|10] "V" DAC
 SG_ OUT_2 : 11|12@0+ (0.002442,0) [0|10] "V" DAC
 SG_ OUT_1 : 31|12@0+ (0.002442,0) [0|10] "V" DAC
 SG_ OUT_0 : 35|12@0+ (0.002442,0) [0|10] "V" DAC
 SG_ ENABLE : 63|8@0+ (1,0) [0|255] "" DAC
BO_ {cmd_b} OTHER_DAC_2: 8 HOST
 SG_ OUT_4 : 7|12@0+ (0.002442,0) [0|10] "V" DAC
 SG_ OUT_5 : 11|12@0+ (0.002442,0) [0|10] "V" DAC
 SG_ OUT_6 : 31|12@0+ (0.002442,0) [0|10] "V" DAC
 SG_ OUT_7 : 35|12@0+ (0.002442,0) [0|10] "V" DAC
 SG_ OUT_8 : 55|12@0+ (0.002442,0) [0|10] "V" DAC
BA_DEF_ SG_ "GenSigStartValue" INT 0 255;
BA_DEF_DEF_ "GenSigStartValue" 0;
BA_ "GenSigStartValue" SG_ {cmd_a} ENABLE 165;
"""


def test_another_board_needs_only_another_dbc(board, channel, tmp_path):
    """Extended IDs, big-endian 12-bit counts, 0-based channel names and an enable byte: no code change."""
    path = tmp_path / "other_dac.dbc"
    path.write_text(OTHER_BOARD_DBC.format(cmd_a=0x80000010, cmd_b=0x80000011))  # 0x8... marks extended in DBC
    options = {"dbc_file": str(path), "channels": list(range(9)), "command_signal": "OUT_{channel}",
               "readback": False}
    with backend_on(channel, **options) as backend:
        receive(board, 2)
        backend.write_pressures(np.full(9, 4.0))
        frames = receive(board, 2)
    assert [(f.arbitration_id, f.is_extended_id) for f in frames] == [(0x10, True), (0x11, True)]
    other = cantools.database.load_file(str(path))
    decoded = {**other.decode_message(0x10, frames[0].data, force_extended_id=True),
               **other.decode_message(0x11, frames[1].data, force_extended_id=True)}
    assert [decoded[f"OUT_{i}"] for i in range(9)] == pytest.approx([4.0 * V_PER_BAR] * 9, abs=0.0025)
    assert decoded["ENABLE"] == 165  # a non-command signal goes out at its DBC start value


def test_python_can_config_file_opens_the_bus(board, channel, tmp_path):
    ini = tmp_path / "can.ini"
    ini.write_text(f"[srs]\ninterface = virtual\nchannel = {channel}\n")
    with CanBackend(options={"can_config_file": str(ini), "can_config_context": "srs"}) as backend:
        receive(board, 3)
        backend.write_pressures(np.full(9, 1.0))
        assert decode_write(receive(board, 3)) == pytest.approx(expected_mv(np.full(9, 1.0)))


@pytest.mark.parametrize(("options", "key"), [
    ({"chanels": [1]}, "chanels"),
    ({"channels": [1, 2, 3]}, "channels"),
    ({"channels": [1, 1, 2, 3, 4, 5, 6, 7, 8]}, "channels"),
    ({"bitrate": "fast"}, "bitrate"),
    ({"interface": ""}, "interface"),
    ({"dbc_file": "no_such_layout.dbc"}, "dbc_file"),
    ({"command_signal": "CMD_CH"}, "command_signal"),
    ({"command_signal": "MISSING_{channel}"}, "command_signal"),
    ({"monitor_signal": "MISSING_{channel}"}, "monitor_signal"),
    ({"monitor_range_v": [5.0, 1.0]}, "monitor_range_v"),
    ({"send_timeout_s": 0}, "send_timeout_s"),
    ({"readback": "yes"}, "readback"),
    ({"bus_options": ["fd"]}, "bus_options"),
    ({"can_config_file": "/no/such/can.ini"}, "can_config_file"),
    ({"board_timeout_s": 0}, "board_timeout_s"),
    ({"board_timeout_s": "50 ms"}, "board_timeout_s"),
    ({"alive_signal": ""}, "alive_signal"),
    ({"alive_signal": "NO_SUCH_COUNTER"}, "alive_signal"),
    ({"alive_signal": "CMD_CH1"}, "alive_signal"),
    ({"checksum_signal": "NO_SUCH_CRC"}, "checksum_signal"),
    ({"checksum_signal": "CMD_CH1"}, "checksum_signal"),
])
def test_invalid_options_fail_with_the_key_named(options, key):
    with pytest.raises(ConfigurationError, match=f"^can backend_options: {key} is "):
        create_backend("can", options={"interface": "virtual", "channel": "x", **options})


def test_a_dbc_in_the_wrong_unit_or_range_is_rejected(tmp_path):
    source = (config_dir() / "srs_dac.dbc").read_text()
    for bad, match in ((source.replace('[0|10] "V" SRS_DAC', '[0|10] "mV" SRS_DAC', 1), "unit"),
                       (source.replace('(0.001,0) [0|10] "V" SRS_DAC', '(0.001,0) [0|3] "V" SRS_DAC', 1), "range")):
        path = tmp_path / "bad.dbc"
        path.write_text(bad)
        with pytest.raises(ConfigurationError, match=f"dbc_file is .*{match}"):
            CanBackend(options={"interface": "virtual", "dbc_file": str(path)})


def test_unknown_interface_fails_at_open_with_the_key_named():
    backend = CanBackend(options={"interface": "no_such_adapter", "channel": "x"})
    with pytest.raises(ConfigurationError, match="interface is 'no_such_adapter'.*socketcan"):
        backend.open()
    assert not backend.is_open


def test_missing_interface_arguments_name_bus_options():
    backend = CanBackend(options={"interface": "socketcand", "channel": "can0"})  # needs host and port
    with pytest.raises(ConfigurationError, match="bus_options is .*host"):
        backend.open()
    assert not backend.is_open


def test_an_interface_without_its_driver_is_unavailable(monkeypatch):
    def missing_driver(**kwargs):
        raise can.CanInterfaceNotImplementedError("PCANBasic.dll not found")

    monkeypatch.setattr(can, "Bus", missing_driver)
    with pytest.raises(BackendUnavailableError, match="pcan.*PCANBasic"):
        CanBackend(options={"interface": "pcan", "channel": "PCAN_USBBUS1"}).open()


def test_the_shipped_can_rig_is_valid():
    rig = load_rig(config_dir() / "rigs" / "can.yaml")
    assert rig.backend == "can" and rig.robot.regulator.name == "ITV3050"
    backend = create_backend(rig.backend, rig.robot, rig.backend_options)
    assert backend.channels == tuple(range(1, 10)) and backend.dbc_path.name == "srs_dac.dbc"
    assert backend._bus_kwargs == {"interface": "socketcan", "channel": "can0", "bitrate": 500000}
    assert len(backend.channel_labels()) == default_robot().joint_count
    assert backend.board_timeout_s == 0.1 == backend.host_loss_timeout_s
    assert rig.command_rate_hz * backend.board_timeout_s >= 3  # the board tolerates a few late ticks


# -- alive counter, CRC, and the board's host-loss timeout (docs/can.md) -------------------------------------
def alive_and_crc_ok(frames) -> int:
    """The alive counter of one write's three frames (the same in all three), each frame's CRC checked."""
    counters = set()
    for frame in frames:
        data = bytes(frame.data)
        assert data[7] == crc8_sae_j1850(data[:7]), f"bad CRC in {frame}"
        counters.add(DBC.decode_message(frame.arbitration_id, data)["ALIVE"])
    assert len(counters) == 1, f"the three frames of one write carry different counters {counters}"
    return counters.pop()


def test_crc8_is_sae_j1850():
    assert crc8_sae_j1850(b"123456789") == 0x4B  # the catalogue check value of CRC-8/SAE-J1850
    assert crc8_sae_j1850(b"") == 0x00


def test_every_write_carries_the_next_alive_counter_in_all_three_frames(board, channel):
    """0 at open, +1 per write (vents too), wraps after 255; a second decoder on the bus sees the same."""
    spy = can.Bus(interface="virtual", channel=channel, receive_own_messages=False)
    try:
        with backend_on(channel) as backend:
            writes = 300
            for k in range(1, writes):
                if k % 7 == 0:
                    backend.vent()
                else:
                    backend.write_pressures(np.full(9, (k % 40) / 10.0))
            assert backend.read_state().details["alive_counter"] == (writes - 1) % 256
        frames = receive(board, 3 * (writes + 1))  # + the vent of close
        seen_by_spy = receive(spy, 3 * (writes + 1))
    finally:
        spy.shutdown()
    counters = [alive_and_crc_ok(frames[3 * k:3 * k + 3]) for k in range(writes + 1)]
    assert counters == [k % 256 for k in range(writes + 1)]
    assert counters[255:258] == [255, 0, 1]
    assert decode_write(frames[3 * 7:3 * 8]) == pytest.approx(np.zeros(9)) and counters[7] == 7  # a vent counts
    assert [alive_and_crc_ok(seen_by_spy[3 * k:3 * k + 3]) for k in range(writes + 1)] == counters


def test_a_reopened_backend_counts_from_zero_again(board, channel):
    backend = backend_on(channel)
    for _ in range(2):
        backend.open()
        backend.write_pressures(np.full(9, 1.0))
        backend.close()
        assert [alive_and_crc_ok(receive(board, 3)) for _ in range(3)] == [0, 1, 2]  # open, write, close


def write_at(backend, rate_hz: float, stop: threading.Event, pressure_bar: float) -> threading.Thread:
    """The host's command tick in a thread, until `stop` is set (then it just stops: no vent, as on SIGKILL)."""
    def loop():
        period_s, next_s = 1.0 / rate_hz, time.monotonic()
        while not stop.is_set():
            backend.write_pressures(np.full(9, pressure_bar))
            next_s += period_s
            time.sleep(max(next_s - time.monotonic(), 0.0))

    thread = threading.Thread(target=loop, daemon=True)
    thread.start()
    return thread


def wait_for(predicate, what: str, timeout_s: float = 5.0) -> None:
    end = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < end, f"timed out waiting for {what}"
        time.sleep(0.002)


def board_applies(board: ReferenceDacBoard, volts: float):
    return lambda: (s := board.snapshot()) and not s[0] and s[1] == pytest.approx([volts] * 9, abs=0.001)


def test_the_board_vents_by_itself_when_the_host_stops_writing(channel):
    """The host dies mid-command (no vent frames): the reference board vents after its timeout, not before."""
    timeout_s = 0.1
    board = ReferenceDacBoard(timeout_s=timeout_s)
    bus = can.Bus(interface="virtual", channel=channel, receive_own_messages=False)
    ticker = BoardTicker(board, bus=bus)
    backend = backend_on(channel, board_timeout_s=timeout_s)
    try:
        backend.open()
        stop = threading.Event()
        writer = write_at(backend, 100.0, stop, pressure_bar=3.0)
        wait_for(board_applies(board, 3.0 * V_PER_BAR), "the board to apply 3 bar")
        stop.set()  # the host dies: frames just stop
        writer.join(5.0)
        stopped_s = time.monotonic()
        wait_for(lambda: board.snapshot()[0], "the board to vent by itself")
        last_valid_s = board.oldest_valid_s()
        vented_at_s, reason = board.snapshot()[2][-1]
        assert reason.startswith("no valid command frame") and board.snapshot()[1] == [0.0] * 9
        assert last_valid_s <= stopped_s < vented_at_s
        # vents once its timeout has passed since the last valid frame; the margin is the test thread's polling
        assert timeout_s <= vented_at_s - last_valid_s < timeout_s + 0.25
        assert board.invalid == {}  # the host's counter and CRC were right all along
    finally:
        ticker.close()
        backend.close()
        bus.shutdown()


def test_a_frozen_counter_vents_the_board_although_frames_keep_coming(channel):
    """An adapter that keeps re-sending the last frames after the host died (cyclic transmit) cannot hold pressure."""
    board = ReferenceDacBoard(timeout_s=0.1)
    bus = can.Bus(interface="virtual", channel=channel, receive_own_messages=False)
    spy = can.Bus(interface="virtual", channel=channel, receive_own_messages=False)
    ticker = BoardTicker(board, bus=bus)
    backend = backend_on(channel)
    replays = []
    try:
        backend.open()
        stop = threading.Event()
        writer = write_at(backend, 100.0, stop, pressure_bar=2.0)
        wait_for(board_applies(board, 2.0 * V_PER_BAR), "the board to apply 2 bar")
        stop.set()
        writer.join(5.0)
        last_write = []
        while (message := spy.recv(timeout=0.05)) is not None:
            last_write = (last_write + [message])[-3:]
        assert decode_write(last_write) == pytest.approx(expected_mv(np.full(9, 2.0)))
        replays = [spy.send_periodic(frame, 0.01) for frame in last_write]  # cyclic transmit: same bytes and counter
        wait_for(lambda: board.snapshot()[0], "the board to vent on a frozen counter")
        assert board.snapshot()[2][-1][1].startswith("no valid command frame")
        assert board.invalid.get("repeated", 0) >= 3 and set(board.invalid) == {"repeated"}
    finally:
        for replay in replays:
            replay.stop()
        ticker.close()
        backend.close()
        spy.shutdown()
        bus.shutdown()


def test_a_counter_jump_vents_at_once_and_a_bad_crc_is_ignored(channel):
    board = ReferenceDacBoard(timeout_s=10.0)  # long: only the counter and CRC checks act here
    bus = can.Bus(interface="virtual", channel=channel, receive_own_messages=False)
    intruder = can.Bus(interface="virtual", channel=channel, receive_own_messages=False)
    ticker = BoardTicker(board, bus=bus)
    try:
        with backend_on(channel) as backend:
            for _ in range(3):
                backend.write_pressures(np.full(9, 1.0))
            wait_for(board_applies(board, V_PER_BAR), "the board to apply 1 bar")
            alive = backend.read_state().details["alive_counter"]
            full_v = np.full(9, 4.0 * V_PER_BAR)
            corrupted = bytearray(backend.encode_frames(full_v, alive + 1)[0][2])
            corrupted[7] ^= 0x01
            intruder.send(can.Message(arbitration_id=0x100, is_extended_id=False, data=bytes(corrupted)))
            wait_for(lambda: board.invalid.get("crc") == 1, "the corrupted frame to be rejected")
            assert board.snapshot()[1] == pytest.approx([V_PER_BAR] * 9, abs=0.001)  # not applied
            for frame_id, _, data in backend.encode_frames(full_v, alive + 10):  # valid CRC, counter jumps
                intruder.send(can.Message(arbitration_id=frame_id, is_extended_id=False, data=data))
            wait_for(lambda: board.snapshot()[0], "the board to vent on the jump")
            assert "jumped" in board.snapshot()[2][-1][1] and board.snapshot()[1] == [0.0] * 9
            for _ in range(4):  # the host goes on: one more jump (back), then it resynchronises
                backend.write_pressures(np.full(9, 1.0))
            wait_for(board_applies(board, V_PER_BAR), "the board to follow the host again")
    finally:
        ticker.close()
        intruder.shutdown()
        bus.shutdown()


AUTOSAR_STYLE_DBC = """VERSION ""
NS_ :
BS_:
BU_: HOST DAC
BO_ 528 DAC_1: 8 HOST
 SG_ OUT_0 : 7|12@0+ (0.002442,0) [0|10] "V" DAC
 SG_ OUT_1 : 11|12@0+ (0.002442,0) [0|10] "V" DAC
 SG_ OUT_2 : 31|12@0+ (0.002442,0) [0|10] "V" DAC
 SG_ OUT_3 : 35|12@0+ (0.002442,0) [0|10] "V" DAC
 SG_ CNT : 51|4@0+ (1,0) [0|14] "" DAC
 SG_ CS : 63|8@0+ (1,0) [0|255] "" DAC
BO_ 529 DAC_2: 8 HOST
 SG_ OUT_4 : 7|12@0+ (0.002442,0) [0|10] "V" DAC
 SG_ OUT_5 : 11|12@0+ (0.002442,0) [0|10] "V" DAC
 SG_ OUT_6 : 31|12@0+ (0.002442,0) [0|10] "V" DAC
 SG_ OUT_7 : 35|12@0+ (0.002442,0) [0|10] "V" DAC
 SG_ OUT_8 : 55|12@0+ (0.002442,0) [0|10] "V" DAC
"""


def test_renamed_counter_and_checksum_signals_follow_their_dbc(board, channel, tmp_path):
    """A 4-bit counter 0..14 (AUTOSAR style) and a big-endian CRC in the first frame only; the second has neither."""
    path = tmp_path / "autosar_dac.dbc"
    path.write_text(AUTOSAR_STYLE_DBC)
    options = {"dbc_file": str(path), "channels": list(range(9)), "command_signal": "OUT_{channel}",
               "readback": False, "alive_signal": "CNT", "checksum_signal": "CS"}
    other = cantools.database.load_file(str(path))
    with backend_on(channel, **options) as backend:
        for _ in range(20):
            backend.write_pressures(np.full(9, 1.0))
        frames = receive(board, 2 * 21)
    counters = []
    for k in range(0, len(frames), 2):
        first, second = bytes(frames[k].data), other.decode_message(0x211, frames[k + 1].data)
        assert first[7] == crc8_sae_j1850(first[:7])
        counters.append(other.decode_message(0x210, first)["CNT"])
        assert second["OUT_8"] == pytest.approx(V_PER_BAR if k else 0.0, abs=0.0025)  # k = 0: the vent of open
    assert counters == [k % 15 for k in range(21)]  # wraps after its DBC maximum 14

    path.write_text(AUTOSAR_STYLE_DBC.replace(" SG_ CS : 63|8@0+", " SG_ CS : 51|8@0+")  # straddles bytes 6 and 7
                    .replace(" SG_ CNT : 51|4@0+", " SG_ CNT : 59|4@0+"))
    with pytest.raises(ConfigurationError, match="checksum_signal is .*byte-aligned.*DAC_1"):
        backend_on(channel, **options)
    path.write_text(AUTOSAR_STYLE_DBC.replace(" SG_ CNT :", " SG_ COUNTER :"))
    with pytest.raises(ConfigurationError, match="alive_signal is 'CNT'.*none has it"):
        backend_on(channel, **options)


def test_a_dbc_without_counter_or_checksum_sends_neither(board, channel, tmp_path):
    path = tmp_path / "v1.dbc"
    source = (config_dir() / "srs_dac.dbc").read_text()
    path.write_text("\n".join(line for line in source.splitlines() if "ALIVE" not in line and "CRC8" not in line))
    with backend_on(channel, dbc_file=str(path)) as backend:
        backend.write_pressures(np.full(9, 2.0))
        receive(board, 3)
        frames = receive(board, 3)
        assert "alive_counter" not in backend.read_state().details
    assert decode_write(frames) == pytest.approx(expected_mv(np.full(9, 2.0)))
    assert all(bytes(f.data[6:]) == bytes(2) for f in frames)  # the spare bytes stay at 0


def test_gaps_longer_than_the_board_timeout_are_counted(board, channel):
    with backend_on(channel, board_timeout_s=0.3) as backend:
        backend.write_pressures(np.full(9, 1.0))
        assert backend.read_state().details["board_timeout_gaps"] == 0
        time.sleep(0.35)  # by its contract the board vents meanwhile
        backend.write_pressures(np.full(9, 1.0))
        assert backend.read_state().details["board_timeout_gaps"] == 1
        assert backend.host_loss_timeout_s == 0.3


# socketcan on vcan0: defined (and so collected) only where the kernel offers the interface, e.g. after
# `sudo modprobe vcan && sudo ip link add vcan0 type vcan && sudo ip link set up vcan0`.
if Path("/sys/class/net/vcan0").exists() and os.name == "posix":

    def test_socketcan_vcan0_carries_the_commands():
        with can.Bus(interface="socketcan", channel="vcan0") as vcan_board:
            with CanBackend(options={"interface": "socketcan", "channel": "vcan0"}) as backend:
                assert decode_write(receive(vcan_board, 3)) == pytest.approx(np.zeros(9))
                backend.write_pressures(np.full(9, 2.5))
                assert decode_write(receive(vcan_board, 3)) == pytest.approx(expected_mv(np.full(9, 2.5)))
            assert decode_write(receive(vcan_board, 3)) == pytest.approx(np.zeros(9))


# -- end to end: the hardware node (its own process) on a CAN bus that fails and comes back -----------------
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
    """A rig file for the hardware node on python-can's socketcand interface, connected to FakeSocketcand."""
    extra = "".join(f"    {key}: {value}\n" for key, value in options.items())
    path = tmp_path / "socketcand.yaml"
    path.write_text(textwrap.dedent(f"""\
        rig:
          name: socketcand_dac
          backend: can
          regulator_model: ITV3050
          command_rate_hz: {rate_hz}
          setpoint_timeout_s: {setpoint_timeout_s}
          backend_options:
            interface: socketcand
            channel: can0
            bus_options: {{host: 127.0.0.1, port: {port}}}
        """) + extra)
    return path


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
        assert ros_client.trigger("/hardware_node/arm").success  # real regulators: the operator's go
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
        assert [frame_id for frame_id, _ in daemon.frames[-3:]] == COMMAND_IDS
        assert daemon.last_write_mv() == pytest.approx(np.full(9, 2222.0))  # it died commanding 2 bar: no vent sent
        assert timeout_s <= vented_at_s - board.oldest_valid_s() < timeout_s + 0.25
        assert vented_at_s - killed_s < timeout_s + 0.25
        assert board.invalid == {}  # across processes: every frame's counter and CRC in sequence
    finally:
        daemon.close()
        ticker.close()

