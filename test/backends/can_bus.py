"""The DAC board's side of a python-can bus for the CAN backend's tests: the DBC, frame decoding, waiting."""

import time
from pathlib import Path

import cantools
import numpy as np
import pytest
import yaml
from backends.reference_dac_board import ReferenceDacBoard

from srs_ros.backends.can_backend import CanBackend
from srs_ros.core.robot import config_dir

DBC = cantools.database.load_file(str(config_dir() / "srs_dac.dbc"))
COMMAND_IDS = [0x100, 0x101, 0x102]
MONITOR_IDS = [0x180, 0x181, 0x182]
V_PER_BAR = 10.0 / 9.0  # ITV3050


def expected_mv(pressure_bar):
    return np.round(np.clip(pressure_bar, 0.0, 4.0) * V_PER_BAR * 1000.0)


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


def wait_for(predicate, what: str, timeout_s: float = 5.0) -> None:
    end = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < end, f"timed out waiting for {what}"
        time.sleep(0.002)


def board_applies(board: ReferenceDacBoard, volts: float):
    return lambda: (s := board.snapshot()) and not s[0] and s[1] == pytest.approx([volts] * 9, abs=0.001)


def write_can_rig(path: Path, name: str, backend_options: dict, rate_hz: float, setpoint_timeout_s: float) -> Path:
    """A rig file (config/rigs' schema) for the CAN backend with ITV3050 regulators."""
    rig = {"name": name, "backend": "can", "regulator_model": "ITV3050", "command_rate_hz": rate_hz,
           "setpoint_timeout_s": setpoint_timeout_s, "backend_options": backend_options}
    path.write_text(yaml.safe_dump({"rig": rig}, sort_keys=False))
    return path
