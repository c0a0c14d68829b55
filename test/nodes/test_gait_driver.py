"""The navigator's gait driver (srs_ros.ros.gait_driver) against real trajectory_server and gait_player processes.

What `ros2 param get` would read back after the driver's calls: the gait, its parameters, the playing direction.
"""

import signal

import pytest
from sensor_msgs.msg import JointState
from srs_testing import ros_args
from std_srvs.srv import Trigger

from srs_ros.core.navigation import GaitCommand
from srs_ros.ros.gait_driver import GaitDriver
from srs_ros.ros.interfaces import FIT_BUSY_PREFIX, SETPOINT_TOPIC, setpoint_qos


def drive_until_playing(ros_client, driver, command, timeout_s=30.0):
    driver.drive(command)

    def applied():
        driver.pump()
        return driver.playing and not driver.busy and driver.wanted == command and not driver.error

    ros_client.spin_until(applied, timeout_s, f"{command.direction} applied and playing ({driver.error or 'no error'})")


@pytest.mark.slow(seconds=5)
def test_a_trajectory_server_busy_with_another_fit_is_asked_again_soon_and_is_no_error(launch_node, ros_client):
    """The main job starts the navigator beside trajectory_server, whose start-up fit may still run when the first
    gait command comes: its regenerate is answered "busy". That is asked again shortly, and is not an error (it was
    published as "gait command not applied" and retried only a second later)."""
    launch_node("trajectory_server", ros_args({"samples": 256, "generate_on_start": False}))
    launch_node("gait_player", ros_args({"ramp_time_s": 0.2}))
    driver = GaitDriver(ros_client.node, "/trajectory_server", "/gait_player", keepalive_s=0.0)
    ros_client.spin_until(lambda: not driver.missing_services(), 30.0, "the gait services")
    regenerate = ros_client.client(Trigger, "trajectory_server/regenerate")
    ros_client.spin_until(regenerate.service_is_ready, 30.0, "trajectory_server/regenerate")
    other_fit = regenerate.call_async(Trigger.Request())  # 256 samples: about a second
    probe = regenerate.call_async(Trigger.Request())
    ros_client.spin_until(probe.done, 10.0, "the probe's answer")
    assert probe.result().message.startswith(FIT_BUSY_PREFIX), probe.result().message  # the other fit runs
    errors = []

    def applied():
        driver.pump()
        errors.append(driver.error)
        return driver.playing and not driver.busy and driver.error == ""

    driver.drive(GaitCommand("inward_rolling", 0.2, 4.0, 1.0))
    ros_client.spin_until(applied, 30.0, "the command applied after the other fit")
    assert driver.calls["regenerate"] >= 2, driver.calls  # the first was answered busy
    assert other_fit.done() and other_fit.result().success
    assert [e for e in errors if e] == [], errors  # a busy answer was never said as a failure
    assert ros_client.get_parameters("/trajectory_server", ["inward_rolling.turn_phase_rad"]) == {
        "inward_rolling.turn_phase_rad": 0.2}
    driver.stop(GaitCommand(None, 0.0, 4.0, 1.0))
    ros_client.spin_until(lambda: not driver.busy, 10.0, "the stop answered")


@pytest.mark.slow(seconds=6)
def test_a_move_along_the_axis_plays_the_straight_serpentine_backward_and_rolling_takes_over_again(
        launch_node, ros_client):
    launch_node("trajectory_server", ros_args({"samples": 32}))
    launch_node("gait_player", ros_args({"ramp_time_s": 0.2}))
    driver = GaitDriver(ros_client.node, "/trajectory_server", "/gait_player", keepalive_s=0.0)
    ros_client.spin_until(lambda: not driver.missing_services(), 30.0, "the gait services")
    drive_until_playing(ros_client, driver, GaitCommand("serpentine_backward", 0.35, 4.0, 1.0))
    gait = ros_client.get_parameters("/trajectory_server", ["gait", "amplitude_bar", "serpentine.c_rad_per_unit"])
    assert gait == {"gait": "serpentine", "amplitude_bar": 4.0, "serpentine.c_rad_per_unit": 0.0}
    assert ros_client.get_parameters("/gait_player", ["reverse"]) == {"reverse": True}
    drive_until_playing(ros_client, driver, GaitCommand("inward_rolling", 0.2, 4.0, 1.0))
    gait = ros_client.get_parameters("/trajectory_server", ["gait", "inward_rolling.turn_phase_rad"])
    assert gait == {"gait": "inward_rolling", "inward_rolling.turn_phase_rad": 0.2}
    assert ros_client.get_parameters("/gait_player", ["reverse"]) == {"reverse": False}
    driver.stop(GaitCommand(None, 0.0, 4.0, 1.0))
    ros_client.spin_until(lambda: not driver.busy, 10.0, "the stop answered")


@pytest.mark.slow(seconds=8)
def test_a_stop_waits_for_a_start_in_flight_so_the_player_ends_stopped(launch_node, ros_client):
    """The dead man's handle sends ~/start every quarter of keepalive_s; ~/start and ~/stop are two services with no
    order between them, and a start the player took after a cancel's stop would ramp the gait in again. Here the
    player is paused (SIGSTOP) with a start in flight when the stop is asked: no stop is sent until the start is
    answered, then one is, and the stream ends."""
    launch_node("trajectory_server", ros_args({"samples": 32}))
    player = launch_node("gait_player", ros_args({"ramp_time_s": 0.2}))
    driver = GaitDriver(ros_client.node, "/trajectory_server", "/gait_player", keepalive_s=0.4)
    setpoints = ros_client.subscribe(JointState, SETPOINT_TOPIC, setpoint_qos())
    ros_client.spin_until(lambda: not driver.missing_services(), 30.0, "the gait services")
    drive_until_playing(ros_client, driver, GaitCommand("inward_rolling", 0.0, 4.0, 1.0))
    player.process.send_signal(signal.SIGSTOP)
    try:
        starts = driver.calls["start"]
        ros_client.spin_until(lambda: driver.pump() or driver.calls["start"] > starts, 5.0, "a keepalive start")
        driver.stop(GaitCommand(None, 0.0, 4.0, 1.0))
        ros_client.spin_for(0.5)
        assert driver.calls["stop"] == 0 and driver.busy, driver.calls  # the start has no answer: no stop yet
    finally:
        player.process.send_signal(signal.SIGCONT)
    ros_client.spin_until(lambda: driver.pump() or (driver.calls["stop"] == 1 and not driver.busy), 10.0,
                          f"the stop after the start's answer ({driver.error or 'no error'})")
    assert not driver.playing and not driver.error
    ros_client.spin_for(1.0)  # the ramp-out (0.2 s) ends the stream
    count = len(setpoints)
    ros_client.spin_for(1.0)
    assert len(setpoints) == count, "gait_player still streams after the stop: the late start ramped it in again"
