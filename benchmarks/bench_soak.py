"""Soak benchmark: N minutes of the 500 Hz setpoint stream through the three nodes as processes.

trajectory_server -> gait_player (500 Hz) -> hardware_node (mock rig, 200 Hz commands, every command
the backend is given recorded to a file), watched by test/srs_testing/stream_probe.py. Prints RSS and CPU of
each process (start, end, largest), setpoints published vs delivered vs accepted vs written to the
backend, vents while playing seen at the backend, the oldest setpoint at arrival and the stamp -> write
latency (p50, worst per-second p99, max).

Run: python benchmarks/bench_soak.py [--minutes 10] [--rate-hz 500]
"""

from __future__ import annotations

import argparse

import numpy as np
from srs_testing.stream import Placement, bench_env, run_stream, summary_lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--rate-hz", type=float, default=500.0)
    args = parser.parse_args()
    with bench_env() as env:
        result = run_stream(Placement(env), args.rate_hz, 60.0 * args.minutes, sample_period_s=5.0)
    for line in summary_lines(f"soak {args.minutes:g} min at {args.rate_hz:g} Hz", result):
        print(line)
    ages = np.array(result["series"]["setpoint_arrival_age_max_ms"])
    print(f"per-second oldest setpoint at arrival: median {np.median(ages):.1f} ms, seconds over 50 ms "
          f"{int(np.sum(ages > 50))}, over 100 ms {int(np.sum(ages > 100))}, over the 200 ms timeout "
          f"{int(np.sum(ages > 200))} (logs: {result['log_dir']})")


if __name__ == "__main__":
    main()
