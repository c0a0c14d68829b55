"""``srs_sweep --ros`` end to end against rigs running as separate processes over DDS.

The simulated rig (sim_world, hardware_node on the sim rig, trajectory_server, gait_player, camera_tracker on
the simulated camera): a short grid, its bags read back with rosbags (topics, message counts), its table in
the offline sweep's layout; a run aborted by an e-stop; Ctrl-C venting and keeping the recording. A rig with
real regulators (CAN on python-can's virtual bus): nothing is armed without the operator's go, and a go arms
only that run.
"""

import csv
import signal
import subprocess
import threading
import time

import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped
from rosbags.interfaces import QosDurability
from srs_testing import RosClient, ros_args, script_path
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger

from srs_ros.core.actuation.operator import arm as operator_arm
from srs_ros.core.actuation.safety import CommandGate
from srs_ros.core.robot import config_dir
from srs_ros.experiments.recording import bag_message_counts, bag_offered_qos, bag_topic_types
from srs_ros.experiments.ros_sweep import RosSweep, RosSweepOptions, RunAborted
from srs_ros.experiments.table import TABLE_COLUMNS, read_table_csv
from srs_ros.ros.interfaces import BUSY_RETRY_S, FIT_BUSY_PREFIX, POSE_TOPIC, STATUS_NODE_KEY, diagnostic_values

SIM_RIG = str(config_dir() / "rigs" / "sim.yaml")


def _start_sim_rig(launch_node):
    launch_node("sim_world", ros_args({"camera_rate_hz": 15.0, "markers_rate_hz": 0.0}))
    launch_node("hardware_node", ros_args({"autostart": True, "rig_file": SIM_RIG}))
    launch_node("trajectory_server", ros_args({"samples": 32}))
    launch_node("gait_player", ros_args({"ramp_time_s": 0.5}))
    launch_node("camera_tracker", ros_args({"color_preset": "sim_bands"}))


def _sweep(ros_env, args, stdin="", timeout_s=180.0):
    return subprocess.run([script_path("srs_sweep"), "--ros", "--no-progress", *args], env=ros_env, input=stdin,
                          capture_output=True, text=True, timeout=timeout_s)


def stamp_s(msg) -> float:
    return msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec


def _rows(path):
    with path.open() as stream:
        return list(csv.reader(stream))


