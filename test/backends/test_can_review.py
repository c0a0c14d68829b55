"""CAN backend: what a rig or DBC can get wrong is refused at construction, and read-back never breaks a write.

Real python-can virtual buses and real cantools; a second bus on the same channel plays the DAC board.
"""

import re
import sys
from pathlib import Path

import can
import numpy as np
import pytest
import yaml
from backends.can_bus import DBC, MONITOR_IDS, backend_on, decode_write, expected_mv, receive

from srs_ros.backends import create_backend
from srs_ros.backends.can_backend import CanBackend
from srs_ros.core.errors import BackendUnavailableError, ConfigurationError
from srs_ros.core.rig import load_rig
from srs_ros.core.robot import config_dir

SHIPPED_DBC = (config_dir() / "srs_dac.dbc").read_text()
DOCS = Path(__file__).resolve().parents[2] / "docs"


def dbc_file(tmp_path: Path, text: str) -> str:
    path = tmp_path / "board.dbc"
    path.write_text(text)
    return str(path)


# -- read-back: a VAL_ table on a monitor signal ----------------------------------------------------------------
def test_a_monitor_signal_with_named_values_is_read_as_a_number_and_the_write_completes(board, channel, tmp_path):
    """cantools names a raw value found in a VAL_ table; the backend reads the number and the write still counts."""
    path = dbc_file(tmp_path, SHIPPED_DBC + 'VAL_ 384 MON_CH1 0 "NO_SIGNAL" 1000 "ONE_VOLT" ;\n')
    with backend_on(channel, dbc_file=path) as backend:
        receive(board, 3)
        monitor = DBC.get_message_by_frame_id(MONITOR_IDS[0])
        data = monitor.encode({"MON_CH1": 0.0, "MON_CH2": 3.0, "MON_CH3": 3.0, "MON_CH4": 3.0})
        board.send(can.Message(arbitration_id=MONITOR_IDS[0], is_extended_id=False, data=data))
        sent = backend.write_pressures(np.full(9, 1.0))  # drains the monitor frame after sending
        assert decode_write(receive(board, 3)) == pytest.approx(expected_mv(np.full(9, 1.0)))
        state = backend.read_state()
    assert sent == pytest.approx(np.full(9, 1.0))
    assert state.commanded_pressure_bar == pytest.approx(np.full(9, 1.0))  # the base class recorded the write
    assert state.details["readback_decode_errors"] == 0
    assert state.measured_pressure_bar[:4] == pytest.approx([-2.25, 4.5, 4.5, 4.5])  # 0 V and 3 V on 1-5 V = 0-9 bar


# -- python-can's config file -----------------------------------------------------------------------------------
def test_python_can_config_file_values_reach_the_bus_typed_as_python_can_types_them(channel, tmp_path):
    ini = tmp_path / "can.ini"
    ini.write_text(f"[srs]\ninterface = virtual\nchannel = {channel}\nbitrate = 500000\nreceive_own_messages = False\n")
    backend = CanBackend(options={"can_config_file": str(ini), "can_config_context": "srs", "readback": False})
    assert backend._bus_kwargs["bitrate"] == 500000 and isinstance(backend._bus_kwargs["bitrate"], int)
    assert backend._bus_kwargs["receive_own_messages"] is False
    with backend:
        assert backend._bus.receive_own_messages is False
        backend.write_pressures(np.full(9, 1.0))
        assert backend._bus.recv(timeout=0.05) is None  # the host does not hear its own command frames


# -- the DBC must carry the rig's commands ----------------------------------------------------------------------
def test_a_command_signal_too_narrow_for_the_pressure_limit_is_refused_naming_the_signal(tmp_path):
    """12 bits of 1 mV end at 4.095 V, short of 4.444 V (4 bar on an ITV3050): refused now, not mid-run."""
    narrow = SHIPPED_DBC.replace("SG_ CMD_CH2 : 16|16@1+", "SG_ CMD_CH2 : 16|12@1+", 1)
    assert narrow != SHIPPED_DBC
    expected = r"^can backend_options: dbc_file is '.*board\.dbc'; expected command signal CMD_CH2 in SRS_CMD_A " \
               r"able to carry 0 V up to 4\.444 V.*Unsigned integer value 4444 out of range"
    with pytest.raises(ConfigurationError, match=expected):
        CanBackend(options={"interface": "virtual", "dbc_file": dbc_file(tmp_path, narrow)})
    wide_enough = SHIPPED_DBC.replace("SG_ CMD_CH2 : 16|16@1+", "SG_ CMD_CH2 : 16|13@1+", 1)  # up to 8.191 V
    CanBackend(options={"interface": "virtual", "dbc_file": dbc_file(tmp_path, wide_enough)})


