"""NI-DAQmx backend: against a stand-in `nidaqmx` (records every write), and the real package without its driver."""

import importlib
import inspect
import os
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from srs_ros.backends import create_backend
from srs_ros.backends.daq_backend import DaqBackend, expand_physical_channels
from srs_ros.core.actuation.timing import CommandTiming
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
    with pytest.raises(ConfigurationError, match=f"^daq backend_options: {key} is "):
        create_backend("daq", options=options)


def test_the_shipped_daq_rig_is_valid():
    rig = load_rig(config_dir() / "rigs" / "daq.yaml")
    backend = create_backend(rig.backend, rig.robot, rig.backend_options)
    assert rig.backend == "daq" and backend.physical_channels == [f"Dev1/ao{i}" for i in range(9)]
    assert backend.watchdog_timeout_s == 0.1 and backend.require_watchdog is False
    assert rig.command_rate_hz * backend.watchdog_timeout_s >= 3  # a few late ticks do not expire it


# -- the NI-DAQmx watchdog timer: the device vents by itself when the host stops writing (docs/daq.md) ---------
def nine_outputs(fake, device="Dev1"):
    terminals = fake.terminals(device)
    return [terminals[f"{device}/ao{i}"] for i in range(9)]


def test_open_arms_a_watchdog_with_0_v_on_every_channel_and_every_write_resets_it(fake_nidaqmx):
    backend = DaqBackend(options={"watchdog_timeout_s": 0.25})
    backend.open()
    (watchdog,) = fake_nidaqmx.RECORD["watchdogs"]
    assert watchdog.running and watchdog.timeout == 0.25 and watchdog._device_name == "Dev1"
    states = watchdog.expiration_states
    assert sorted(states) == sorted(f"Dev1/ao{i}" for i in range(9))
    assert {(s.ao_state, s.ao_output_type.name) for s in states.values()} == {(0.0, "VOLTAGE")}
    assert backend.host_loss_timeout_s == 0.25 and backend.read_state().details["watchdog"].startswith("armed")
    resets = watchdog.resets
    for k in range(5):
        fake_nidaqmx.BEHAVIOUR.clock.advance(0.2)  # a write every 0.2 s keeps a 0.25 s watchdog from expiring
        backend.write_pressures(np.full(9, 3.0)) if k % 2 else backend.vent()
    assert watchdog.resets == resets + 5 and not watchdog.expired
    backend.close()
    assert watchdog.closed and not watchdog.running and backend.host_loss_timeout_s is None


def test_a_stalled_host_lets_the_device_vent_and_the_next_write_says_so(fake_nidaqmx):
    backend = DaqBackend()  # default watchdog_timeout_s 0.1
    backend.open()
    backend.write_pressures(np.full(9, 3.0))
    assert nine_outputs(fake_nidaqmx) == pytest.approx([10 / 3] * 9)
    fake_nidaqmx.BEHAVIOUR.clock.advance(0.09)
    backend.write_pressures(np.full(9, 3.0))  # just in time
    fake_nidaqmx.BEHAVIOUR.clock.advance(0.11)  # the process stalls (or dies): no write, no reset
    watchdog = fake_nidaqmx.RECORD["watchdogs"][0]
    assert watchdog.expired and nine_outputs(fake_nidaqmx) == [0.0] * 9  # the device vented by itself
    with pytest.raises(HardwareError, match=r"watchdog of Dev1 EXPIRED.*0\.1 s.*0 V by itself.*re-open") as failure:
        backend.write_pressures(np.full(9, 3.5))
    assert isinstance(failure.value.__cause__, fake_nidaqmx.errors.DaqError)
    with pytest.raises(HardwareError, match="EXPIRED"):  # locked until re-opened, without asking the driver
        backend.write_pressures(np.full(9, 1.0))
    backend.vent()  # the outputs already hold 0 V: a vent is done, not an error
    assert backend.read_state().details["watchdog"] == "EXPIRED"
    backend.close()  # clears the expiration, releases both tasks
    assert not fake_nidaqmx.BEHAVIOUR.devices["Dev1"].expired and watchdog.closed

    backend.open()  # recovery without touching the device by hand
    backend.write_pressures(np.full(9, 1.0))
    assert nine_outputs(fake_nidaqmx) == pytest.approx([10 / 9] * 9)
    backend.close()


