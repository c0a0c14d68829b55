"""Benchmark (issue item 8): the 500 Hz setpoint stream while other processes load every core.

Runs trajectory_server, gait_player and hardware_node as processes (mock rig, every backend command
recorded) with ``--hogs`` busy-looping Python processes beside them (a `stress`-like CPU load, each
hog in a session of its own so the kernel's autogroups do not shield the nodes from it), once per
``--realtime-priority`` of gait_player and hardware_node (0 = the normal scheduler; > 0 = SCHED_FIFO,
which needs root, CAP_SYS_NICE or an rtprio limit), and prints per run: setpoints published /
delivered / taken / written, vents while playing seen at the backend, the oldest setpoint at arrival
at the hardware node, stale-on-arrival rejections, gaps in the player's stamps, the stamp -> write
latency, and the hardware node's own command stalls. The observer (test/srs_testing/stream_probe.py) runs at the
nodes' priority.

Run: python benchmarks/bench_cpu_load.py [--hogs 0 40] [--realtime-priority 0 50] [--duration-s 60]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys

from srs_testing.stream import Placement, bench_env, run_stream, summary_lines

HOG = "while True: pass"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--hogs", type=int, nargs="+", default=[0, 40], help="busy processes per run")
    parser.add_argument("--realtime-priority", type=int, nargs="+", default=[0, 50],
                        help="realtime_priority of gait_player and hardware_node per run (0 = normal scheduler)")
    parser.add_argument("--duration-s", type=float, default=60.0)
    parser.add_argument("--rate-hz", type=float, default=500.0)
    args = parser.parse_args()
    print(f"{os.cpu_count()} cores; {args.rate_hz:g} Hz for {args.duration_s:g} s per run", flush=True)
    for hogs, priority in [(h, p) for h in args.hogs for p in args.realtime_priority]:
        with bench_env() as env:
            load = [subprocess.Popen([sys.executable, "-c", HOG], start_new_session=True) for _ in range(hogs)]
            try:
                params = {node: {"realtime_priority": priority} for node in ("gait_player", "hardware_node")}
                # the observer at the nodes' priority, so that its own starvation is not counted as loss
                placement = Placement(env, prefixes={"probe": ["chrt", "-f", str(priority)]} if priority else {})
                result = run_stream(placement, args.rate_hz, args.duration_s, params=params)
            finally:
                for hog in load:
                    hog.kill()
                    hog.wait()
        name = f"{hogs} hogs, " + (f"SCHED_FIFO {priority}" if priority else "normal scheduler")
        for line in summary_lines(name, result):
            print(line, flush=True)


if __name__ == "__main__":
    main()
