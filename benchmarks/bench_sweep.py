"""Benchmark of the offline sweep: wall time of the paper's 48 runs (3 gaits x 4 amplitudes x 4 frequencies, 15 s).

Runs the whole grid on the simulated robot with ``config/sim.yaml`` in ``--workers`` processes (default one
per core), as ``srs_sweep`` does, and prints the wall time, the simulated seconds per wall-clock second, the
CPU time of the workers and the load average at the start (other jobs on the machine stretch the wall time,
not the CPU time). Target: under 2 minutes on the 2-core development machine.

Run: python benchmarks/bench_sweep.py [--duration-s 15] [--workers N]
"""

from __future__ import annotations

import argparse
import os
import time

from srs_testing.cpu import descendants_cpu_s

from srs_ros.experiments.sweep import SweepGrid, default_workers, run_offline_sweep
from srs_ros.experiments.table import paper_table
from srs_ros.sim.config import load_sim_config

TARGET_S = 120.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration-s", type=float, default=paper_table().duration_s)
    parser.add_argument("--workers", type=int, default=default_workers())
    args = parser.parse_args()
    grid = SweepGrid.of_table(paper_table(), args.duration_s)
    config = load_sim_config()
    load, cpu_before_s, cpu_self_s = os.getloadavg()[0], descendants_cpu_s(), time.process_time()
    started = time.perf_counter()
    records = run_offline_sweep(grid, config, args.workers)
    wall_s = time.perf_counter() - started
    failed = [r for r in records if not r.ok]
    simulated_s = len(records) * grid.duration_s
    cpu_s = descendants_cpu_s() - cpu_before_s  # the pool's workers are the forkserver's children
    if args.workers == 1:  # one worker: the runs are made in this process
        cpu_s = time.process_time() - cpu_self_s
    print(f"{len(records)} runs x {grid.duration_s:g} s on {args.workers} workers: {wall_s:.1f} s wall time "
          f"({simulated_s / wall_s:.1f} simulated s per wall s; target < {TARGET_S:g} s: "
          f"{'met' if wall_s < TARGET_S else 'NOT met'}); {len(failed)} failed")
    print(f"worker CPU time {cpu_s:.1f} s ({cpu_s / args.workers:.1f} s per worker); 1-min load average at the "
          f"start {load:.1f} on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
