"""The navigator's gait driver (srs_ros.ros.gait_driver) against real trajectory_server and gait_player processes.

What `ros2 param get` would read back after the driver's calls: the gait, its parameters, the playing direction.
"""

import pytest
from srs_testing import ros_args

from srs_ros.core.navigation import GaitCommand
from srs_ros.ros.gait_driver import GaitDriver


def drive_until_playing(ros_client, driver, command, timeout_s=30.0):
    driver.drive(command)

    def applied():
        driver.pump()
        return driver.playing and not driver.busy and driver.wanted == command and not driver.error

    ros_client.spin_until(applied, timeout_s, f"{command.direction} applied and playing ({driver.error or 'no error'})")


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
