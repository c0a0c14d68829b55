"""srs_wiring_check: pulses each regulator in turn, never above the limit, vents between pulses and on Ctrl-C."""

import io
import json
import os
import signal
import subprocess
import sys
import time
import uuid

import can
import cantools
import numpy as np
import pytest
from backends.can_bus import write_can_rig
from srs_testing import script_path

from srs_ros.core.robot import config_dir
from srs_ros.tools.wiring_check import main, select_joints

DBC = cantools.database.load_file(str(config_dir() / "srs_dac.dbc"))
JOINTS = ["m1_pma1", "m1_pma2", "m1_pma3", "m2_pma1", "m2_pma2", "m2_pma3", "m3_pma1", "m3_pma2", "m3_pma3"]


def can_rig(tmp_path, channel: str, rate_hz: float = 100.0):
    return write_can_rig(tmp_path / "virtual_can.yaml", "virtual_can", {"interface": "virtual", "channel": channel},
                         rate_hz, 0.2)


def writes_from_frames(frames) -> list[tuple]:
    """The command voltages (mV, per channel) of each write: three frames 0x100, 0x101, 0x102 per write."""
    assert len(frames) % 3 == 0, f"{len(frames)} frames is not whole writes"
    writes = []
    for k in range(0, len(frames), 3):
        ids = [frame_id for frame_id, _ in frames[k:k + 3]]
        assert ids == [0x100, 0x101, 0x102]
        signals = {}
        for frame_id, data in frames[k:k + 3]:
            signals.update(DBC.decode_message(frame_id, data))
        writes.append(tuple(round(signals[f"CMD_CH{i}"] * 1000) for i in range(1, 10)))
    return writes


def collapse(writes) -> list[tuple]:
    """Consecutive repeats removed: the sequence of distinct commands."""
    return [w for i, w in enumerate(writes) if i == 0 or w != writes[i - 1]]


def pulse(channel_index: int, millivolts: int) -> tuple:
    values = [0] * 9
    values[channel_index] = millivolts
    return tuple(values)


def test_select_joints_by_name_or_number():
    assert select_joints(None, JOINTS) == list(range(9))
    assert select_joints(["m2_pma1", "9", "1,3"], JOINTS) == [3, 8, 0, 2]
    with pytest.raises(ValueError, match="m4_pma1"):
        select_joints(["m4_pma1"], JOINTS)


def test_mock_rig_pulses_every_regulator_in_order(capsys):
    code = main(["--rig", str(config_dir() / "rigs" / "mock.yaml"), "--hold-s", "0.05", "--vent-s", "0.02"])
    out = capsys.readouterr().out
    assert code == 0, out
    pulses = [line for line in out.splitlines() if line.startswith("pulse ")]
    assert len(pulses) == 9
    for k, (line, joint) in enumerate(zip(pulses, JOINTS), start=1):
        assert line.startswith(f"pulse {k}/9: {joint} (joint {k}) -> mock output {k}: 1.50 bar = 1.667 V")
    assert out.count("  vented ") == 9 and "done: 9 regulator(s) pulsed, all vented" in out


def test_backend_override_runs_a_can_rig_on_the_mock(capsys):
    code = main(["--rig", str(config_dir() / "rigs" / "can.yaml"), "--backend", "mock", "--channels", "m3_pma2",
                 "--hold-s", "0.02", "--vent-s", "0.02"])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "(mock backend, ITV3050): 1 pulse(s)" in out and "pulse 1/1: m3_pma2 (joint 8) -> mock output 8" in out


