"""The gait near the deadzone for the navigator's fine approach (issue 20): travel, turn and roll-on after a stop.

For each physics (default isotropic, anisotropic, the calibrated one), amplitude and frequency, the navigator's
rolling cycle (inward rolling, turn_phase_rad 0; outward = played backward) is played from rest through the gait
player's logic (soft start), stopped after 3 cycles at each of 8 gait phases, and left 3 s to rest. It prints the
travel per cycle (the last cycle before the stop), the turn per cycle, and where the robot rested from where the
stop was commanded, along and across its travel (mean, sd and range over the 8 stop phases).

Run: python benchmarks/bench_fine_gait.py [--amplitudes 2 4] [--frequencies 0.25 1] [--physics default calibrated]
"""

import argparse
import math

import numpy as np

from srs_ros.core.robot import config_dir, default_robot
from srs_ros.experiments.turning import rest_after_stop, rolling_cycle
from srs_ros.sim.config import load_sim_config

PHASES = np.arange(8) / 8.0


def config_for(physics: str, robot):
    if physics == "calibrated":
        calibrated = load_sim_config(config_dir() / "sim_calibrated_paper.yaml", robot=robot)
        return calibrated.replace("contact", friction="isotropic")
    friction = "anisotropic" if physics == "anisotropic" else "isotropic"
    return load_sim_config(robot=robot).replace("contact", friction=friction)


def grid(args, robot):
    """(physics, its simulation config, amplitude, frequency) for every cell of the command line's grid."""
    for physics in args.physics:
        config = config_for(physics, robot)
        for frequency in args.frequencies:
            for amplitude in args.amplitudes:
                yield physics, config, amplitude, frequency


def measure(config, robot, amplitude_bar, frequency_hz, reverse):
    cycle, period = rolling_cycle(amplitude_bar, frequency_hz, 0.0, robot), 1.0 / frequency_hz
    rests = [rest_after_stop(cycle, (3 + phase) * period, reverse, 3.0, config, robot) for phase in PHASES]
    offsets = np.array([(r.along_m, r.across_m) for r in rests])
    return offsets, float(np.mean([r.travel_m for r in rests])), float(np.mean([math.degrees(r.turn_rad)
                                                                                 for r in rests]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--amplitudes", type=float, nargs="+", default=[2.0, 4.0])
    parser.add_argument("--frequencies", type=float, nargs="+", default=[0.25, 1.0])
    parser.add_argument("--physics", nargs="+", default=["default", "anisotropic", "calibrated"],
                        choices=("default", "anisotropic", "calibrated"))
    args = parser.parse_args()
    robot = default_robot()
    print("| physics | A (bar) | f (Hz) | direction | travel (cm/cycle) | turn (deg/cycle) | rest along: mean, sd, "
          "range over 8 stop phases (cm) | rest across: mean, sd (cm) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for physics, config, amplitude, frequency in grid(args, robot):
        for reverse in (False, True):
            offsets, travel, turn = measure(config, robot, amplitude, frequency, reverse)
            along, across = 100 * offsets[:, 0], 100 * offsets[:, 1]
            print(f"| {physics} | {amplitude:g} | {frequency:g} | {'outward' if reverse else 'inward'} | "
                  f"{100 * travel:.1f} | {turn:+.1f} | {along.mean():+.1f}, {along.std():.1f}, "
                  f"{np.ptp(along):.1f} | {across.mean():+.1f}, {across.std():.1f} |", flush=True)


if __name__ == "__main__":
    main()
