"""Closed-loop navigation on the simulated robot: success rate, resting error, time, path length (issue 20).

For each physics (default isotropic friction, anisotropic friction; ``--sim-config`` for another, e.g. the
calibrated one) it draws random goals 0.4-1.0 m from the start inside the simulated camera's view (seeded),
drives each from the start on a fresh world with one navigator (what it learns is kept, as a running
navigator keeps it) and prints:

- success: goals reached (the controller reports REACHED and the robot rests within goal_tolerance_m);
- resting error (cm) of every goal, reached or not;
- time (s) and time / (straight distance / gait speed), gait speed = the straight rolling speed
  (turn_phase_rad 0, mean of inward and outward) measured on the same physics;
- path length / straight distance (path of the tracked point sampled at 2 Hz).

Targets of the issue: >= 9 of 10 reached within 5 cm, median time <= 2 x straight distance / gait speed.

``--latency POSE_S COMMAND_S`` runs the controller as over DDS on a loaded machine (:class:`Latency`: each
pose reaches it late, stamped with its frame's time and gait phase, each command reaches the gait player late,
and every 10 s on average the navigator stalls for 0.3 s).

Each goal is given up after ``--goal-timeout-s`` (60 s by default, as in every table before stop 53; the
navigator's own ``stall_timeout_s`` ends it sooner when it makes no progress); bench_navigation_ros.py gives
each goal 120 s.

Run: python benchmarks/bench_navigation.py [--goals 10] [--seed 20 [7 3 ...]] [--camera] [--sim-config FILE]
     [--friction isotropic|anisotropic] [--latency 0.1 0.2] [--goal-timeout-s 120] [--set NAME=VALUE]
"""

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

from srs_ros.core.navigation import load_navigation_settings
from srs_ros.core.schema import parse_assignments
from srs_ros.experiments.turning import measure_turn_phase
from srs_ros.sim.config import load_sim_config
from srs_ros.sim.navigation import Latency, random_goals, run_navigation

#: Each goal is given up after this long by default (s): every table before stop 53 used it.
GOAL_TIMEOUT_S = 60.0


def gait_speed_m_s(config, settings=None) -> float:
    """Straight rolling speed (turn_phase_rad 0), mean of both directions, on ``config``, at the navigator's cruise
    amplitude and frequency (``settings``; default 4 bar 1 Hz: a --set amplitude_bar=3 was divided by the 4 bar
    speed, every ratio 22 % low; a review)."""
    amplitude_bar, frequency_hz = (4.0, 1.0) if settings is None else (settings.amplitude_bar,
                                                                      settings.cruise_frequency_hz)
    runs = [m for d in ("inward_rolling", "outward_rolling")
            for m in measure_turn_phase(d, amplitude_bar, frequency_hz, 0.0, config, start_yaws_rad=(0.0,))]
    return statistics.mean(m.speed_m_s for m in runs)


def report(label, config, goals, camera, settings, latency=None,
           goal_timeout_s=GOAL_TIMEOUT_S) -> tuple[int, list[float]]:
    """Drive to ``goals`` and print the figures; returns (goals reached, time ratio of every goal)."""
    started = time.perf_counter()
    speed = gait_speed_m_s(config, settings)
    result = run_navigation(goals, config=config, settings=settings, camera=camera, from_start=True,
                            goal_timeout_s=goal_timeout_s, progress=lambda line: print("   ", line, flush=True),
                            latency=latency)
    outcomes = result.outcomes
    reached = [o for o in outcomes if o.reached and o.final_error_m <= settings.goal_tolerance_m]
    ratios = [o.time_s * speed / o.straight_m for o in outcomes]
    print(f"{label}: {len(reached)} of {len(outcomes)} reached within {100 * settings.goal_tolerance_m:g} cm; "
          f"gait speed {100 * speed:.1f} cm/s")
    print(f"  resting error (cm): median {100 * statistics.median(o.final_error_m for o in outcomes):.1f}, "
          f"reached ones {[round(100 * o.final_error_m, 1) for o in reached]}")
    reached_ratios = [r for r, o in zip(ratios, outcomes) if o in reached]
    reached_ratio = statistics.median(reached_ratios) if reached_ratios else float("nan")
    print(f"  time (s): median {statistics.median(o.time_s for o in outcomes):.1f}; time / (straight / speed): "
          f"median {statistics.median(ratios):.2f} (target <= 2), of the reached ones {reached_ratio:.2f}")
    print(f"  path / straight: median {statistics.median(o.path_length_m / o.straight_m for o in outcomes):.2f}"
          f"; wall {time.perf_counter() - started:.0f} s")
    return len(reached), ratios


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--goals", type=int, default=10)
    parser.add_argument("--seed", type=int, nargs="+", default=[20],
                        help="seed(s) of the goal sets; several: a line per set and the totals per physics")
    parser.add_argument("--camera", action="store_true", help="pose from the simulated camera + tracker")
    parser.add_argument("--sim-config", help="another simulation config (e.g. the calibrated one)")
    parser.add_argument("--friction", choices=("isotropic", "anisotropic"), action="append",
                        help="only this friction (repeatable; default both)")
    parser.add_argument("--latency", type=float, nargs=2, metavar=("POSE_S", "COMMAND_S"),
                        help="poses and commands this late, and a 0.3 s stall every 10 s on average")
    parser.add_argument("--goal-timeout-s", type=float, default=GOAL_TIMEOUT_S,
                        help="each goal is given up after this long (s; default 60, every table before stop 53); "
                        "bench_navigation_ros.py gives 120")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                        help="a navigation setting (e.g. stop_cycle_ahead=false, "
                        "turning_map_file=config/turning_map_calibrated_paper.yaml)")
    args = parser.parse_args()
    if not args.goal_timeout_s > 0.0:
        parser.error(f"--goal-timeout-s {args.goal_timeout_s:g}: expected a time over 0 s, e.g. 60 or 120")
    settings = load_navigation_settings(parse_assignments(args.set, "--set", "stop_cycle_ahead=false"))
    base = load_sim_config(args.sim_config)
    for friction in args.friction or ("isotropic", "anisotropic"):
        config = base.replace("contact", friction=friction)
        reached, ratios = 0, []
        for seed in args.seed:
            latency = Latency(args.latency[0], args.latency[1], 10.0, 0.3, seed=seed) if args.latency else None
            goals = random_goals(np.random.default_rng(seed), args.goals, config, settings)
            late = f", poses {args.latency[0]:g} s and commands {args.latency[1]:g} s late" if latency else ""
            got, seed_ratios = report(f"{Path(base.source).name}: {config.contact.describe()} (seed {seed}, "
                                      f"{'camera' if args.camera else 'simulator pose'}{late})", config, goals,
                                      args.camera, settings, latency, args.goal_timeout_s)
            reached, ratios = reached + got, ratios + seed_ratios
        if len(args.seed) > 1:
            print(f"{config.contact.describe()}, seeds {' '.join(map(str, args.seed))}: {reached} of {len(ratios)} "
                  f"reached; time / (straight / speed): median {statistics.median(ratios):.2f}\n")


if __name__ == "__main__":
    main()
