"""The navigator node over DDS on the simulated robot: success rate, final error, time, path over straight distance.

The ROS counterpart of ``benchmarks/bench_navigation.py`` (the same controller offline): every node a process
of its own in real time (sim_world, camera_tracker on its images, hardware_node on the sim rig,
trajectory_server, gait_player, navigator; :class:`srs_testing.navigation.NavigationSystem`), the pose from
pixels, each goal sent on ``goal_pose`` as RViz sends it, from the start pose (``sim_world/reset`` between
goals; one navigator process, learning throughout). Goals: :func:`srs_ros.sim.navigation.random_goals`
(0.4-1.0 m from the start inside the camera's view, seeded as the offline benchmark's).

Per goal: the navigator's final state, final error (the simulator's reference point at rest, read by the
benchmark only), time (wall s from the goal to the end), path length (the reference point averaged over one
gait cycle, so the rolling body's wobble within a cycle is not counted) over the straight distance; then the
success rate (reached and resting within goal_tolerance_m), and the median time over the time the gait's
straight speed (measured on the same physics) would need (the issue asks for at most 2).

Run: python benchmarks/bench_navigation_ros.py [--goals 3] [--seed 20] [--friction anisotropic]
     [--sim-config FILE] [--pose-timeout-s 3] [--turning-map FILE] [--record DIR]

``--record DIR`` keeps, per goal, what the client saw (``goal_NN.csv``: the tracked pose, the simulator's
truth and the commanded pressures, time-stamped; ``goal_NN_progress.jsonl``: the navigator's progress) and
at the end every process's log, to trace a goal that went wrong; ``run.json`` holds the run's options and the
straight-line speed of its physics (read by ``nav_time_tally.py``).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from srs_ros.core.navigation import load_navigation_settings
from srs_ros.sim.config import load_sim_config, to_dict, with_friction

#: Longest a goal may take before it is cancelled (wall s).
GOAL_TIMEOUT_S = 120.0
#: In a ``--record`` folder: the run's options and the straight-line speed its time ratios are taken at.
RUN_FILE = "run.json"


@dataclass(frozen=True)
class Outcome:
    """One goal: where, the navigator's final state, final error (m), time (s), path and straight distance (m)."""

    goal_xy_m: tuple[float, float]
    state: str
    final_error_m: float
    time_s: float
    path_m: float
    straight_m: float


def smoothed_path_length_m(times_s: np.ndarray, xy_m: np.ndarray, window_s: float = 1.0) -> float:
    """Length of the path of ``xy_m`` (n, 2) averaged over ``window_s`` (one gait cycle at 1 Hz)."""
    if len(xy_m) < 2:
        return 0.0
    starts = np.arange(times_s[0], times_s[-1], window_s / 4)
    means = [xy_m[(times_s >= t) & (times_s < t + window_s)].mean(axis=0) for t in starts
             if np.any((times_s >= t) & (times_s < t + window_s))]
    points = np.vstack([xy_m[:1], *means, xy_m[-1:]]) if means else xy_m[[0, -1]]
    return float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))


def pose_rows(source: str, poses) -> list[str]:
    """CSV rows ``source,t_s,x_m,y_m,yaw_rad`` of PoseStamped messages."""
    from srs_ros.ros.interfaces import stamp_to_seconds

    rows = []
    for p in poses:
        q = p.pose.orientation
        yaw = np.arctan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
        rows.append(f"{source},{stamp_to_seconds(p.header.stamp):.3f},{p.pose.position.x:.4f},"
                    f"{p.pose.position.y:.4f},{yaw:.4f}")
    return rows


def record(folder: Path, index: int, system, marks: dict[str, int]) -> None:
    """Write goal ``index``'s tracked poses, truth, commands (since ``marks``) and progress into ``folder``."""
    rows = ["source,t_s,x_m,y_m,yaw_rad"]
    rows += pose_rows("tracked", system.tracked[marks["tracked"]:])
    rows += pose_rows("truth", system.truth[marks["truth"]:])
    rows += [f"command,{i},{max(m.data):.3f},{min(m.data):.3f},0" for i, m in
             enumerate(system.pressures[marks["pressures"]:])]
    (folder / f"goal_{index:02d}.csv").write_text("\n".join(rows) + "\n")
    (folder / f"goal_{index:02d}_progress.jsonl").write_text(
        "".join(m.data + "\n" for m in system.progress[marks["progress"]:]))


def drive(system, goal, record_dir: Path | None = None, index: int = 0) -> Outcome:
    """One goal from the start pose, to the navigator's end (or cancelled after GOAL_TIMEOUT_S)."""
    from srs_testing.navigation import FINAL_STATES

    from srs_ros.ros.interfaces import stamp_to_seconds

    start = system.at_rest_at_start()
    first_truth = len(system.truth)
    marks = {name: len(getattr(system, name)) for name in ("tracked", "truth", "pressures", "progress")}
    system.goal(*goal)
    system.wait(lambda: system.state()["goal_xy_m"] == [float(v) for v in goal], 10.0, "the goal taken")
    started_s = time.monotonic()
    try:
        system.wait(lambda: system.state()["state"] in FINAL_STATES, GOAL_TIMEOUT_S, "the goal's end")
    except AssertionError:
        system.client.trigger("/navigator/cancel")
    took_s = time.monotonic() - started_s
    system.wait(system.vented, 10.0, "the vent")
    system.client.spin_for(1.0)  # at rest
    poses = system.truth[first_truth:]
    if record_dir is not None:
        record(record_dir, index, system, marks)
    times = np.array([stamp_to_seconds(p.header.stamp) for p in poses])
    xy = np.array([[p.pose.position.x, p.pose.position.y] for p in poses])
    return Outcome(tuple(goal), system.state()["state"], float(np.linalg.norm(xy[-1] - goal)), took_s,
                   smoothed_path_length_m(times, xy), float(np.linalg.norm(np.subtract(goal, start))))


