"""CAN backend on real python-can buses: a second `virtual` bus on the same channel plays the DAC board."""

import time

import can
import cantools
import numpy as np
import pytest
from backends.can_bus import (
    DBC,
    MONITOR_IDS,
    V_PER_BAR,
    assert_nothing_more,
    backend_on,
    decode_write,
    expected_mv,
    receive,
)

from srs_ros.backends import create_backend
from srs_ros.backends.can_backend import CanBackend
from srs_ros.core.errors import BackendUnavailableError, ConfigurationError, HardwareError
from srs_ros.core.rig import load_rig
from srs_ros.core.robot import config_dir, default_robot


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
