"""Strokes from rest (issue 20): how far one cycle of a rolling gait, started and stopped at rest, turns the body.

A turn on the spot is made of such strokes, and each starts from rest: the gait player's soft start, one cycle,
the ramp-out, then the body settles. For each physics and each stroke (direction, amplitude, frequency,
turn_phase_rad) the simulated robot plays ``--repeats`` strokes in a row, each through the navigator's own
command path (:class:`srs_ros.sim.navigation.GaitDriver`: a ``GaitCommand``, then a stop at gait phase 0) and
left ``--rest-s`` to settle, and the script prints, over the repeats, the mean and sd of the yaw turned (deg,
counter-clockwise positive) and of the move of the tracked point along the body's axis and across it (cm, across
positive to the body's left, where inward rolling travels on the default physics).

Run: python benchmarks/bench_strokes.py [--physics default calibrated] [--amplitudes 4] [--frequencies 1 0.25]
     [--levels -0.5 0 0.5] [--repeats 6]
"""

import argparse
import math

import numpy as np
from bench_fine_gait import grid

from srs_ros.core.navigation.commands import GaitCommand
from srs_ros.core.robot import default_robot
from srs_ros.sim.navigation import GaitDriver
from srs_ros.sim.world import SimWorld

STEP_S = 0.01


def _run(world: SimWorld, driver: GaitDriver, seconds: float, command: GaitCommand | None = None) -> None:
    end_s = world.time_s + seconds
    while world.time_s < end_s - 1e-9:
        if command is not None:
            driver.apply(command)
        world.advance_to(world.time_s + STEP_S)
        world.command_pressures(driver.pressures_bar(STEP_S))


def strokes(config, robot, direction: str, amplitude_bar: float, frequency_hz: float, level_rad: float,
            repeats: int, rest_s: float) -> np.ndarray:
    """Per stroke: (yaw turned deg, move along the body's axis cm, move across it cm), from rest to rest."""
    world, driver = SimWorld(config, robot), GaitDriver(robot)
    _run(world, driver, 1.0)
    rows = []
    for _ in range(repeats):
        x0, y0, yaw0 = world.state(with_contacts=False).pose
        _run(world, driver, 1.0 / frequency_hz, GaitCommand(direction, level_rad, amplitude_bar, frequency_hz))
        driver.apply(GaitCommand(None, 0.0, amplitude_bar, frequency_hz, stop_phase=0.0))
        _run(world, driver, 1.0 / frequency_hz + rest_s)
        x1, y1, yaw1 = world.state(with_contacts=False).pose
        dx, dy = x1 - x0, y1 - y0
        along = dx * math.cos(yaw0) + dy * math.sin(yaw0)
        across = -dx * math.sin(yaw0) + dy * math.cos(yaw0)
        rows.append((math.degrees(math.remainder(yaw1 - yaw0, 2.0 * math.pi)), 100.0 * along, 100.0 * across))
    return np.array(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--physics", nargs="+", default=["default", "calibrated"],
                        choices=["default", "anisotropic", "calibrated"])
    parser.add_argument("--amplitudes", nargs="+", type=float, default=[4.0])
    parser.add_argument("--frequencies", nargs="+", type=float, default=[1.0, 0.25])
    parser.add_argument("--levels", nargs="+", type=float, default=[-0.5, 0.0, 0.5], help="turn_phase_rad")
    parser.add_argument("--repeats", type=int, default=6)
    parser.add_argument("--rest-s", type=float, default=3.0, help="settling after each stroke's ramp-out (s)")
    args = parser.parse_args()
    robot = default_robot()
    print("| physics | direction | A (bar) | f (Hz) | turn_phase_rad | turn, mean / sd (deg) | along the axis, "
          "mean / sd (cm) | across, mean / sd (cm) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for physics, config, amplitude, frequency in grid(args, robot):
        for direction in ("inward_rolling", "outward_rolling"):
            for level in args.levels:
                rows = strokes(config, robot, direction, amplitude, frequency, level, args.repeats, args.rest_s)
                mean, sd = rows.mean(axis=0), rows.std(axis=0)
                print(f"| {physics} | {direction.split('_')[0]} | {amplitude:g} | {frequency:g} | {level:+g} "
                      f"| {mean[0]:+.1f} / {sd[0]:.1f} | {mean[1]:+.1f} / {sd[1]:.1f} "
                      f"| {mean[2]:+.1f} / {sd[2]:.1f} |", flush=True)


if __name__ == "__main__":
    main()
