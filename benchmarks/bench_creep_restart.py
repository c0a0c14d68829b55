"""The navigator's creep started again from rest: does its first stroke go the way it was sent? (issue 20)

For each physics and each way of choosing the start phase, the creep (the navigator's ``fine_amplitude_bar`` and
``fine_frequency_hz``, inward rolling; outward = played backward) rolls 8.1 s from a straight body one way, is
stopped at each of the 4 stop phases (gait_player's ramp-out), rests 3 s, and is started again either way: 16
restarts. It prints per restart the gain along the new travel (square to the resting body: inward to its left)
at 3, 4, 6 and 8 s and the worst dip before, and per physics and start how many restarts were behind their start
3 s later. Start phases: ``zero`` (what gait_player does), ``resume`` (where the ramp-out ended), ``rolled`` (the
stop phase plus the roll-on after the stop in cycles of the last cycle's travel).

Run: python benchmarks/bench_creep_restart.py [--physics calibrated default] [--start zero resume rolled]
(about 1.5 min per physics and start on one core)
"""

import argparse
import math

import numpy as np
from bench_fine_gait import config_for

from srs_ros.core.actuation.pressure import lengths_to_pressures_bar
from srs_ros.core.gait.playback import GaitPlayback, PlaybackState
from srs_ros.core.navigation import load_navigation_settings
from srs_ros.core.navigation.settings import STOP_PHASES
from srs_ros.core.rig import load_rig
from srs_ros.core.robot import default_robot
from srs_ros.experiments.turning import rolling_cycle
from srs_ros.sim.world import SimWorld

RUN_S, REST_S, WATCH_S = 8.1, 3.0, 8.0  # 8.1 s: a stop at phase 0 is then well ahead, not at the phase itself
REPORT_S = (3.0, 4.0, 6.0, 8.0)


class Rig:
    """The simulated world and the playback, stepped together at the command rate."""

    def __init__(self, config, robot, cycle):
        self.world, self.robot = SimWorld(config, robot), robot
        self.playback = GaitPlayback(max_length_m=robot.max_extension_m)
        self.playback.load(cycle.lengths_m, cycle.frequency_hz)
        self.dt_s, self.t_s = 1.0 / load_rig(robot=robot).command_rate_hz, 0.0

    def step(self) -> np.ndarray:
        """One command period; the reference point's (x, y, yaw) after it."""
        self.t_s += self.dt_s
        self.world.advance_to(self.t_s)
        self.world.command_pressures(lengths_to_pressures_bar(self.playback.step(self.dt_s).positions_m, self.robot))
        return np.asarray(self.world.state(with_contacts=False).pose, dtype=float)


def stop_and_rest(rig: Rig, first_reverse: bool, stop_phase: float) -> tuple[float, float]:
    """Roll, stop at ``stop_phase``, rest: (where the ramp-out ended, the 'rolled' start phase)."""
    rig.playback.set_reverse(first_reverse)
    rig.playback.start()
    track = [rig.step() for _ in range(round(RUN_S / rig.dt_s))]
    rig.playback.stop_at_phase(stop_phase)
    while rig.playback.state is PlaybackState.RUNNING:
        track.append(rig.step())
    # abs: played backward (outward first) the frequency is negative, and this took the point at 4 s (a review)
    at, cycle_ago = track[-1], track[-1 - round(1.0 / (abs(rig.playback.frequency_hz) * rig.dt_s))]
    while rig.playback.state is not PlaybackState.IDLE:
        rig.step()
    ended = rig.playback.phase
    for _ in range(round(REST_S / rig.dt_s)):
        rest = rig.step()
    travel = at[:2] - cycle_ago[:2]
    per_cycle_m = max(float(np.linalg.norm(travel)), 1e-6)
    rolled_m = float(np.dot(rest[:2] - at[:2], travel / per_cycle_m))
    return ended, (stop_phase + (-1.0 if first_reverse else 1.0) * rolled_m / per_cycle_m) % 1.0


def restart(config, robot, cycle, first_reverse: bool, stop_phase: float, then_reverse: bool, start: str):
    """One restart: ({seconds: gain m}, worst dip m) along the new travel."""
    rig = Rig(config, robot, cycle)
    ended, rolled = stop_and_rest(rig, first_reverse, stop_phase)
    x0, y0, yaw0 = rig.world.state(with_contacts=False).pose
    rig.playback.set_reverse(then_reverse)
    rig.playback.start(phase={"zero": 0.0, "resume": ended, "rolled": rolled}[start])
    heading = yaw0 + (-math.pi / 2 if then_reverse else math.pi / 2)
    gains, worst, t0 = {}, 0.0, rig.t_s
    while rig.t_s - t0 < WATCH_S - 1e-9:
        x, y, _ = rig.step()
        gain = (x - x0) * math.cos(heading) + (y - y0) * math.sin(heading)
        worst = min(worst, gain)
        gains.update({s: gain for s in REPORT_S if s not in gains and rig.t_s - t0 >= s - 1e-9})
    return gains, worst


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--physics", nargs="+", default=["calibrated", "default"],
                        choices=("default", "anisotropic", "calibrated"))
    parser.add_argument("--start", nargs="+", default=["zero", "resume"], choices=("zero", "resume", "rolled"))
    args = parser.parse_args()
    robot, settings = default_robot(), load_navigation_settings()
    cycle = rolling_cycle(settings.fine_amplitude_bar, settings.fine_frequency_hz, 0.0, robot)
    for physics in args.physics:
        config = config_for(physics, robot)
        for start in args.start:
            rows = []
            for first in (False, True):
                for phase in STOP_PHASES:
                    for then in (False, True):
                        gains, worst = restart(config, robot, cycle, first, float(phase), then, start)
                        rows.append((gains[REPORT_S[0]], gains[REPORT_S[-1]], worst))
                        print(f"{physics} {start}: {'outward' if first else 'inward '} stopped at {phase:.2f}, then "
                              f"{'outward' if then else 'inward '}: gain (cm) " +
                              " ".join(f"{s:g} s {100 * g:+5.1f}" for s, g in gains.items()) +
                              f"; worst {100 * worst:+5.1f}", flush=True)
            a = 100 * np.array(rows)
            print(f"{physics} {start}: behind the start at 3 s in {int((a[:, 0] < 0).sum())} of {len(a)}; worst dip "
                  f"{a[:, 2].min():+.1f} cm; gain at 8 s median {np.median(a[:, 1]):+.1f} cm (least "
                  f"{a[:, 1].min():+.1f})\n", flush=True)


if __name__ == "__main__":
    main()