@pytest.mark.slow(seconds=36)
def test_ros_sweep_on_the_simulated_rig_records_bags_and_the_offline_table_layout(launch_node, ros_env, tmp_path):
    _start_sim_rig(launch_node)
    out = tmp_path / "ros"
    grid = ["--gait", "inward_rolling", "--amplitudes", "3", "4", "--frequencies", "1", "--duration-s", "2.5"]
    done = _sweep(ros_env, [*grid, "--settle-s", "0.5", "--out", str(out)])
    assert done.returncode == 0, done.stdout + done.stderr
    assert "no arm needed; simulated world" in done.stderr

    records = read_table_csv(out / "table.csv")
    assert [r.status for r in records] == ["ok", "ok"]
    assert all(r.speed_cm_s > 1.0 for r in records), records  # inward rolling at 4 bar moves the tracked robot
    bags = sorted((out / "bags").iterdir())
    assert [b.name for b in bags] == ["01_inward_rolling_3bar_1hz", "02_inward_rolling_4bar_1hz"]
    for bag in bags:
        assert sorted(p.name for p in bag.iterdir()) == sorted(["metadata.yaml", f"{bag.name}.mcap"])
        counts = bag_message_counts(bag)
        types = bag_topic_types(bag)
        assert types["/robot_pose"] == "geometry_msgs/msg/PoseStamped"
        assert types["/joint_setpoints"] == "sensor_msgs/msg/JointState"
        assert counts["/gait_trajectory"] >= 1
        # Each stream is in the bag (the rates themselves are the nodes' tests; these hold on a busy machine,
        # where 205 setpoints and 11 poses were seen): 200 Hz over a 2.5 s run and the ramp-out ...
        assert counts["/joint_setpoints"] > 2.5 * 50
        assert counts["/commanded_pressure_bar"] > 2.5 * 50
        assert counts["/actuator_state"] > 10
        assert counts["/robot_pose"] > 2.5 * 2  # ... the tracker on a 15 fps camera
        assert counts["/sim/ground_truth_pose"] > 2.5 * 20
        assert counts["/diagnostics"] >= 3
        # The publishers' QoS, as rosbag2 records it: `ros2 bag play` replays the trajectory latched (it recorded
        # none: `offered_qos_profiles: []`).
        offered = bag_offered_qos(bag)
        assert offered["/gait_trajectory"] and {q.durability for q in offered["/gait_trajectory"]} == {
            QosDurability.TRANSIENT_LOCAL}, offered["/gait_trajectory"]
        assert offered["/joint_setpoints"] and {q.durability for q in offered["/joint_setpoints"]} == {
            QosDurability.VOLATILE}, offered["/joint_setpoints"]

    offline = tmp_path / "offline"
    from srs_ros.tools.sweep_cli import main

    assert main([*grid, "--duration-s", "1", "--workers", "1", "--no-progress", "--out", str(offline)]) == 0
    ros_rows, offline_rows = _rows(out / "table.csv"), _rows(offline / "table.csv")
    assert ros_rows[0] == offline_rows[0] == list(TABLE_COLUMNS)
    assert [r[:3] for r in ros_rows] == [r[:3] for r in offline_rows]  # the same cells in the same order
    assert [r[7:9] for r in ros_rows] == [r[7:9] for r in offline_rows] == [["paper_vx_cm_s", "paper_vy_cm_s"],
                                                                            ["5.23", "7.89"], ["5.61", "10.11"]]
    for name in ("table.png", "paths_inward_rolling.png"):
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

    # An e-stop during a run aborts it, is marked with its reason, and --on-failure stop ends the sweep.
    output, records = _interrupted_sweep(ros_env, tmp_path / "estop", lambda client, _process: client.trigger(
        "/hardware_node/emergency_stop").success, expected_code=1, extra=["--on-failure", "stop"])
    assert len(records) == 1 and records[0].status.startswith("failed: e-stop latched"), output
    assert "stopping at the first failed run" in output

    # Ctrl-C vents, writes the table of what was done and keeps the bag of the interrupted run.
    output, records = _interrupted_sweep(ros_env, tmp_path / "ctrl_c", lambda _client, process: process.send_signal(
        signal.SIGINT) or True, expected_code=130)
    assert len(records) == 1 and records[0].status == "failed: interrupted (Ctrl-C); its bag keeps what was recorded", \
        output
    assert "Ctrl-C: venting" in output


