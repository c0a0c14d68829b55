"""NI-DAQmx backend: against a stand-in `nidaqmx` (records every write), and the real package without its driver."""

import importlib
import sys
from pathlib import Path

import numpy as np
import pytest

from srs_ros.backends import create_backend
from srs_ros.backends.daq_backend import DaqBackend, expand_physical_channels
from srs_ros.core.errors import BackendUnavailableError, ConfigurationError, HardwareError
from srs_ros.core.rig import load_rig
from srs_ros.core.robot import config_dir

FAKE_DIR = Path(__file__).parent / "fake_nidaqmx"


def _nidaqmx_modules() -> dict:
    return {name: mod for name, mod in sys.modules.items() if name == "nidaqmx" or name.startswith("nidaqmx.")}


@pytest.fixture
def fake_nidaqmx(monkeypatch):
    """The stand-in package first on sys.path for this test only; the real one is restored afterwards."""
    saved = _nidaqmx_modules()
    for name in saved:
        del sys.modules[name]
    monkeypatch.syspath_prepend(str(FAKE_DIR))
    fake = importlib.import_module("nidaqmx")
    assert Path(fake.__file__).is_relative_to(FAKE_DIR)
    fake.reset()
    yield fake
    for name in _nidaqmx_modules():
        del sys.modules[name]
    sys.modules.update(saved)


@pytest.fixture
def real_nidaqmx():
    """NI's own package (installed here, its driver is not)."""
    saved = _nidaqmx_modules()
    for name in saved:
        del sys.modules[name]
    real = importlib.import_module("nidaqmx")
    assert not Path(real.__file__).is_relative_to(FAKE_DIR)
    yield real
    sys.modules.update(saved)


def test_channels_are_expanded_in_joint_order():
    assert expand_physical_channels("Dev1/ao0:8") == [f"Dev1/ao{i}" for i in range(9)]
    assert expand_physical_channels("Dev1/ao3:0, Dev2/ao0:4") == (
        ["Dev1/ao3", "Dev1/ao2", "Dev1/ao1", "Dev1/ao0"] + [f"Dev2/ao{i}" for i in range(5)])
    assert expand_physical_channels(["Dev1/ao0:7", "Dev2/ao1"])[-1] == "Dev2/ao1"


def test_open_adds_nine_0_to_10_v_channels_and_writes_zero(fake_nidaqmx):
    backend = DaqBackend(options={"physical_channels": "Dev1/ao0:8"})
    backend.open()
    (task,) = fake_nidaqmx.RECORD["tasks"]
    assert task.ao_channels.channel_names == [f"Dev1/ao{i}" for i in range(9)]
    assert {(c.ao_min, c.ao_max) for c in task.ao_channels.channels} == {(0.0, 10.0)}
    assert task.writes == [[0.0] * 9]
    backend.close()


def test_writes_are_one_sample_per_channel_in_volts(fake_nidaqmx):
    channels = ["Dev2/ao3"] + [f"Dev1/ao{i}" for i in range(8)]  # joint 1 wired to the second card
    with DaqBackend(options={"physical_channels": channels}) as backend:
        task = fake_nidaqmx.RECORD["tasks"][0]
        assert task.ao_channels.channel_names == channels
        backend.write_pressures([4.0, 0.0, 1.5, 2.0, 3.0, 9.0, -1.0, 0.9, 3.6])
        assert task.writes[-1] == pytest.approx(
            [4.444444, 0.0, 1.666667, 2.222222, 3.333333, 4.444444, 0.0, 1.0, 4.0], abs=1e-6)
        assert backend.channel_labels()[0] == "Dev2/ao3"
        backend.vent()
        assert task.writes[-1] == [0.0] * 9
        backend.write_pressures(np.full(9, 2.0))
    assert task.writes[-1] == [0.0] * 9 and task.closed  # close: zero, then release
    assert len(task.writes) == 5


def test_the_regulator_model_of_the_rig_sets_the_volts(fake_nidaqmx, tmp_path):
    rig_file = tmp_path / "itv3030.yaml"
    rig_file.write_text((config_dir() / "rigs" / "daq.yaml").read_text().replace("ITV3050", "ITV3030"))
    rig = load_rig(rig_file)
    with create_backend(rig.backend, rig.robot, rig.backend_options) as backend:
        backend.write_pressures(np.full(9, 4.0))
        assert fake_nidaqmx.RECORD["tasks"][0].writes[-1] == pytest.approx([8.0] * 9)  # 5 bar full scale


def test_a_failed_write_zeroes_the_outputs_then_raises(fake_nidaqmx):
    with DaqBackend() as backend:
        task = fake_nidaqmx.RECORD["tasks"][0]
        backend.write_pressures(np.full(9, 3.0))
        fake_nidaqmx.BEHAVIOUR.fail_writes = 1
        with pytest.raises(HardwareError, match="underflow.*outputs set to 0 V") as failure:
            backend.write_pressures(np.full(9, 3.5))
        assert isinstance(failure.value.__cause__, fake_nidaqmx.errors.DaqError)
        assert task.writes[-1] == [0.0] * 9
        backend.write_pressures(np.full(9, 1.0))  # the card works again: so does the backend
        assert task.writes[-1] == pytest.approx([10 / 9] * 9)


