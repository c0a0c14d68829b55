"""Closed-loop navigation on the simulated robot: success rate, final error, time, path length over straight distance.

Goals are drawn at random (seeded) 0.4-1.0 m from the start inside the simulated camera's view (less the
navigator's view_margin_m), each driven from the start pose. Two modes, one controller
(:class:`srs_ros.core.navigation.NavigationController`):

- offline (default): :func:`srs_ros.sim.navigation.run_navigation`, no ROS, simulated time (``--camera``: the
  pose from the rendered image through the tracker, else from the simulator's reference point);
- ``--ros``: every node a process of its own over DDS in real time (sim_world, camera_tracker, hardware_node,
  trajectory_server, gait_player, navigator; :class:`srs_testing.navigation.NavigationSystem`), the pose from
  pixels, goals on ``goal_pose`` as RViz sends them. The ground truth is read by the benchmark only.

Per goal: reached (the navigator's state ``reached``), final error (m, the simulator's reference point at rest),
time (s, from the goal to the arrival; for --ros wall time), path length over the straight distance (the
reference point averaged over one gait cycle, so the rolling body's wobble within a cycle is not counted), and
time over the time the gait's straight speed would need (the issue asks for a median of at most 2).

Run: python benchmarks/bench_navigation.py [--goals 10] [--seed 1] [--friction anisotropic] [--camera]
     python benchmarks/bench_navigation.py --ros [--goals 3] [--sim-config FILE]
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from srs_ros.core.navigation import FloorArea, load_navigation_settings
from srs_ros.sim.camera import OverheadCamera
from srs_ros.sim.config import load_sim_config, to_dict, with_friction

#: Longest a goal may take before it counts as failed (s).
GOAL_TIMEOUT_S = 120.0


@dataclass(frozen=True)
class Outcome:
    """One goal: where, reached or not, final error (m), time (s), path length and straight distance (m)."""

    goal_xy_m: tuple[float, float]
    state: str
    final_error_m: float
    time_s: float
    path_m: float
    straight_m: float

    @property
    def reached(self) -> bool:
        return self.state == "reached"


def smoothed_path_length_m(times_s: np.ndarray, xy_m: np.ndarray, window_s: float = 1.0) -> float:
    """Length of the path of ``xy_m`` (n, 2) averaged over ``window_s`` (one gait cycle at 1 Hz)."""
    if len(xy_m) < 2:
        return 0.0
    edges = np.arange(times_s[0], times_s[-1] + window_s, window_s / 4)
    means = [xy_m[(times_s >= t) & (times_s < t + window_s)].mean(axis=0) for t in edges
             if np.any((times_s >= t) & (times_s < t + window_s))]
    points = np.vstack([xy_m[:1], means, xy_m[-1:]])
    return float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))


def gait_speed_m_per_s(settings) -> float:
    """The rolling gaits' straight speed (turning map, turn 0, both directions' mean) at the cruise frequency."""
    travel = np.mean([settings.turning_map[d].travel_at(0.0) for d in ("inward_rolling", "outward_rolling")])
    return float(travel * settings.cruise_frequency_hz)


def sim_config(args):
    config = load_sim_config(args.sim_config or None)
    return with_friction(config, args.friction) if args.friction else config


def goals_for(args, config, settings) -> list[tuple[float, float]]:
    from srs_testing.navigation import random_goals

    area = FloorArea.from_calibration(OverheadCamera(config).calibration, settings.view_margin_m)
    return random_goals(args.goals, args.seed, (config.start.x_m, config.start.y_m), (0.4, 1.0), area)


# ------------------------------------------------------------------------------------------
# offline
# ------------------------------------------------------------------------------------------
def run_offline(args, config, settings, goals) -> list[Outcome]:
    from srs_ros.sim.navigation import run_navigation

    outcomes = []
    for goal in goals:  # each from the start pose (a fresh world)
        result = run_navigation([goal], config, settings, camera=args.camera, goal_timeout_s=GOAL_TIMEOUT_S)
        rows = result.rows
        outcome = result.outcomes[0]
        path = smoothed_path_length_m(rows[:, 0], rows[:, 1:3]) if len(rows) else 0.0
        outcomes.append(Outcome(goal, outcome.state.value, outcome.final_error_m, outcome.time_s, path,
                                outcome.straight_m))
        print("  " + line(outcomes[-1]), flush=True)
    return outcomes


# ------------------------------------------------------------------------------------------
# over DDS
# ------------------------------------------------------------------------------------------
def run_ros(args, config, goals) -> list[Outcome]:
    from srs_testing.navigation import FINAL_STATES, NavigationSystem
    from srs_testing.ros import RosSession

    from srs_ros.ros.interfaces import stamp_to_seconds

    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    folder = Path(tempfile.mkdtemp(prefix="bench_navigation_"))
    sim_file = folder / "sim.yaml"
    sim_file.write_text(yaml.safe_dump({"sim": to_dict(config)}))
    session = RosSession(folder, "bench_navigation")
    outcomes = []
    try:
        system = NavigationSystem(session, {"pose_timeout_s": args.pose_timeout_s}, sim_config_file=str(sim_file))
        for goal in goals:
            start = system.at_rest_at_start()
            first_truth = len(system.truth)
            system.goal(*goal)
            system.wait(lambda g=goal: system.state()["goal_xy_m"] == [float(v) for v in g], 10.0, "the goal taken")
            started_s = time.monotonic()
            try:
                system.wait(lambda: system.state()["state"] in FINAL_STATES, GOAL_TIMEOUT_S, "the goal's end")
            except AssertionError:
                system.client.trigger("/navigator/cancel")
            took_s = time.monotonic() - started_s
            system.wait(system.vented, 10.0, "the vent")
            system.client.spin_for(1.0)
            poses = system.truth[first_truth:]
            times = np.array([stamp_to_seconds(p.header.stamp) for p in poses])
            xy = np.array([[p.pose.position.x, p.pose.position.y] for p in poses])
            outcomes.append(Outcome(goal, system.state()["state"], float(np.linalg.norm(xy[-1] - goal)), took_s,
                                    smoothed_path_length_m(times, xy), float(np.linalg.norm(np.subtract(goal, start)))))
            print("  " + line(outcomes[-1]), flush=True)
    finally:
        session.close()
    return outcomes


# ------------------------------------------------------------------------------------------
# report
# ------------------------------------------------------------------------------------------
def line(o: Outcome) -> str:
    return (f"goal ({o.goal_xy_m[0]:+.3f}, {o.goal_xy_m[1]:+.3f}) m, {o.straight_m:.2f} m away: {o.state:9s} "
            f"error {o.final_error_m * 100:5.1f} cm, {o.time_s:5.1f} s, path {o.path_m:.2f} m "
            f"({o.path_m / max(o.straight_m, 1e-9):.2f}x straight)")


def summary(outcomes: list[Outcome], speed_m_per_s: float, tolerance_m: float) -> str:
    within = [o for o in outcomes if o.reached and o.final_error_m <= tolerance_m]
    reached = [o for o in outcomes if o.reached]
    errors = np.array([o.final_error_m for o in outcomes]) * 100
    ratios = [o.time_s / (o.straight_m / speed_m_per_s) for o in reached]
    paths = [o.path_m / o.straight_m for o in reached]
    times = [o.time_s for o in reached]
    return (f"success (reached, resting within {tolerance_m * 100:g} cm by the ground truth): {len(within)}/"
            f"{len(outcomes)}; final error: median {np.median(errors):.1f} cm, worst "
            f"{np.max(errors):.1f} cm; time of the reached: median {np.median(times or [math.nan]):.1f} s, "
            f"median {np.median(ratios or [math.nan]):.2f}x the straight time at {speed_m_per_s * 100:.1f} cm/s "
            f"(goal <= 2); path over straight distance: median {np.median(paths or [math.nan]):.2f}")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--goals", type=int, default=10, help="number of random goals (default 10)")
    parser.add_argument("--seed", type=int, default=1, help="seed of the goals (default 1)")
    parser.add_argument("--ros", action="store_true", help="every node a process over DDS, in real time")
    parser.add_argument("--camera", action="store_true", help="offline: the pose from the rendered image")
    parser.add_argument("--sim-config", default="",
                        help="simulation YAML (e.g. a calibrated one; default config/sim.yaml)")
    parser.add_argument("--friction", default="", help="floor friction: isotropic, anisotropic, 0.8 or 0.3,0.9")
    parser.add_argument("--pose-timeout-s", type=float, default=3.0,
                        help="--ros: the navigator's pose_timeout_s (default 3: a loaded machine drops frames)")
    args = parser.parse_args(argv)
    settings = load_navigation_settings()
    config = sim_config(args)
    goals = goals_for(args, config, settings)
    mode = "over DDS (separate processes, pose from pixels)" if args.ros else (
        "offline, pose from " + ("pixels" if args.camera else "the simulator's reference point"))
    print(f"navigation benchmark: {len(goals)} goals (seed {args.seed}), {mode}, {config.contact.describe()}"
          f"{', ' + args.sim_config if args.sim_config else ''}; {os.cpu_count()} cores, load "
          f"{os.getloadavg()[0]:.1f}", flush=True)
    started = time.monotonic()
    outcomes = run_ros(args, config, goals) if args.ros else run_offline(args, config, settings, goals)
    print(summary(outcomes, gait_speed_m_per_s(settings), settings.goal_tolerance_m))
    print(f"wall time {time.monotonic() - started:.0f} s")


if __name__ == "__main__":
    main()
