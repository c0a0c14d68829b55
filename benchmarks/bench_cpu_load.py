"""Benchmark (issue item 8): the 500 Hz setpoint stream while other processes load every core.

Runs trajectory_server, gait_player and hardware_node as processes (mock rig, every backend command
recorded) with ``--hogs`` busy-looping Python processes beside them (a `stress`-like CPU load), and
prints per load: setpoints published / delivered / written, vents while playing seen at the backend,
the oldest setpoint at arrival at the hardware node, stale-on-arrival rejections, gaps in the
player's stamps and the stamp -> write latency.

Run: python benchmarks/bench_cpu_load.py [--hogs 0 4] [--duration-s 120] [--rate-hz 500]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test"))
from srs_stream import Placement, run_stream, summary_lines  # noqa: E402
from srs_testing import allocate_domain, fastdds_shm_clean, release_domain  # noqa: E402

HOG = "while True: pass"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--hogs", type=int, nargs="+", default=[0, 4], help="busy processes per run")
    parser.add_argument("--duration-s", type=float, default=120.0)
    parser.add_argument("--rate-hz", type=float, default=500.0)
    args = parser.parse_args()
    print(f"{os.cpu_count()} cores; {args.rate_hz:g} Hz for {args.duration_s:g} s per run", flush=True)
    for hogs in args.hogs:
        domain = allocate_domain()
        env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
                   ROS_LOG_DIR=os.environ.get("ROS_LOG_DIR", "/tmp/srs_bench_logs"), PYTHONUNBUFFERED="1")
        os.environ.update({k: env[k] for k in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_LOG_DIR")})
        load = [subprocess.Popen([sys.executable, "-c", HOG], start_new_session=True) for _ in range(hogs)]
        try:
            result = run_stream(Placement(env), args.rate_hz, args.duration_s)
        finally:
            for hog in load:
                hog.kill()
                hog.wait()
            release_domain(domain)
            fastdds_shm_clean()
        for line in summary_lines(f"{hogs} hogs", result):
            print(line, flush=True)


if __name__ == "__main__":
    main()