def _interrupted_sweep(ros_env, out, interrupt, expected_code, extra=()):
    """A 20 s sweep of two runs, interrupted by ``interrupt(client, process)`` while the first one commands."""
    process = subprocess.Popen([script_path("srs_sweep"), "--ros", "--no-progress", "--gait", "inward_rolling",
                                "--amplitudes", "4", "--frequencies", "1", "0.5", "--duration-s", "20", *extra,
                                "--out", str(out)], env=ros_env, text=True,
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    try:
        with RosClient(int(ros_env["ROS_DOMAIN_ID"]), "interrupting_client") as client:
            pressures = client.subscribe(Float64MultiArray, "commanded_pressure_bar")
            client.spin_until(lambda: pressures and max(pressures[-1].data) > 2.0, 60.0, "the first run commanding")
            assert interrupt(client, process)
            output, _ = process.communicate(timeout=60.0)
            assert process.returncode == expected_code, output
            client.spin_for(0.3)
            assert max(pressures[-1].data) <= 0.01  # vented before the sweep ended
            assert client.trigger("/hardware_node/reset").success  # (releases an e-stop for the next sweep)
    finally:
        if process.poll() is None:
            process.kill()
    assert bag_message_counts(out / "bags" / "01_inward_rolling_4bar_1hz")["/joint_setpoints"] > 0  # kept
    return output, read_table_csv(out / "table.csv")


@pytest.mark.slow(seconds=17)
def test_on_a_rig_with_real_regulators_nothing_is_armed_without_the_operators_go(launch_node, ros_env, ros_client,
                                                                                  tmp_path, monkeypatch):
    rig = tmp_path / "can_virtual.yaml"  # a real CAN backend on python-can's in-process virtual bus
    rig.write_text("rig: {name: can_virtual, backend: can, command_rate_hz: 100.0, setpoint_timeout_s: 0.2,\n"
                   "      backend_options: {interface: virtual, channel: srs_sweep_test}}\n")
    launch_node("hardware_node", ros_args({"autostart": False, "rig_file": str(rig)}))  # configured below
    launch_node("trajectory_server", ros_args({"samples": 16}))
    launch_node("gait_player", ros_args({"ramp_time_s": 0.5}))
    diagnostics = ros_client.subscribe(DiagnosticArray, "/diagnostics")
    pressures = ros_client.subscribe(Float64MultiArray, "commanded_pressure_bar")

    def armed_seen():
        return [kv.value for m in diagnostics for s in m.status if s.name.startswith("hardware_node")
                for kv in s.values if kv.key == "armed"]

    # A sweep that found hardware_node unconfigured (its status says requires_arm False until a rig is configured)
    # still asks the go once the operator has brought it up on the real rig (a safety review found it arming).
    monkeypatch.setenv("ROS_DOMAIN_ID", ros_env["ROS_DOMAIN_ID"])
    sweep, asked = RosSweep(), []
    try:
        found = sweep.discover()
        assert (found.state, found.requires_arm) == ("unconfigured", True), found
        assert ros_client.change_state("/hardware_node", "configure")
        assert ros_client.change_state("/hardware_node", "activate")
        assert sweep.spin_until(lambda: sweep._rig_now(False).state == "active", 10.0)
        record = sweep.run(("inward_rolling", 2.0, 1.0), 1.0, tmp_path / "early_bag",
                           go=lambda cell: asked.append(cell) or False)
    finally:
        sweep.close()
    assert asked == [("inward_rolling", 2.0, 1.0)] and record.status == "skipped: no go from the operator"
    assert "True" not in armed_seen()

    def catch_up(what: str) -> None:
        """Take what was published while the sweep ran: until a diagnostics message from after it (1 Hz)."""
        ended_s = ros_client.node.get_clock().now().nanoseconds * 1e-9
        ros_client.spin_until(lambda: any(stamp_s(m) > ended_s for m in diagnostics[-5:] for s in m.status
                                          if s.name.startswith("hardware_node")), 10.0, what)

    out = tmp_path / "real"
    # The operator says no to the first run and quits at the second: nothing is ever armed or pressurised.
    # A "no" is not a failure: --on-failure stop goes on to ask the second (it stopped there before).
    done = _sweep(ros_env, ["--gait", "inward_rolling", "--amplitudes", "2", "3", "--frequencies", "1",
                            "--duration-s", "1", "--on-failure", "stop", "--out", str(out)], stdin="n\nq\n")
    catch_up("the diagnostics after the first sweep")
    assert done.returncode == 1, done.stdout + done.stderr
    assert "real regulators: each run needs the operator's go" in done.stderr
    assert done.stdout.count("on the real rig?") + done.stderr.count("on the real rig?") == 2
    statuses = [r.status for r in read_table_csv(out / "table.csv")]
    assert statuses == ["skipped: no go from the operator", "failed: the operator stopped the sweep"]
    assert "1 failed, 1 skipped by the operator" in done.stdout and "   skipped   " in done.stdout
    assert "True" not in armed_seen() and pressures and max(max(m.data) for m in pressures) == 0.0

    # With the go the hardware is armed for the run; with no camera there is no pose: the run fails and the
    # sweep disarms again.
    done = _sweep(ros_env, ["--gait", "inward_rolling", "--amplitudes", "2", "--frequencies", "1", "--duration-s",
                            "1", "--yes", "--out", str(tmp_path / "go")])
    catch_up("the diagnostics after the second sweep")
    assert done.returncode == 1, done.stdout + done.stderr
    [record] = read_table_csv(tmp_path / "go" / "table.csv")
    assert record.status.startswith("failed: no pose on /robot_pose"), record.status
    seen = armed_seen()
    assert "True" in seen and seen[-1] == "False"
    assert max(max(m.data) for m in pressures) == 0.0  # armed, but the gait never started


@pytest.mark.slow(seconds=6)
def test_a_tracker_still_starting_is_waited_for_and_a_missing_one_is_not(ros_domain, monkeypatch):
    """A sweep started with the rig (camera and tracker still starting) waits for the first pose as long as for
    discovery; with no tracker at all the run fails after the pose timeout (1 s here, 5 s by default)."""
    monkeypatch.setenv("ROS_DOMAIN_ID", str(ros_domain))
    sweep = RosSweep(RosSweepOptions(pose_timeout_s=1.0))
    stop = threading.Event()
    with RosClient(ros_domain, "rig_stand_in") as rig:
        status = DiagnosticStatus(name="hardware_node: actuators", level=DiagnosticStatus.OK,
                                  values=[KeyValue(key="lifecycle_state", value="active"),
                                          KeyValue(key=STATUS_NODE_KEY, value="/hardware_node")])
        diagnostics = rig.node.create_publisher(DiagnosticArray, "/diagnostics", 10)
        rig.node.create_timer(0.2, lambda: diagnostics.publish(DiagnosticArray(status=[status])))
        spinner = threading.Thread(target=lambda: [rig.executor.spin_once(timeout_sec=0.05)
                                                   for _ in iter(stop.is_set, True)])
        spinner.start()
        try:
            sweep.spin_until(lambda: sweep._hardware is not None, 10.0)
            started_s = time.monotonic()
            with pytest.raises(RunAborted, match=r"no pose on /robot_pose for 1 s before the start"):
                sweep._wait_pose(0.0, "before the start")
            assert time.monotonic() - started_s < 3.0

            poses = rig.node.create_publisher(PoseStamped, POSE_TOPIC, 10)
            first_pose_s = time.monotonic() + 2.0  # the tracker's first pose 2 s after it appears (timeout: 1 s)
            rig.node.create_timer(0.1, lambda: time.monotonic() > first_pose_s and poses.publish(PoseStamped()))
            x_m, y_m, _yaw = sweep._wait_pose(0.0, "before the start")
            assert (x_m, y_m) == (0.0, 0.0) and time.monotonic() >= first_pose_s
        finally:
            stop.set()
            spinner.join()
            sweep.close()


def test_a_trajectory_server_busy_with_another_fit_is_asked_again_and_another_refusal_ends_the_run(ros_domain,
                                                                                                   monkeypatch):
    """trajectory_server answers "busy" while its start-up fit runs (2.5 s under the suite's load made a sweep's first
    run fail before the operator was asked): the sweep asks again until the fit is done; any other refusal ends the
    run at once with the server's reason."""
    monkeypatch.setenv("ROS_DOMAIN_ID", str(ros_domain))
    sweep, stop, answers, calls = RosSweep(RosSweepOptions(fit_timeout_s=10.0)), threading.Event(), [], []

    def regenerate(_request, response):
        calls.append(time.monotonic())
        response.success, response.message = answers.pop(0) if answers else (True, "published")
        return response

    with RosClient(ros_domain, "trajectory_server") as server:
        server.node.create_service(Trigger, "/trajectory_server/regenerate", regenerate)  # the node is named with a pid
        spinner = threading.Thread(target=lambda: [server.executor.spin_once(timeout_sec=0.05)
                                                   for _ in iter(stop.is_set, True)])
        spinner.start()
        try:
            answers += [(False, f"{FIT_BUSY_PREFIX} a fit of inward_rolling at 4 bar, 1 Hz is running for 2.1 s")] * 2
            sweep.regenerate()
            assert len(calls) == 3 and calls[-1] - calls[0] >= 2 * BUSY_RETRY_S
            answers.append((False, "fit failed: amplitude_bar 9 is outside [0, 4] bar"))
            with pytest.raises(RunAborted, match=r"trajectory_server/regenerate: fit failed: amplitude_bar 9"):
                sweep.regenerate()
            assert len(calls) == 4
        finally:
            stop.set()
            spinner.join()
            sweep.close()


@pytest.mark.slow(seconds=5)
def test_a_rig_that_answers_the_arm_as_a_real_one_without_a_go_is_disarmed_and_the_run_fails(launch_node, ros_domain,
                                                                                             monkeypatch, tmp_path):
    """The go is decided from hardware_node's last status (1 Hz): a node reconfigured on a real rig since then answers
    ~/arm as one. The sweep, which asked no go, disarms at once and fails the run. The stand-in hardware node (in this
    process, over DDS) says in its status that it needs no arm and answers ~/arm as a real rig does."""
    launch_node("trajectory_server", ros_args({"samples": 16}))
    launch_node("gait_player", ros_args({"ramp_time_s": 0.5}))
    monkeypatch.setenv("ROS_DOMAIN_ID", str(ros_domain))
    calls, stop = [], threading.Event()
    with RosClient(ros_domain, "rig_stand_in") as rig:
        def service(name, message):
            def answer(_request, response):
                calls.append(name)
                response.success, response.message = True, message
                return response
            return rig.node.create_service(Trigger, f"/hardware_node/{name}", answer)

        service("arm", operator_arm_message())
        service("disarm", "disarmed: venting to 0 bar until ~/arm.")
        status = DiagnosticStatus(name="hardware_node: actuators", level=DiagnosticStatus.OK, values=[
            KeyValue(key="lifecycle_state", value="active"), KeyValue(key="requires_arm", value="False"),
            KeyValue(key="backend", value="mock"), KeyValue(key="rig", value="mock"),
            KeyValue(key=STATUS_NODE_KEY, value="/hardware_node")])
        diagnostics = rig.node.create_publisher(DiagnosticArray, "/diagnostics", 10)
        commanded = rig.node.create_publisher(Float64MultiArray, "commanded_pressure_bar", 10)
        rig.node.create_timer(0.1, lambda: (diagnostics.publish(DiagnosticArray(status=[status])),
                                            commanded.publish(Float64MultiArray(data=[0.0] * 9))))
        spinner = threading.Thread(target=lambda: [rig.executor.spin_once(timeout_sec=0.05)
                                                   for _ in iter(stop.is_set, True)])
        spinner.start()
        sweep = RosSweep()
        try:
            assert sweep.discover().requires_arm is False
            record = sweep.run(("inward_rolling", 2.0, 1.0), 1.0, tmp_path / "bag",
                               go=lambda cell: pytest.fail("no go is asked of a rig that says it needs no arm"))
        finally:
            sweep.close()
            stop.set()
            spinner.join()
    assert record.status.startswith("failed: hardware_node turned out to drive real regulators"), record.status
    assert calls[-2:] == ["arm", "disarm"]  # disarmed right after the arm's answer


def operator_arm_message() -> str:
    """What hardware_node's ~/arm answers on a rig with real regulators (the node's own code, on a CAN rig's gate)."""
    gate = CommandGate(joint_count=9, setpoint_timeout_s=0.2)
    gate.configure(9, 0.2, 1.0, requires_arm=True)
    gate.set_active(True)
    return operator_arm(gate, "can").message


@pytest.mark.slow(seconds=5)
def test_a_sweep_in_a_namespace_reads_its_own_robots_hardware_status_not_anothers(launch_node, ros_domain, ros_client,
                                                                                  monkeypatch):
    """Two robots on one domain share /diagnostics: `srs_sweep --namespace snake1` must read snake1's hardware_node
    (not configured yet: the go will be asked), never snake2's (active, a rig that needs no arm). Before stop 57 it
    took any hardware_node status, whichever came last (a helper's review of the ROS interfaces)."""
    launch_node("hardware_node", ros_args({"autostart": False}, {"__ns": "/snake1"}))
    launch_node("hardware_node", ros_args({"autostart": True}, {"__ns": "/snake2"}))
    statuses = ros_client.subscribe(DiagnosticArray, "/diagnostics")
    monkeypatch.setenv("ROS_DOMAIN_ID", str(ros_domain))
    sweep = RosSweep(RosSweepOptions(namespace="snake1"))
    states = []

    def both_robots_seen_for_a_second() -> bool:  # the sweep's reading, sampled while both report (1 Hz each)
        states.append(sweep._rig_now(False))
        sweep.spin_for(0.05)
        nodes = {diagnostic_values(s).get(STATUS_NODE_KEY) for m in statuses[-6:] for s in m.status}
        return {"/snake1/hardware_node", "/snake2/hardware_node"} <= nodes and len(states) > 22

    try:
        assert sweep.spin_until(lambda: sweep._hardware is not None, 10.0)
        ros_client.spin_until(both_robots_seen_for_a_second, 15.0, "both robots' statuses")
    finally:
        sweep.close()
    assert {(rig.state, rig.requires_arm) for rig in states} == {("unconfigured", True)}, states[-5:]