def line(o: Outcome) -> str:
    return (f"goal ({o.goal_xy_m[0]:+.3f}, {o.goal_xy_m[1]:+.3f}) m, {o.straight_m:.2f} m away: {o.state:9s} "
            f"error {o.final_error_m * 100:5.1f} cm, {o.time_s:5.1f} s, path {o.path_m:.2f} m "
            f"({o.path_m / max(o.straight_m, 1e-9):.2f}x straight)")


def summary(outcomes: list[Outcome], speed_m_s: float, tolerance_m: float) -> str:
    reached = [o for o in outcomes if o.state == "reached" and o.final_error_m <= tolerance_m]
    ratios = [o.time_s * speed_m_s / o.straight_m for o in outcomes]
    return (f"{len(reached)} of {len(outcomes)} reached within {tolerance_m * 100:g} cm; final error: median "
            f"{100 * statistics.median(o.final_error_m for o in outcomes):.1f} cm; time: median "
            f"{statistics.median(o.time_s for o in outcomes):.1f} s, time / (straight / {100 * speed_m_s:.1f} cm/s): "
            f"median {statistics.median(ratios):.2f} (target <= 2); path / straight: median "
            f"{statistics.median(o.path_m / o.straight_m for o in outcomes):.2f}")


def main(argv=None) -> None:
    from bench_navigation import gait_speed_m_s  # the same straight speed as the offline benchmark's
    from srs_testing.navigation import NavigationSystem
    from srs_testing.ros import RosSession

    from srs_ros.sim.navigation import random_goals

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--goals", type=int, default=3, help="number of random goals (default 3)")
    parser.add_argument("--seed", type=int, default=20, help="seed of the goals (default 20, as the offline test)")
    parser.add_argument("--sim-config", default="", help="simulation YAML (default config/sim.yaml)")
    parser.add_argument("--friction", default="", help="floor friction: isotropic, anisotropic, 0.8 or 0.3,0.9")
    parser.add_argument("--pose-timeout-s", type=float, default=3.0,
                        help="the navigator's pose_timeout_s (default 3: a loaded machine's tracker drops frames)")
    parser.add_argument("--turning-map", default="",
                        help="the navigator's turning_map_file (e.g. config/turning_map_calibrated_paper.yaml with the "
                             "calibrated physics; default: the navigator's own)")
    parser.add_argument("--record", default="", help="folder for each goal's poses, commands and progress, and "
                                                     "the processes' logs (default: not kept)")
    args = parser.parse_args(argv)
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    settings = load_navigation_settings()
    config = load_sim_config(args.sim_config or None)
    config = with_friction(config, args.friction) if args.friction else config
    goals = random_goals(np.random.default_rng(args.seed), args.goals, config, settings)
    print(f"navigator over DDS: {len(goals)} goals (seed {args.seed}), {config.contact.describe()}"
          f"{', ' + args.sim_config if args.sim_config else ''}; {os.cpu_count()} cores, load "
          f"{os.getloadavg()[0]:.1f}", flush=True)
    started = time.monotonic()
    speed = gait_speed_m_s(config, settings)
    folder = Path(tempfile.mkdtemp(prefix="bench_navigation_ros_"))
    sim_file = folder / "sim.yaml"
    sim_file.write_text(yaml.safe_dump({"sim": to_dict(config)}))
    session = RosSession(folder, "bench_navigation_ros")
    outcomes = []
    try:
        params = {"pose_timeout_s": args.pose_timeout_s}
        if args.turning_map:
            params["turning_map_file"] = str(Path(args.turning_map).resolve())
        system = NavigationSystem(session, params, sim_config_file=str(sim_file))
        record_dir = Path(args.record) if args.record else None
        if record_dir is not None:
            record_dir.mkdir(parents=True, exist_ok=True)
            (record_dir / RUN_FILE).write_text(json.dumps({  # what nav_time_tally.py sets the time against
                "seed": args.seed, "goals": len(goals), "sim_config": args.sim_config, "friction": args.friction,
                "turning_map": args.turning_map, "straight_speed_cm_s": round(100.0 * speed, 3)}) + "\n")
        for index, goal in enumerate(goals):
            outcomes.append(drive(system, goal, record_dir, index))
            print("  " + line(outcomes[-1]), flush=True)
    finally:
        session.close()
        if args.record:
            for process in session.started:
                (Path(args.record) / f"{process.script}.log").write_text(process.output())
    print(summary(outcomes, speed, settings.goal_tolerance_m) if outcomes else "no goal driven")
    print(f"wall time {time.monotonic() - started:.0f} s, load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
