"""The stop oracle of the navigation bound (srs_ros.sim.stop_oracle): a stopped copy rests where the robot rests."""

import numpy as np

from srs_ros.core.navigation.commands import GaitCommand
from srs_ros.core.rig import load_rig
from srs_ros.core.robot import default_robot
from srs_ros.sim.config import load_sim_config
from srs_ros.sim.navigation import GaitDriver
from srs_ros.sim.stop_oracle import REST_S, rest_if_stopped
from srs_ros.sim.world import SimWorld


def test_a_stopped_copy_rests_exactly_where_the_robot_stopped_then_rests_and_the_originals_play_on():
    robot = default_robot()
    world, driver = SimWorld(load_sim_config(robot=robot), robot), GaitDriver(robot)
    driver.apply(GaitCommand("inward_rolling", 0.0, 4.0, 1.0, "cruise"))
    dt_s = 1.0 / load_rig(robot=robot).command_rate_hz
    command_s = 0.0
    while command_s < 2.5:  # the loop's own stepping: a command on the grid, a frame between two
        world.advance_to(command_s)
        world.command_pressures(driver.pressures_bar(dt_s))
        command_s += dt_s
    world.advance_to(command_s - 0.4 * dt_s)
    stopped_xy = world.state(with_contacts=False).reference_xy_m.copy()
    rest = rest_if_stopped(world, driver, command_s, dt_s)
    assert driver.playback.state.value == "running"  # the copy's stop did not touch the original player
    assert np.allclose(world.state(with_contacts=False).reference_xy_m, stopped_xy, atol=0.0)
    driver.playback.stop()
    end_s = world.time_s + REST_S
    while command_s <= end_s:
        world.advance_to(command_s)
        world.command_pressures(driver.pressures_bar(dt_s))
        command_s += dt_s
    world.advance_to(end_s)
    truth = world.state(with_contacts=False).reference_xy_m
    assert np.linalg.norm(truth - stopped_xy) > 0.05  # the body rolls on after the stop: there is something to predict
    assert np.allclose(rest, truth, atol=1e-9, rtol=0.0)
