"""The CAN backend's alive counter and CRC, and the reference DAC board venting on host loss (docs/can.md)."""

import os
import threading
import time
from pathlib import Path

import can
import cantools
import numpy as np
import pytest
from backends.can_bus import (
    DBC,
    V_PER_BAR,
    backend_on,
    board_applies,
    decode_write,
    expected_mv,
    receive,
    wait_for,
)
from backends.reference_dac_board import BoardTicker, ReferenceDacBoard

from srs_ros.backends.can_backend import CanBackend, crc8_sae_j1850
from srs_ros.core.errors import ConfigurationError
from srs_ros.core.robot import config_dir


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
