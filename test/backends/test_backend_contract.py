"""The contract every backend must pass (python-can style): add a backend to BACKEND_FACTORIES to run it here.

A factory takes the robot description and returns an unopened backend whose commands reach something
the test can run without hardware (a simulation, a virtual bus, a stand-in driver).
"""

import contextlib
import sys
import uuid
from pathlib import Path

import numpy as np
import pytest

from srs_ros.backends import ActuatorBackend, ActuatorState, create_backend
from srs_ros.backends.daq_backend import DaqBackend
from srs_ros.core.errors import HardwareError, InvalidInputError
from srs_ros.core.robot import default_robot

FAKE_NIDAQMX_DIR = Path(__file__).parent / "fake_nidaqmx"


@contextlib.contextmanager
def _fake_nidaqmx_imported():
    """The stand-in `nidaqmx` (fake_nidaqmx/) in sys.modules for this block only; the real one is restored."""
    def ours():
        return [name for name in sys.modules if name == "nidaqmx" or name.startswith("nidaqmx.")]

    saved = {name: sys.modules.pop(name) for name in ours()}
    sys.path.insert(0, str(FAKE_NIDAQMX_DIR))
    try:
        import nidaqmx

        nidaqmx.reset()
        yield
    finally:
        sys.path.remove(str(FAKE_NIDAQMX_DIR))
        for name in ours():
            del sys.modules[name]
        sys.modules.update(saved)


class _DaqOnFakeDriver(DaqBackend):
    """The real DaqBackend; only the `import nidaqmx` of open() finds the stand-in."""

    def _open(self):
        with _fake_nidaqmx_imported():
            super()._open()


BACKEND_FACTORIES = {
    "mock": lambda robot: create_backend("mock", robot, {"transport_delay_s": 0.0}),
    "can": lambda robot: create_backend("can", robot, {"interface": "virtual",
                                                       "channel": f"srs_contract_{uuid.uuid4().hex[:8]}"}),
    "daq": lambda robot: _DaqOnFakeDriver(robot, {"physical_channels": "Dev1/ao0:8"}),
}


@pytest.fixture(params=sorted(BACKEND_FACTORIES))
def backend(request):
    backend = BACKEND_FACTORIES[request.param](default_robot())
    yield backend
    backend.close()


def test_is_an_actuator_backend_with_a_name(backend):
    assert isinstance(backend, ActuatorBackend)
    assert backend.name in BACKEND_FACTORIES


def test_opens_vented(backend):
    backend.open()
    backend.open()  # idempotent
    state = backend.read_state()
    assert isinstance(state, ActuatorState)
    assert state.commanded_pressure_bar == pytest.approx(np.zeros(9))
    assert state.command_v == pytest.approx(np.zeros(9))


def test_writes_clamped_pressures_and_their_volts(backend):
    backend.open()
    sent = backend.write_pressures([4.0, 2.0, 9.0, -1.0, 0.0, 1.0, 3.0, 0.5, 4.0])
    assert sent == pytest.approx([4.0, 2.0, 4.0, 0.0, 0.0, 1.0, 3.0, 0.5, 4.0])
    state = backend.read_state()
    assert state.commanded_pressure_bar == pytest.approx(sent)
    assert state.command_v == pytest.approx(10.0 * sent / 9.0)  # ITV3050: 4 bar -> 4.444 V
    for measured in (state.measured_pressure_bar, state.measured_length_m):
        assert measured is None or np.shape(measured) == (9,)


@pytest.mark.parametrize("bad", [np.full(9, np.nan), np.r_[np.inf, np.zeros(8)], np.zeros(8)])
def test_bad_commands_raise_and_change_nothing(backend, bad):
    backend.open()
    backend.write_pressures(np.full(9, 2.0))
    with pytest.raises(InvalidInputError):
        backend.write_pressures(bad)
    assert backend.read_state().commanded_pressure_bar == pytest.approx(np.full(9, 2.0))


def test_vent_commands_zero(backend):
    backend.open()
    backend.write_pressures(np.full(9, 3.0))
    backend.vent()
    state = backend.read_state()
    assert state.commanded_pressure_bar == pytest.approx(np.zeros(9)) and state.command_v == pytest.approx(np.zeros(9))


def test_close_vents_is_idempotent_and_writes_after_it_fail(backend):
    backend.open()
    backend.write_pressures(np.full(9, 3.0))
    backend.close()
    backend.close()
    assert not backend.is_open
    assert backend.read_state().commanded_pressure_bar == pytest.approx(np.zeros(9))
    with pytest.raises(HardwareError, match="not open"):
        backend.write_pressures(np.ones(9))


def test_reopens_after_close(backend):
    with backend:
        backend.write_pressures(np.ones(9))
    with backend:
        backend.write_pressures(np.full(9, 2.0))
        assert backend.read_state().commanded_pressure_bar == pytest.approx(np.full(9, 2.0))
