"""The main job's patrol offline: does the robot stay in the camera's view for round after round? (issue 20)

Drives the simulated robot, pose from the simulated camera, round the main job's patrol (``srs_bringup``'s
waypoints, ``SIM_PATROL_XY_M``) for ``--rounds`` rounds as the navigator patrols them (its progress says
"waypoint 2 of 4 (round 3)"), with the delays of a ROS system on a busy
machine (:class:`~srs_ros.sim.navigation.Latency`: poses 0.06 s and commands 0.03 s late, a 0.3 s stall of the
navigator every 10 s on average, seeded), and prints per seed how the path ended (``reached``: every waypoint;
``pose_lost``: out of the camera's view; ``failed``: no progress for a minute; ``cancelled``: out of time, 20 s
a waypoint summed over the whole patrol (400 s for 4 waypoints and 5 rounds; one waypoint may take longer; a
review)) and how many waypoints were passed. The latency's seed changes the run as DDS timing does: one
seed is one possible run of ``scripts/run.sh``.

Run: python benchmarks/bench_patrol.py [--seed 1 2 3 4 5 6 7 8] [--rounds 5] [--friction isotropic]
"""

import argparse
import time

from srs_ros.nodes.bringup import SIM_PATROL_XY_M
from srs_ros.sim.config import load_sim_config, with_friction
from srs_ros.sim.navigation import Latency, run_navigation

LATENCY_S = (0.06, 0.03)  # pose, command (s)
STALL_EVERY_S, STALL_S = 10.0, 0.3
WAYPOINT_TIMEOUT_S = 20.0


def patrol(seed: int, rounds: int, friction: str) -> tuple[str, float, int]:
    """(how the path ended, when (s), waypoints passed) for one latency seed."""
    passed = [0]

    def count(now_s, controller):
        index, points, round_ = controller.waypoint()
        passed[0] = max(passed[0], (round_ - 1) * points + index)

    config = with_friction(load_sim_config(), friction)
    result = run_navigation(SIM_PATROL_XY_M, config=config, camera=True, as_path=True, rounds=rounds,
                            goal_timeout_s=WAYPOINT_TIMEOUT_S, events=count,
                            latency=Latency(*LATENCY_S, STALL_EVERY_S, STALL_S, seed))
    outcome = result.outcomes[0]
    return outcome.state.value, outcome.time_s, passed[0] + int(outcome.reached)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seed", type=int, nargs="+", default=list(range(1, 9)))
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--friction", default="isotropic", help="isotropic | anisotropic (as srs_sim)")
    args = parser.parse_args()
    total = len(SIM_PATROL_XY_M) * args.rounds
    ended = {}
    for seed in args.seed:
        started = time.perf_counter()
        state, time_s, passed = patrol(seed, args.rounds, args.friction)
        ended[state] = ended.get(state, 0) + 1
        print(f"seed {seed}: {state} after {time_s:.0f} s, {passed} of {total} waypoints "
              f"({time.perf_counter() - started:.0f} s wall)", flush=True)
    print(f"{len(args.seed)} patrols of {total} waypoints, {args.friction} friction: "
          + ", ".join(f"{count} {state}" for state, count in sorted(ended.items())))


if __name__ == "__main__":
    main()