def test_an_expiry_found_by_the_vent_of_close_is_not_an_error(fake_nidaqmx, caplog):
    backend = DaqBackend()
    backend.open()
    backend.write_pressures(np.full(9, 2.0))
    fake_nidaqmx.BEHAVIOUR.clock.advance(1.0)
    with caplog.at_level("WARNING", logger="srs_ros.backends.daq_backend"):
        backend.close()
    assert "EXPIRED" in caplog.text and not backend.is_open
    assert nine_outputs(fake_nidaqmx) == [0.0] * 9 and not fake_nidaqmx.BEHAVIOUR.devices["Dev1"].expired


@pytest.mark.parametrize(("device", "what"), [("Dev4", "watchdog timer is not supported"),
                                              ("Dev3", "not supported by the device")])
def test_a_device_without_an_ao_watchdog_warns_by_default(fake_nidaqmx, caplog, device, what):
    channels = f"{device}/ao0:3, Dev1/ao0:4"  # joints 1-4 on the device in question, 5-9 on Dev1
    with caplog.at_level("WARNING", logger="srs_ros.backends.daq_backend"):
        backend = DaqBackend(options={"physical_channels": channels})
        backend.open()
    warning = caplog.text
    assert f"no NI-DAQmx analog-output watchdog on {device} (" in warning and what in warning
    assert f"{device}/ao0..{device}/ao3" in warning and "HOLD their last voltage" in warning
    assert "dump valve" in warning and "require_watchdog: true" in warning
    assert "Dev1 (" not in warning  # Dev1 has its watchdog
    assert [w._device_name for w in fake_nidaqmx.RECORD["watchdogs"] if not w.closed] == ["Dev1"]
    assert backend.host_loss_timeout_s is None and backend.read_state().details["watchdog"] == f"MISSING on {device}"
    backend.write_pressures(np.full(9, 2.0))  # it runs, unprotected on that device
    backend.close()


def test_the_watchdogs_that_run_beside_a_device_without_one_are_checked_against_the_command_period(fake_nidaqmx):
    """Dev1's watchdog at 0.01 s beside Dev4 (none): the rig was taken with a warning, and the first command 0.1 s
    later failed as 'the process stalled' (a helper's review); the same timeout on Dev1 alone was refused."""
    backend = DaqBackend(options={"physical_channels": "Dev1/ao0:7, Dev4/ao0", "watchdog_timeout_s": 0.01})
    backend.open()
    try:
        assert backend.host_loss_timeout_s is None and backend.partial_host_loss_timeout_s == 0.01
        timing = CommandTiming(command_rate_hz=10.0, setpoint_timeout_s=0.2)
        with pytest.raises(ConfigurationError, match="vents after 0.01 s without a command, less than three"):
            timing.check_hardware("daq", backend.host_loss_timeout_s, True, backend.silence_vent_s)
        assert timing.stall_gap_s(backend.silence_vent_s) == 0.01
        slow_enough = CommandTiming(command_rate_hz=400.0, setpoint_timeout_s=0.2)
        assert "keeps its last command" in slow_enough.check_hardware("daq", None, True, backend.silence_vent_s)
    finally:
        backend.close()
    assert backend.silence_vent_s is None  # closed: nothing runs


@pytest.mark.parametrize("device", ["Dev3", "Dev4"])
def test_require_watchdog_refuses_such_a_device_and_leaves_nothing_open(fake_nidaqmx, device):
    channels = f"Dev1/ao0:4, {device}/ao0:3"
    backend = DaqBackend(options={"physical_channels": channels, "require_watchdog": True})
    with pytest.raises(HardwareError, match=f"require_watchdog: true.*no NI-DAQmx analog-output watchdog on {device}"):
        backend.open()
    assert not backend.is_open and fake_nidaqmx.RECORD["tasks"] == []  # refused before any output was touched
    assert all(w.closed for w in fake_nidaqmx.RECORD["watchdogs"])


def test_modules_in_a_compactdaq_chassis_use_the_chassis_watchdog(fake_nidaqmx):
    channels = "cDAQ1Mod1/ao0:3, cDAQ1Mod2/ao0:3, cDAQ1Mod3/ao0"
    with DaqBackend(options={"physical_channels": channels, "require_watchdog": True}) as backend:
        (watchdog,) = fake_nidaqmx.RECORD["watchdogs"]
        assert watchdog._device_name == "cDAQ1" and len(watchdog.expiration_states) == 9
        backend.write_pressures(np.full(9, 2.0))
        fake_nidaqmx.BEHAVIOUR.clock.advance(0.5)
        outputs = [v for m in (1, 2, 3) for v in fake_nidaqmx.terminals(f"cDAQ1Mod{m}").values()]
        assert outputs == [0.0] * 9 and watchdog.expired  # one chassis watchdog vents all three modules
        with pytest.raises(HardwareError, match="watchdog of cDAQ1 EXPIRED"):
            backend.write_pressures(np.full(9, 2.0))