def test_a_dead_card_says_so_and_close_still_releases_the_task(fake_nidaqmx):
    backend = DaqBackend()
    backend.open()
    task = fake_nidaqmx.RECORD["tasks"][0]
    fake_nidaqmx.BEHAVIOUR.fail_all_writes = True
    with pytest.raises(HardwareError, match="could NOT set the outputs to 0 V"):
        backend.write_pressures(np.full(9, 2.0))
    with pytest.raises(HardwareError):
        backend.close()  # the vent fails too ...
    assert task.closed and not backend.is_open  # ... but the task is released


def test_ctrl_c_during_a_write_zeroes_and_propagates(fake_nidaqmx):
    with DaqBackend() as backend:
        task = fake_nidaqmx.RECORD["tasks"][0]
        backend.write_pressures(np.full(9, 2.0))
        fake_nidaqmx.BEHAVIOUR.raise_on_write = KeyboardInterrupt()
        with pytest.raises(KeyboardInterrupt):
            backend.write_pressures(np.full(9, 3.0))
        assert task.writes[-1] == [0.0] * 9


def test_an_exception_inside_the_with_block_vents_and_closes(fake_nidaqmx):
    with pytest.raises(RuntimeError, match="planner crashed"):
        with DaqBackend() as backend:
            backend.write_pressures(np.full(9, 4.0))
            raise RuntimeError("planner crashed")
    task = fake_nidaqmx.RECORD["tasks"][0]
    assert task.writes[-1] == [0.0] * 9 and task.closed


def test_a_missing_device_fails_open_with_nothing_left_open(fake_nidaqmx):
    backend = DaqBackend(options={"physical_channels": "Dev7/ao0:8"})
    with pytest.raises(HardwareError, match="Dev7/ao0.*physical_channels.*NI MAX"):
        backend.open()
    assert not backend.is_open and fake_nidaqmx.RECORD["tasks"][0].closed
    backend = DaqBackend(options={"physical_channels": "Dev2/ao0:8"})  # Dev2 has only 4 outputs
    with pytest.raises(HardwareError, match="Dev2/ao4"):
        backend.open()
    assert fake_nidaqmx.RECORD["tasks"][1].closed and fake_nidaqmx.RECORD["tasks"][1].writes == []


def test_reopen_after_close_uses_a_fresh_task(fake_nidaqmx):
    backend = DaqBackend()
    for _ in range(2):
        backend.open()
        backend.write_pressures(np.full(9, 1.0))
        backend.close()
    first, second = fake_nidaqmx.RECORD["tasks"]
    assert first.closed and second.closed and second.writes[0] == [0.0] * 9


def test_driver_missing_in_the_fake_is_backend_unavailable(fake_nidaqmx):
    fake_nidaqmx.BEHAVIOUR.driver_installed = False
    backend = DaqBackend()
    with pytest.raises(BackendUnavailableError, match="Could not find an installation of NI-DAQmx.*installdriver"):
        backend.open()
    assert not backend.is_open and fake_nidaqmx.RECORD["tasks"] == []


def test_driver_missing_with_the_real_nidaqmx_package(real_nidaqmx):
    backend = create_backend("daq", options={"physical_channels": "Dev1/ao0:8"})
    with pytest.raises(BackendUnavailableError) as failure:
        backend.open()
    message = str(failure.value)
    assert "NI-DAQmx" in message and "python -m nidaqmx installdriver" in message
    assert isinstance(failure.value.__cause__, real_nidaqmx.errors.DaqNotFoundError)
    assert not backend.is_open and backend._task is None
    backend.close()  # nothing open: a no-op, no error


@pytest.mark.parametrize(("options", "key"), [
    ({"physical_channels": "Dev1/ao0:7"}, "physical_channels"),
    ({"physical_channels": ["Dev1/ao0"] * 9}, "physical_channels"),
    ({"physical_channels": 42}, "physical_channels"),
    ({"physical_channels": "Dev1/ao0:7,"}, "physical_channels"),
    ({"physical_channel": "Dev1/ao0:8"}, "physical_channel"),
])
def test_invalid_options_fail_with_the_key_named(options, key):
    with pytest.raises(ConfigurationError, match=f"'{key}'"):
        create_backend("daq", options=options)


def test_the_shipped_daq_rig_is_valid():
    rig = load_rig(config_dir() / "rigs" / "daq.yaml")
    backend = create_backend(rig.backend, rig.robot, rig.backend_options)
    assert rig.backend == "daq" and backend.physical_channels == [f"Dev1/ao{i}" for i in range(9)]
