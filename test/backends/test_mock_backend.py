"""The mock backend: simulated muscles behind the contract, its options and fault injection."""

import numpy as np
import pytest

from srs_ros.backends import create_backend
from srs_ros.backends.mock import MockBackend, read_record
from srs_ros.core.errors import ConfigurationError, HardwareError
from srs_ros.core.rig import load_rig


class ManualClock:
    def __init__(self):
        self.now_s = 100.0

    def __call__(self):
        return self.now_s


def test_measured_state_follows_the_command_with_delay_lag_and_deadzone():
    clock = ManualClock()
    backend = MockBackend(options={"pressure_time_constant_s": 0.05, "transport_delay_s": 0.02}, clock=clock)
    with backend:
        backend.write_pressures(np.r_[0.5, 2.5, 4.0, np.zeros(6)])
        clock.now_s += 0.01
        assert backend.read_state().measured_pressure_bar == pytest.approx(np.zeros(9))  # in the supply line
        clock.now_s += 2.0
        state = backend.read_state()
        assert state.measured_pressure_bar[:3] == pytest.approx([0.5, 2.5, 4.0])
        assert state.measured_length_m[:3] == pytest.approx([0.0, 0.0325, 0.065])  # deadzone, linear, saturated
        assert state.commanded_pressure_bar[:3] == pytest.approx([0.5, 2.5, 4.0])
        assert state.details["simulated"] is True


def test_the_mock_rig_file_configures_the_backend():
    rig = load_rig()
    backend = create_backend(rig.backend, rig.robot, rig.backend_options)
    assert isinstance(backend, MockBackend)
    assert backend.params.pressure_time_constant_s == rig.backend_options["pressure_time_constant_s"]
    assert backend.params.max_extension_m == rig.robot.max_extension_m


@pytest.mark.parametrize(("options", "key"), [
    ({"pressure_time_constant_s": -1.0}, "pressure_time_constant_s"),
    ({"transport_delay_s": "fast"}, "transport_delay_s"),
    ({"deadzone_bar": 5.0}, "deadzone_bar"),
    ({"max_extension": 0.06}, "max_extension"),
    ({"fail_after_writes": -2}, "fail_after_writes"),
    ({"fail_on_open": "yes"}, "fail_on_open"),
])
def test_bad_options_name_the_key(options, key):
    with pytest.raises(ConfigurationError, match=f"^mock backend_options: {key} is "):
        MockBackend(options=options)


def test_fail_after_writes_injects_a_hardware_error_and_reopen_recovers():
    backend = MockBackend(options={"fail_after_writes": 2})
    backend.open()
    backend.write_pressures(np.ones(9))
    backend.write_pressures(np.ones(9))
    with pytest.raises(HardwareError, match="fail_after_writes"):
        backend.write_pressures(np.ones(9))
    with pytest.raises(HardwareError):
        backend.close()  # the vent on close fails too, as on a dead bus; the backend is closed anyway
    assert not backend.is_open
    backend.open()
    backend.write_pressures(np.ones(9))


def test_fail_on_open_leaves_the_backend_closed():
    backend = MockBackend(options={"fail_on_open": True})
    with pytest.raises(HardwareError, match="fail_on_open"):
        backend.open()
    assert not backend.is_open


def test_record_file_holds_every_command_the_backend_is_given(tmp_path):
    record = tmp_path / "writes.txt"
    backend = MockBackend(options={"record_file": str(record)})
    with backend:
        backend.write_pressures(np.r_[1.0, 2.5, 9.0, np.zeros(6)])  # 9 bar: the clamp gives the backend 4
        times, pressures, _ = read_record(record)  # visible while the backend is open (another process reads it)
        assert pressures.tolist() == [[1.0, 2.5, 4.0] + [0.0] * 6]
    times, pressures, _ = read_record(record)
    assert len(times) == 2 and np.all(np.diff(times) >= 0) and not pressures[-1].any()  # close vents
    assert record.read_text().count("# open") == 1 and record.read_text().count("# close") == 1


@pytest.mark.parametrize("value", ["", 3, "/no/such/folder/writes.txt", "/dev/null"])
def test_a_bad_record_file_names_the_key(value):
    with pytest.raises(ConfigurationError, match=f"^mock backend_options: record_file is {value!r}"):
        MockBackend(options={"record_file": value})