# -- send_timeout_s within the board's timeout ------------------------------------------------------------------
def test_a_send_timeout_beyond_the_board_timeouts_share_is_refused():
    """Three frames per write, each waiting up to send_timeout_s, must fit in board_timeout_s (0.1 s)."""
    with pytest.raises(ConfigurationError, match=r"^can backend_options: send_timeout_s is 5\.0; expected at most "
                                                 r"0\.03333 s: board_timeout_s 0\.1 s shared by the 3 command frames"):
        create_backend("can", options={"interface": "virtual", "channel": "x", "send_timeout_s": 5.0})
    assert CanBackend(options={"interface": "virtual", "send_timeout_s": 0.03}).send_timeout_s == 0.03
    assert CanBackend(options={"interface": "virtual"}).send_timeout_s == 0.02  # the default fits
    short_board = CanBackend(options={"interface": "virtual", "board_timeout_s": 0.03})
    assert short_board.send_timeout_s == pytest.approx(0.01)  # unset: lowered to the share


# -- signal-name patterns ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("key", ["command_signal", "monitor_signal"])
@pytest.mark.parametrize("pattern", ["CMD_{channel}_{x}", "{0}CMD_CH{channel}", "MON_CH{channel}{",
                                     "CMD_CH{channel[0]}{channel}", "CMD{channel}_{channel:s}"])
def test_a_signal_pattern_with_other_fields_is_refused_naming_the_key(key, pattern):
    expected = f"^can backend_options: {key} is {re.escape(repr(pattern))}; expected a signal-name pattern whose " \
               r"only field is \{channel\}"
    with pytest.raises(ConfigurationError, match=expected):
        create_backend("can", options={"interface": "virtual", "channel": "x", key: pattern})


# -- python-can and cantools are optional packages --------------------------------------------------------------
@pytest.mark.parametrize(("module", "package"), [("can", "python-can"), ("cantools", "cantools")])
def test_a_missing_python_package_makes_the_backend_unavailable_with_the_install_hint(monkeypatch, module, package):
    monkeypatch.setitem(sys.modules, module, None)  # as on a host without the package's hardware extra
    with pytest.raises(BackendUnavailableError, match=f"the Python package {package} is not installed .*"
                                                      r"`pip install python-can cantools`"):
        create_backend("can", options={"interface": "virtual", "channel": "x"})


# -- the backend's name in a rig file ---------------------------------------------------------------------------
def test_a_misspelled_backend_in_a_rig_file_names_the_file_and_the_key(tmp_path):
    path = tmp_path / "can_typo.yaml"
    path.write_text(yaml.safe_dump({"rig": {"name": "typo", "backend": "cann", "command_rate_hz": 100.0,
                                            "setpoint_timeout_s": 0.2, "backend_options": {}}}))
    rig = load_rig(path)
    expected = f"^{re.escape(str(path))}: rig.backend: unknown backend 'cann'; expected one of " \
               r"\['can', 'daq', 'mock', 'sim'\]\.$"
    with pytest.raises(ConfigurationError, match=expected):
        create_backend(rig.backend, rig.robot, rig.backend_options, rig.source)  # as the hardware node calls it


# -- docs/can.md agrees with the hardware node ------------------------------------------------------------------
def test_the_can_page_says_setpoints_are_written_only_on_command_ticks():
    """The hardware node writes only from its command timer (docs/safety.md), never through per setpoint."""
    text = " ".join((DOCS / "can.md").read_text().split())
    assert "written through" not in text and "faster than the command rate" not in text
    assert "Setpoints are written only on these command ticks, never per setpoint" in text


def test_a_coarse_command_signal_never_carries_more_than_the_limits_voltage(board, channel, tmp_path):
    """cantools rounds to the nearest raw step: with 0.5 V steps the limit's 4.444 V went out as 4.5 V, 4.05 bar
    (a helper's review). The command is now the highest step at or below the limit: 4.0 V."""
    coarse = dbc_file(tmp_path, SHIPPED_DBC.replace("(0.001,0) [0|10] \"V\"", "(0.5,0) [0|10] \"V\""))
    with backend_on(channel, dbc_file=coarse) as backend:
        receive(board, 3)  # the open's vent
        backend.write_pressures(np.full(9, 4.0))
        sent = {}
        for frame in receive(board, 3):
            sent.update(backend.layout.database.decode_message(frame.arbitration_id, frame.data))
    commands = [sent[f"CMD_CH{i}"] for i in range(1, 10)]
    assert max(commands) <= backend.layout.limit_v and commands == [4.0] * 9
