"""The serpentine as a turn on the spot (issue 20): how far its steady turning c turns the resting body, and which way.

For each physics the simulated robot lies still for 0.5 s, then plays ``--rolled-cycles`` of a rolling gait
(4 bar 1 Hz, inward or outward) stopped at each stop phase of the navigator (or nothing: straight from the start
pose); then ``--cycles`` of the serpentine with ``c_rad_per_unit`` = ``--c`` at 4 bar 1 Hz, stopped at phase 0.
Every stop is the gait player's ramp-out (one cycle at most) plus 2.5 s to rest; everything goes through the gait
player's logic (soft start, stop at a phase). It prints the tail's roll about its own axis before the serpentine
(deg; a rolling body at rest lies about its axis as the gait phase at its stop left it, and the serpentine's wave
bends in that plane), the yaw the serpentine turned (deg, counter-clockwise positive) and how far it moved the
tracked point along the body's axis (toward the head) and across it (to the left), in cm.

Run from the repository's root: python benchmarks/bench_serpentine_turn.py [--physics default anisotropic
calibrated] [--c 0.2] [--cycles 3] [--rolled-cycles 2]
"""

import argparse
import math

import numpy as np
from bench_fine_gait import config_for

from srs_ros.core.actuation.pressure import lengths_to_pressures_bar
from srs_ros.core.gait.playback import GaitPlayback
from srs_ros.core.gait.trajectory import generate_cycle
from srs_ros.core.navigation.settings import STOP_PHASES
from srs_ros.core.robot import default_robot
from srs_ros.sim.world import SimWorld

STEP_S = 0.01
#: Rest after each ramp-out (s).
REST_S = 2.5


class Rig:
    """A fresh simulated robot and the gait player's logic, stepped together."""

    def __init__(self, config, robot):
        self.robot, self.world = robot, SimWorld(config, robot)
        self.player = GaitPlayback(max_length_m=robot.max_extension_m)

    def run(self, seconds: float) -> None:
        end_s = self.world.time_s + seconds
        while self.world.time_s < end_s - 1e-9:
            self.world.advance_to(self.world.time_s + STEP_S)
            rest = np.zeros(self.robot.joint_count)
            lengths = self.player.step(STEP_S).positions_m if self.player.has_cycle else rest
            self.world.command_pressures(lengths_to_pressures_bar(lengths, self.robot))

    def play(self, cycle, cycles: float, stop_phase: float, reverse: bool = False) -> None:
        """``cycles`` of ``cycle`` from rest, then stopped at ``stop_phase`` and left to rest."""
        period_s = 1.0 / cycle.frequency_hz
        self.player.load(cycle.lengths_m, cycle.frequency_hz)
        self.player.set_reverse(reverse)
        self.player.start()
        self.run(cycles * period_s)
        self.player.stop_at_phase(stop_phase)
        self.run(period_s + REST_S)


def tail_roll_deg(state) -> float:
    """The tail segment's roll about its own axis: the angle of world up in its cross-section (deg)."""
    w, x, y, z = state.base_quaternion_wxyz
    return math.degrees(math.atan2(2 * (x * z - w * y), 2 * (y * z + w * x)))


def serpentine_turn(config, robot, cycles_played: tuple, before: str | None, stop_phase: float) -> tuple:
    """(tail roll deg, yaw turned deg, moved along, across cm) of the serpentine after ``before`` (None: no roll).

    ``cycles_played``: (the serpentine's cycle, its cycles, the rolling cycle, its cycles before).
    """
    serpentine, cycles, rolling, rolled_cycles = cycles_played
    rig = Rig(config, robot)
    rig.run(0.5)
    if before is not None:
        rig.play(rolling, rolled_cycles, stop_phase, reverse=before == "outward_rolling")
    state = rig.world.state(with_contacts=False)
    (x0, y0, yaw0), roll = state.pose, tail_roll_deg(state)
    rig.play(serpentine, cycles, 0.0)
    x1, y1, yaw1 = rig.world.state(with_contacts=False).pose
    dx, dy = x1 - x0, y1 - y0
    along, across = dx * math.cos(yaw0) + dy * math.sin(yaw0), -dx * math.sin(yaw0) + dy * math.cos(yaw0)
    return roll, math.degrees(math.remainder(yaw1 - yaw0, 2 * math.pi)), 100 * along, 100 * across


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--physics", nargs="+", default=["default", "anisotropic", "calibrated"],
                        choices=["default", "anisotropic", "calibrated"])
    parser.add_argument("--c", type=float, default=0.2, help="the serpentine's c_rad_per_unit (rad per curve unit)")
    parser.add_argument("--cycles", type=float, default=3.0, help="cycles of the serpentine (at 1 Hz)")
    parser.add_argument("--rolled-cycles", type=float, default=2.0, help="cycles of rolling before it (at 1 Hz)")
    args = parser.parse_args()
    robot = default_robot()
    played = (generate_cycle("serpentine", 4.0, 1.0, 100, robot, {"c_rad_per_unit": args.c}), args.cycles,
              generate_cycle("inward_rolling", 4.0, 1.0, 100, robot, {"turn_phase_rad": 0.0}), args.rolled_cycles)
    print(f"| physics | rolled before (stopped at phase) | tail roll (deg) | turn, c = {args.c:+g} (deg) "
          "| moved along / across the axis (cm) |")
    print("| --- | --- | --- | --- | --- |")
    for physics in args.physics:
        config = config_for(physics, robot)
        cases = [(None, 0.0)] + [(d, p) for d in ("inward_rolling", "outward_rolling") for p in STOP_PHASES]
        for before, phase in cases:
            roll, turn, along, across = serpentine_turn(config, robot, played, before, phase)
            what = "nothing (straight from the start)" if before is None else f"{before.split('_')[0]} ({phase:g})"
            print(f"| {physics} | {what} | {roll:+.0f} | {turn:+.1f} | {along:+.1f} / {across:+.1f} |", flush=True)


if __name__ == "__main__":
    main()
