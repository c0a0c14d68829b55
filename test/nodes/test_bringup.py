"""The main job: srs_bringup runs the whole system on the mock robot in one process; Ctrl-C vents."""

import numpy as np
import pytest
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from srs_ros.core.robot import default_robot
from srs_ros.ros.interfaces import setpoint_qos


@pytest.mark.slow(seconds=3)
def test_bringup_streams_inward_rolling_at_4_bar_and_vents_on_ctrl_c(launch_node, ros_client):
    proc = launch_node("srs_bringup", ["--status-period-s", "0.5"])
    pressures = ros_client.subscribe(Float64MultiArray, "commanded_pressure_bar")
    setpoints = ros_client.subscribe(JointState, "joint_setpoints", setpoint_qos(depth=1000))
    ros_client.spin_until(lambda: pressures and max(max(m.data) for m in pressures) > 3.9, 30.0,
                          "commanded pressures reaching the 4 bar amplitude")
    ros_client.spin_until(lambda: setpoints, 10.0, "setpoints (best effort) seen by the client")
    robot = default_robot()
    latest = np.array([m.data for m in pressures[-50:]])
    assert latest.shape[1] == 9 and latest.max() <= robot.max_pressure_bar
    assert pressures[-1].layout.dim[0].label == ",".join(robot.joint_names)
    assert setpoints and list(setpoints[-1].name) == list(robot.joint_names)
    assert proc.stop() == 0
    output = proc.output()
    assert "inward_rolling 4 bar 1 Hz" in output and "setpoints" in output and "largest" in output
    assert "every valve vented to 0 bar" in output
    assert "Traceback" not in output


def test_bringup_rejects_bad_arguments(launch_node):
    proc = launch_node("srs_bringup", ["--amplitude-bar", "abc"])
    assert proc.process.wait(30) == 2
    assert "invalid float value" in proc.output()


def test_bringup_refuses_out_of_range_requests_with_the_reason(launch_node):
    for args, reason in ((["--amplitude-bar", "5"], "amplitude_bar out of range"),
                         (["--gait", "crawl"], "gait is 'crawl'; expected one of")):
        proc = launch_node("srs_bringup", args)
        assert proc.process.wait(30) == 2
        output = proc.output()
        assert reason in output and "Traceback" not in output


def test_bringup_stops_with_status_2_and_the_reason_when_the_hardware_cannot_start(launch_node, tmp_path):
    rig = tmp_path / "missing_bus.yaml"
    rig.write_text("rig: {name: missing_bus, backend: can, command_rate_hz: 100.0, setpoint_timeout_s: 0.2,\n"
                   "      backend_options: {interface: socketcan, channel: vcan_does_not_exist}}\n")
    proc = launch_node("srs_bringup", ["--rig", str(rig), "--samples", "16"])
    assert proc.process.wait(60) == 2, proc.output()
    output = proc.output()
    assert "hardware_node could not start" in output and "vcan_does_not_exist" in output
    assert "Traceback" not in output


@pytest.mark.slow(seconds=4)
def test_a_rig_with_real_regulators_holds_0_bar_until_the_operator_arms_it(launch_node, ros_client, tmp_path):
    rig = tmp_path / "can_virtual.yaml"  # a real CAN backend on python-can's in-process virtual bus
    rig.write_text("rig: {name: can_virtual, backend: can, command_rate_hz: 100.0, setpoint_timeout_s: 0.2,\n"
                   "      backend_options: {interface: virtual, channel: srs_test}}\n")
    proc = launch_node("srs_bringup", ["--rig", str(rig), "--samples", "16"])
    pressures = ros_client.subscribe(Float64MultiArray, "commanded_pressure_bar")
    setpoints = ros_client.subscribe(JointState, "joint_setpoints", setpoint_qos(depth=1000))
    ros_client.spin_until(lambda: len(setpoints) > 400 and len(pressures) > 200, 30.0,
                          "two seconds of streaming setpoints")
    assert all(max(m.data) == 0.0 for m in pressures)  # the gait plays, the valves stay vented
    assert "holding 0 bar until the operator arms it" in proc.output()
    response = ros_client.trigger("/hardware_node/arm")
    assert response.success and "ARMED" in response.message
    ros_client.spin_until(lambda: max(pressures[-1].data) > 1.0, 10.0, "pressures after the arm")
    assert proc.stop() == 0 and "every valve vented to 0 bar" in proc.output()