def test_virtual_can_bus_sees_one_regulator_at_a_time(tmp_path, capsys):
    channel = f"srs_wiring_{uuid.uuid4().hex[:8]}"
    board = can.Bus(interface="virtual", channel=channel)
    try:
        code = main(["--rig", str(can_rig(tmp_path, channel)), "--pressure-bar", "4.0",
                     "--hold-s", "0.05", "--vent-s", "0.03", "--yes"])
        frames = []
        while (message := board.recv(timeout=0.0)) is not None:
            frames.append((message.arbitration_id, bytes(message.data)))
    finally:
        board.shutdown()
    out = capsys.readouterr().out
    assert code == 0, out
    assert "m3_pma3 (joint 9) -> CMD_CH9 in SRS_CMD_C (0x102): 4.00 bar = 4.444 V" in out
    writes = writes_from_frames(frames)
    expected = [pulse(0, 0)]
    for k in range(9):
        expected += [pulse(k, 4444), pulse(k, 0)]
    assert collapse(writes) == expected  # vented before, between and after; never two at once
    assert max(max(w) for w in writes) == 4444  # 4 bar on an ITV3050, the limit: never above
    assert len(writes) >= 9 * 2 * 2  # each pulse and vent resent at the command rate


def test_a_rig_with_real_regulators_needs_the_operators_go_and_without_it_nothing_is_sent(tmp_path, capsys,
                                                                                          monkeypatch):
    """As srs_identify: no --yes and no terminal to type yes at, the CAN rig is refused before the bus is opened."""
    channel = f"srs_wiring_{uuid.uuid4().hex[:8]}"
    board = can.Bus(interface="virtual", channel=channel)
    monkeypatch.setattr(sys, "stdin", io.StringIO(""))  # no terminal: no typed yes
    try:
        code = main(["--rig", str(can_rig(tmp_path, channel)), "--hold-s", "0.05", "--vent-s", "0.03"])
        received = board.recv(timeout=0.2)
    finally:
        board.shutdown()
    err = capsys.readouterr().err
    assert code == 2 and received is None, err
    assert "refused: the can rig drives real regulators with real air: 9 pulse(s) of 1.5 bar" in err
    assert "Pass --yes" in err


def test_pressure_above_the_limit_is_refused_with_exit_code_2(capsys):
    for bad in ("4.01", "nan", "-1", "0"):
        with pytest.raises(SystemExit) as stop:
            main(["--rig", str(config_dir() / "rigs" / "mock.yaml"), "--pressure-bar", bad])
        assert stop.value.code == 2
    assert "--pressure-bar" in capsys.readouterr().err


def test_bad_rig_or_channel_exits_2_naming_the_problem(tmp_path, capsys):
    rig = tmp_path / "bad.yaml"
    rig.write_text("rig: {name: x, backend: can, command_rate_hz: 100, setpoint_timeout_s: 0.2,"
                   " backend_options: {interface: virtual, channels: [1, 2]}}\n")
    assert main(["--rig", str(rig)]) == 2
    assert f"{rig}: can backend_options: channels is [1, 2]; expected 9 distinct" in capsys.readouterr().err
    assert main(["--rig", str(config_dir() / "rigs" / "mock.yaml"), "--channels", "m9_pma9"]) == 2
    assert "m9_pma9" in capsys.readouterr().err


def test_missing_driver_exits_1_with_the_hint(capsys):
    assert main(["--rig", str(config_dir() / "rigs" / "daq.yaml"), "--hold-s", "0.05", "--yes"]) == 1
    assert "installdriver" in capsys.readouterr().err


def _wait_for_line(process, prefix: str, timeout_s: float = 30.0) -> list[str]:
    """Read the process's stdout until a line starts with ``prefix``; return the lines read."""
    lines, end = [], time.monotonic() + timeout_s
    while time.monotonic() < end:
        line = process.stdout.readline()
        if not line:
            raise AssertionError(f"process ended before {prefix!r}: {lines} {process.stderr.read()}")
        lines.append(line)
        if line.startswith(prefix):
            return lines
    raise AssertionError(f"no {prefix!r} line within {timeout_s} s: {lines}")