def test_the_chassis_watchdog_cannot_start_once_an_output_task_runs(fake_nidaqmx):
    """Why open() starts the watchdog before the AO task: the fake refuses the other order, as a cDAQ chassis does."""
    task = fake_nidaqmx.Task()
    task.ao_channels.add_ao_voltage_chan("cDAQ1Mod1/ao0", min_val=0.0, max_val=10.0)
    task.write([0.0])
    watchdog = fake_nidaqmx.system.WatchdogTask("cDAQ1", timeout=0.1)
    with pytest.raises(fake_nidaqmx.errors.DaqError) as failure:
        watchdog.start()
    assert failure.value.error_type.name == "CANT_RESERVE_WATCHDOG_TASK_WHILE_OTHER_TASKS_RESERVED"


def test_a_zero_timeout_disables_the_watchdog_with_a_warning(fake_nidaqmx, caplog):
    with caplog.at_level("WARNING", logger="srs_ros.backends.daq_backend"):
        with DaqBackend(options={"watchdog_timeout_s": 0}) as backend:
            backend.write_pressures(np.full(9, 1.0))
            assert backend.read_state().details["watchdog"].startswith("disabled")
    assert fake_nidaqmx.RECORD["watchdogs"] == [] and "watchdog is disabled" in caplog.text
    assert "HOLD their last voltage" in caplog.text


@pytest.mark.parametrize(("options", "key"), [
    ({"watchdog_timeout_s": -1}, "watchdog_timeout_s"),
    ({"watchdog_timeout_s": 0.001}, "watchdog_timeout_s"),
    ({"watchdog_timeout_s": 60}, "watchdog_timeout_s"),
    ({"watchdog_timeout_s": "100 ms"}, "watchdog_timeout_s"),
    ({"watchdog_timeout_s": True}, "watchdog_timeout_s"),
    ({"require_watchdog": "yes"}, "require_watchdog"),
    ({"require_watchdog": True, "watchdog_timeout_s": 0}, "watchdog_timeout_s"),
])
def test_invalid_watchdog_options_fail_with_the_key_named(options, key):
    with pytest.raises(ConfigurationError, match=f"^daq backend_options: {key} is "):
        create_backend("daq", options=options)


def _signature(obj) -> list[str]:
    return list(inspect.signature(obj).parameters)


def test_the_fake_has_the_real_packages_names_signatures_and_error_codes(fake_nidaqmx):
    """The stand-in imitates nidaqmx as installed: same call shapes for what the backend uses, same error codes."""
    fake = {name: sys.modules[name] for name in list(sys.modules) if name.split(".")[0] == "nidaqmx"}
    for name in fake:
        del sys.modules[name]
    sys.path.remove(str(FAKE_DIR))
    try:
        real = importlib.import_module("nidaqmx")
        for module in ("system", "constants", "error_codes", "errors", "types"):
            importlib.import_module(f"nidaqmx.{module}")
        assert not Path(real.__file__).is_relative_to(FAKE_DIR)
        real_watchdog, fake_watchdog = real.system.WatchdogTask, fake["nidaqmx.system"].WatchdogTask
        assert _signature(fake_watchdog.__init__) == _signature(real_watchdog.__init__)
        for method in ("cfg_watchdog_ao_expir_states", "start", "reset_timer", "clear_expiration", "stop", "close"):
            assert _signature(getattr(fake_watchdog, method)) == _signature(getattr(real_watchdog, method)), method
        for prop in ("expired", "timeout", "expiration_states", "name"):
            assert isinstance(getattr(real_watchdog, prop), property) and isinstance(getattr(fake_watchdog, prop),
                                                                                    property)
        real_device, fake_device = real.system.Device, fake["nidaqmx.system"].Device
        assert _signature(fake_device.__init__) == _signature(real_device.__init__)
        for prop in ("name", "product_type", "product_category", "compact_daq_chassis_device"):
            assert isinstance(getattr(real_device, prop), property) and isinstance(getattr(fake_device, prop), property)
        assert _signature(fake["nidaqmx"].Task.write) == _signature(real.Task.write)
        assert real.system.watchdog.AOExpirationState._fields == fake["nidaqmx.types"].AOExpirationState._fields
        for enum in ("WatchdogAOExpirState", "ProductCategory", "WDTTaskAction"):
            for member in getattr(fake["nidaqmx.constants"], enum):
                assert getattr(real.constants, enum)[member.name].value == member.value
        for member in fake["nidaqmx.error_codes"].DAQmxErrors:
            assert real.error_codes.DAQmxErrors[member.name].value == member.value
        for error in ("Error", "DaqError", "DaqWriteError", "DaqNotFoundError"):
            assert [c.__name__ for c in getattr(fake["nidaqmx.errors"], error).__mro__[:-2]] == [
                c.__name__ for c in getattr(real.errors, error).__mro__[:-2]]
    finally:
        for name in [n for n in sys.modules if n.split(".")[0] == "nidaqmx"]:
            del sys.modules[name]
        sys.modules.update(fake)
        sys.path.insert(0, str(FAKE_DIR))


