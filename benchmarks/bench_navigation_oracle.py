"""A bound for issue 20's time target: the navigator's cruise with every stop's resting point known exactly.

:func:`srs_ros.sim.stop_oracle.run_oracle_navigation` drives the benchmark's goals (`bench_navigation.py`'s: 10 per
seed, 0.4-1.0 m from the start, each from the start, 60 s each, the simulator's pose) with the navigator's
controller; while it cruises within 0.45 m of the goal, a copy of the world is stopped every 0.1 s and left to
rest, and the robot is stopped where the copy rests within ``--within-m`` of the goal. Prints per seed the goals
reached within 5 cm, how many by an oracle stop, and the median time ratio (time to the stop plus settle_s, over
straight distance / gait speed), as bench_navigation.py does.

By default the fine approach is off (``--set fine_distance_m=0``): with it on, the cruise stops 15-20 cm short on
the goal's line to creep, before any stop could rest on the goal.

Run: python benchmarks/bench_navigation_oracle.py --seed 1 2 [--friction anisotropic] [--sim-config FILE]
     [--within-m 0.04] [--set NAME=VALUE ...]
"""

import argparse
import statistics

import numpy as np
import yaml
from bench_navigation import gait_speed_m_s

from srs_ros.core.navigation import load_navigation_settings
from srs_ros.sim.config import load_sim_config
from srs_ros.sim.navigation import random_goals
from srs_ros.sim.stop_oracle import run_oracle_navigation


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, nargs="+", default=[1])
    parser.add_argument("--friction", choices=("isotropic", "anisotropic"), default="isotropic")
    parser.add_argument("--sim-config", default=None)
    parser.add_argument("--within-m", type=float, default=0.04)
    parser.add_argument("--set", nargs="*", default=[], metavar="NAME=VALUE",
                        help="navigation settings; fine_distance_m=0 unless given (any --set replaced it; a review)")
    args = parser.parse_args()
    overrides = {"fine_distance_m": 0, **{k: yaml.safe_load(v) for k, v in (item.split("=", 1) for item in args.set)}}
    settings = load_navigation_settings(overrides)
    config = load_sim_config(args.sim_config).replace("contact", friction=args.friction)
    speed = gait_speed_m_s(config, settings)
    ratios, reached, by_oracle, total = [], 0, 0, 0
    for seed in args.seed:
        goals = random_goals(np.random.default_rng(seed), 10, config, settings)
        results = run_oracle_navigation(goals, config, settings, args.within_m)
        seed_ratios = [r.outcome.time_s * speed / r.outcome.straight_m for r in results]
        ok = [r for r in results if r.outcome.reached and r.outcome.final_error_m <= settings.goal_tolerance_m]
        print(f"seed {seed}: {len(ok)} of {len(results)} within {100 * settings.goal_tolerance_m:g} cm "
              f"({sum(r.oracle_stop for r in ok)} by an oracle stop); time ratio median "
              f"{statistics.median(seed_ratios):.2f}; errors (cm) "
              f"{' '.join(f'{100 * r.outcome.final_error_m:.1f}' for r in results)}", flush=True)
        ratios += seed_ratios
        reached, by_oracle, total = reached + len(ok), by_oracle + sum(r.oracle_stop for r in ok), total + len(results)
    print(f"{config.contact.describe()}, seeds {' '.join(map(str, args.seed))}: {reached} of {total} reached "
          f"({by_oracle} by an oracle stop); time / (straight / speed): median {statistics.median(ratios):.2f} "
          f"(gait speed {100 * speed:.1f} cm/s; settings {overrides})")


if __name__ == "__main__":
    main()
