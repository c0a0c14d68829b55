"""The simulated loop under CPU load: does the simulated rig keep running when the machine is busy?

Starts the launch layout as separate processes (sim_world with its camera at 30 fps, hardware_node on the sim
rig, trajectory_server, gait_player playing inward rolling 4 bar 1 Hz, camera_tracker) and, for each count of
busy processes beside it (default 0, 2, 4: busy-looping Python processes, as a compile), measures over the
window: sim_world's world rate and the wall time it slipped behind the steady clock, the hardware node's
command rate, its holds (sim_world silent > 0.2 s: 0 bar, then a ramp back), stale-setpoint vents and faults,
the board's own vents, and the ground-truth travel speed.

Run: python benchmarks/bench_sim_load.py [--busy 0 2 4] [--duration-s 30]
"""

import argparse
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from srs_testing import RosClient, RosSession, launch_sim_loop
from std_msgs.msg import Float64MultiArray

from srs_ros.ros.interfaces import diagnostic_values

COUNTERS = ("holds", "stale_vents", "recoveries")


def latest(diagnostics: list, prefix: str) -> dict:
    for msg in reversed(diagnostics):
        for status in msg.status:
            if status.name.startswith(prefix):
                return diagnostic_values(status) | {"_level": int.from_bytes(status.level, "little")}
    return {}


def measure(client: RosClient, busy: int, duration_s: float, streams: dict) -> str:
    diagnostics, truth, commands = streams["diagnostics"], streams["truth"], streams["commands"]
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(busy)]
    try:
        client.spin_for(2.0)  # let the load settle
        world0, hw0 = latest(diagnostics, "sim_world"), latest(diagnostics, "hardware_node")
        n_truth, n_commands, n_diag, start_s = len(truth), len(commands), len(diagnostics), time.monotonic()
        client.spin_for(duration_s)
        span_s = time.monotonic() - start_s
        world1, hw1 = latest(diagnostics, "sim_world"), latest(diagnostics, "hardware_node")
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()
    faults = sum(1 for m in diagnostics[n_diag:] for s in m.status
                 if s.name.startswith("hardware_node") and s.level == 2)
    world_rate = (float(world1["world_time_s"]) - float(world0["world_time_s"])) / span_s
    slipped_s = float(world1["slipped_s"]) - float(world0["slipped_s"])
    window = truth[n_truth:]
    a, b = window[0].pose.position, window[-1].pose.position
    speed = 100 * np.hypot(b.x - a.x, b.y - a.y) / span_s
    counts = {k: int(hw1.get(k, 0)) - int(hw0.get(k, 0)) for k in COUNTERS}
    board_vents = int(world1["silence_vents"]) - int(world0["silence_vents"])
    return (f"{busy:4d} | {world_rate:6.3f} | {slipped_s:7.2f} | {(len(commands) - n_commands) / span_s:7.1f} | "
            f"{counts['holds']:5d} | {counts['stale_vents']:5d} | {board_vents:5d} | {faults:6d} | "
            f"{counts['recoveries']:5d} | {speed:5.1f}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--busy", type=int, nargs="+", default=[0, 2, 4], help="busy processes per window")
    parser.add_argument("--duration-s", type=float, default=30.0, help="measuring window per count, s")
    args = parser.parse_args()
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    with RosSession(tempfile.mkdtemp(prefix="bench_sim_load_")) as session:  # stops every process, pass or fail
        launch_sim_loop(session.launch)
        client = session.client
        streams = {"diagnostics": client.subscribe(DiagnosticArray, "/diagnostics"),
                   "truth": client.subscribe(PoseStamped, "sim/ground_truth_pose"),
                   "commands": client.subscribe(Float64MultiArray, "commanded_pressure_bar")}
        client.spin_until(lambda: len(streams["truth"]) > 100 and latest(streams["diagnostics"], "sim_world")
                          and latest(streams["diagnostics"], "hardware_node"), 60.0, "the loop running")
        print(f"simulated loop under load, {args.duration_s:g} s per row, {os.cpu_count()} cores "
              "(world rate: world s per wall s; slipped: wall s the world did not follow)")
        print("busy | world  | slipped | cmd/s   | holds | stale | board | faults | recov | cm/s")
        for busy in args.busy:
            print(measure(client, busy, args.duration_s, streams), flush=True)


if __name__ == "__main__":
    main()