@pytest.mark.ros
@pytest.mark.slow(seconds=4)
def test_hardware_node_takes_an_expired_watchdog_through_its_fault_path_and_recovers(launch_node, ros_client,
                                                                                     tmp_path):
    """The node (its own process, the stand-in driver on its path) stalls once for 0.5 s while commanding 2 bar."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from sensor_msgs.msg import JointState
    from srs_testing import ros_args
    from std_msgs.msg import Float64MultiArray

    from srs_ros.core.robot import default_robot
    from srs_ros.ros.interfaces import COMMANDED_PRESSURE_TOPIC, DIAGNOSTICS_TOPIC, SETPOINT_TOPIC, setpoint_qos

    rig = tmp_path / "daq.yaml"
    rig.write_text((config_dir() / "rigs" / "daq.yaml").read_text().replace("setpoint_timeout_s: 0.2",
                                                                           "setpoint_timeout_s: 1.0"))
    env = {"PYTHONPATH": os.pathsep.join(filter(None, [str(FAKE_DIR), os.environ.get("PYTHONPATH")])),
           "FAKE_NIDAQMX_REAL_TIME": "1", "FAKE_NIDAQMX_STALL": "300:0.5"}  # 3 s after configure
    node = launch_node("hardware_node", ros_args({"rig_file": str(rig), "ramp_time_s": 0.0}), env_overrides=env)
    publisher = ros_client.node.create_publisher(JointState, SETPOINT_TOPIC, setpoint_qos())
    commanded = ros_client.subscribe(Float64MultiArray, COMMANDED_PRESSURE_TOPIC)
    diagnostics = ros_client.subscribe(DiagnosticArray, DIAGNOSTICS_TOPIC)
    setpoint = JointState(name=list(default_robot().joint_names), position=[0.02] * 9)  # 2 bar

    def stream_until(predicate, what, timeout_s=20.0):
        end = time.monotonic() + timeout_s
        while not predicate():
            assert time.monotonic() < end, f"timed out waiting for {what}; node output:\n{node.output()}"
            publisher.publish(setpoint)
            ros_client.executor.spin_once(timeout_sec=0.01)

    ros_client.spin_until(lambda: ros_client.lifecycle_state("/hardware_node") == "unconfigured", what="node up")
    for transition in ("configure", "activate"):
        assert ros_client.change_state("/hardware_node", transition), node.output()
    assert ros_client.trigger("/hardware_node/arm", repeatable=True).success  # real regulators: the operator's go
    stream_until(lambda: ros_client.lifecycle_state("/hardware_node") == "unconfigured",
                 "the expired watchdog to take the node through ErrorProcessing")
    assert any(max(m.data) == pytest.approx(2.0) for m in commanded)  # it was commanding 2 bar before the stall
    ros_client.spin_until(lambda: diagnostics and diagnostics[-1].status[0].level == DiagnosticStatus.ERROR,
                          what="the fault on /diagnostics")
    message = diagnostics[-1].status[0].message
    assert "HardwareError" in message and "watchdog of Dev1 EXPIRED" in message, message

    for transition in ("configure", "activate"):  # close cleared the expiration: recover without a restart
        assert ros_client.change_state("/hardware_node", transition), node.output()
    assert ros_client.trigger("/hardware_node/arm").success
    count = len(commanded)
    stream_until(lambda: len(commanded) > count and max(commanded[-1].data) == pytest.approx(2.0), "2 bar again")
    assert node.alive()
