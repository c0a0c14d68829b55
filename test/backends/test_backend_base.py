"""The backend contract's final methods: every command goes through the clamp, close vents."""

import numpy as np
import pytest

from srs_ros.backends import create_backend
from srs_ros.backends.base import ActuatorBackend
from srs_ros.core.errors import ConfigurationError, HardwareError, InvalidInputError


class RecordingBackend(ActuatorBackend):
    """The smallest backend: records what reaches `_write`."""

    name = "recording"

    def _open(self):
        self.sent = []

    def _write(self, pressure_bar, command_v):
        self.sent.append((pressure_bar.copy(), command_v.copy()))

    def _close(self):
        self.closed = True


def test_commands_are_clamped_before_the_backend_sees_them():
    with RecordingBackend() as backend:
        sent = backend.write_pressures(np.r_[-1.0, 2.0, 9.0, np.zeros(6)])
        assert sent[:3] == pytest.approx([0.0, 2.0, 4.0])
        pressure, volts = backend.sent[-1]
        assert pressure[:3] == pytest.approx([0.0, 2.0, 4.0])
        assert volts[:3] == pytest.approx([0.0, 20 / 9, 40 / 9])
        state = backend.read_state()
        assert state.commanded_pressure_bar[:3] == pytest.approx([0.0, 2.0, 4.0])
    assert backend.closed and backend.sent[-1][0] == pytest.approx(np.zeros(9))  # vented on close


def test_nan_and_wrong_size_never_reach_the_backend():
    with RecordingBackend() as backend:
        for bad in (np.full(9, np.nan), np.zeros(3)):
            with pytest.raises(InvalidInputError):
                backend.write_pressures(bad)
        assert backend.sent == []


def test_write_before_open_is_a_hardware_error():
    with pytest.raises(HardwareError, match="not open"):
        RecordingBackend().write_pressures(np.zeros(9))


def test_unknown_backend_lists_the_known_ones():
    known = r"\['can', 'daq', 'mock', 'sim'\]"
    with pytest.raises(ConfigurationError, match=r"unknown backend 'pcan'; expected one of " + known):
        create_backend("pcan")


def test_a_batch_is_not_a_command():
    with RecordingBackend() as backend:
        with pytest.raises(InvalidInputError, match=r"expected one command of shape \(9,\)"):
            backend.write_pressures(np.zeros((2, 9)))
        assert backend.sent == []