def _interrupt(process, timeout_s: float = 15.0) -> tuple[int, str, float]:
    sent = time.monotonic()
    process.send_signal(signal.SIGINT)
    out, err = process.communicate(timeout=timeout_s)
    return process.returncode, out + err, time.monotonic() - sent


def _interrupt_during_first_pulse(command, env=None):
    """Run the tool, press Ctrl-C while it holds pulse 1; (exit code, output, seconds to exit)."""
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        _wait_for_line(process, "pulse 1/9")
        return _interrupt(process)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()


def test_ctrl_c_vents_at_once_mock_console_script():
    code, output, elapsed_s = _interrupt_during_first_pulse(
        [script_path("srs_wiring_check"), "--rig", str(config_dir() / "rigs" / "mock.yaml"), "--hold-s", "30"])
    assert code == 130, output
    assert "interrupted: all regulators vented" in output and "Traceback" not in output
    assert elapsed_s < 10.0  # at once, not after the 30 s pulse


CAN_CHILD = """
import json, sys
import can
from srs_ros.tools.wiring_check import main
board = can.Bus(interface="virtual", channel=sys.argv[1])  # the DAC board, in the tool's process
code = main(sys.argv[3:])
frames = []
while (message := board.recv(timeout=0.0)) is not None:
    frames.append([message.arbitration_id, bytes(message.data).hex()])
with open(sys.argv[2], "w") as stream:
    json.dump(frames, stream)
sys.exit(code)
"""


def test_ctrl_c_vents_at_once_on_a_can_bus(tmp_path):
    channel = f"srs_wiring_{uuid.uuid4().hex[:8]}"
    record = tmp_path / "frames.json"
    args = ["--rig", str(can_rig(tmp_path, channel, rate_hz=50.0)), "--hold-s", "30", "--vent-s", "0.05", "--yes"]
    code, output, elapsed_s = _interrupt_during_first_pulse(
        [sys.executable, "-c", CAN_CHILD, channel, str(record), *args], env=dict(os.environ, PYTHONUNBUFFERED="1"))
    assert code == 130, output
    assert "interrupted: all regulators vented" in output and elapsed_s < 10.0
    writes = writes_from_frames([(frame_id, bytes.fromhex(data)) for frame_id, data in json.loads(record.read_text())])
    assert collapse(writes) == [pulse(0, 0), pulse(0, 1667), pulse(0, 0)]  # open, the interrupted pulse, vent
    assert writes[-1] == pulse(0, 0) and np.count_nonzero(writes[1:-1], axis=1).max() == 1


@pytest.mark.parametrize("channels", [[","], [""], ["²"]])
def test_channels_that_name_no_joint_are_refused_not_taken_for_none(channels):
    """``--channels ,`` pulsed nothing and said "done"; ``²`` (a digit to str.isdigit) gave int()'s own error."""
    with pytest.raises(ValueError, match="--channels"):
        select_joints(channels, JOINTS)


def test_the_sim_rig_with_no_world_answering_pulses_nothing_and_fails(ros_env, tmp_path):
    """With no sim_world, the default run (13.5 s) ended before the sim backend's 15 s start-up timeout: nine pulses
    printed, "done, all vented", exit 0, though nothing heard them (a helper's review). It now waits for the world."""
    rig = tmp_path / "sim.yaml"
    rig.write_text((config_dir() / "rigs" / "sim.yaml").read_text().replace("startup_timeout_s: 15.0",
                                                                             "startup_timeout_s: 1.0"))
    done = subprocess.run([script_path("srs_wiring_check"), "--rig", str(rig), "--hold-s", "0.1", "--vent-s", "0.1"],
                          env=ros_env, capture_output=True, text=True, timeout=60, stdin=subprocess.DEVNULL)
    output = done.stdout + done.stderr
    assert done.returncode == 1, output
    assert "waiting: waiting for sim_world's first read-back" in output and "no read-back from sim_world" in output
    assert "pulse 1/" not in output
