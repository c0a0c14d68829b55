"""Benchmark of the offline runs on Dask: the paper's sweep and a calibration, local pool vs a Dask cluster.

Runs the paper's 48-run sweep (3 gaits x 4 amplitudes x 4 frequencies, 15 s, ``config/sim.yaml``) on
``--workers`` local processes (``srs_sweep``'s local pool) and on a Dask cluster of as many worker
processes (a ``distributed.LocalCluster`` started here, one thread per worker, or a running cluster with
``--scheduler tcp://HOST:8786``), checks that both give identical records and prints each wall time with
the 1-minute load average at its start (on a shared machine other jobs stretch the wall time). Then the
same for a calibration to the paper's Table I (``srs_sweep --calibrate``) with ``--max-evaluations``
evaluations: 6 by default instead of the command's 40, so that both together stay near 10 minutes on 2
cores (the full calibration takes about 27 min wall per backend); ``--no-calibration`` skips it.
The local pool's time includes starting its processes; the cluster's start is printed apart.

Run: python benchmarks/bench_cluster.py [--workers 2] [--duration-s 15] [--max-evaluations 6]
     [--no-calibration] [--scheduler tcp://HOST:8786]
"""

from __future__ import annotations

import argparse
import os
import time
from contextlib import contextmanager

import numpy as np
from distributed import LocalCluster

from srs_ros.experiments.calibration import calibrate
from srs_ros.experiments.cluster import runner_for
from srs_ros.experiments.sweep import OfflineRunner, SweepGrid
from srs_ros.experiments.table import paper_table
from srs_ros.sim.config import load_sim_config


def _timed(work):
    """``work()``, its wall time (s) and the 1-minute load average at its start."""
    load = os.getloadavg()[0]
    started = time.perf_counter()
    result = work()
    return result, time.perf_counter() - started, load


@contextmanager
def _dask_runner(args):
    """A runner on the cluster of ``--scheduler``, or on a LocalCluster of ``--workers`` processes; its start time."""
    started = time.perf_counter()
    if args.scheduler:
        with runner_for(args.scheduler, args.workers) as runner:
            yield runner, time.perf_counter() - started
        return
    with LocalCluster(n_workers=args.workers, processes=True, threads_per_worker=1, dashboard_address=":0") as cluster:
        with runner_for(cluster.scheduler_address, args.workers) as runner:
            yield runner, time.perf_counter() - started


def _same_records(a, b) -> bool:
    return a == b and all((x.track is None and y.track is None) or np.array_equal(x.track, y.track)
                          for x, y in zip(a, b))


def _sweeps(args, config) -> None:
    grid = SweepGrid.of_table(paper_table(), args.duration_s)
    with OfflineRunner(args.workers) as local:
        records, local_s, local_load = _timed(lambda: local.run(grid.cells(), grid.duration_s, config))
    with _dask_runner(args) as (runner, start_s):
        remote, dask_s, dask_load = _timed(lambda: runner.run(grid.cells(), grid.duration_s, config))
        where = runner.describe()
    print(f"sweep, {len(grid)} runs x {grid.duration_s:g} s:")
    print(f"  local pool, {args.workers} workers: {local_s:.1f} s wall (load average {local_load:.1f} at the start)")
    print(f"  {where}: {dask_s:.1f} s wall (load average {dask_load:.1f}; the cluster's start, {start_s:.1f} s, "
          "not counted)")
    print(f"  records identical: {'yes' if _same_records(records, remote) else 'NO'}; "
          f"{sum(not r.ok for r in remote)} failed")


def _calibrations(args, config) -> None:
    reference = paper_table()

    def fit(runner):
        return calibrate(reference, config, max_evaluations=args.max_evaluations, runner=runner)

    with OfflineRunner(args.workers) as local:
        result, local_s, local_load = _timed(lambda: fit(local))
    with _dask_runner(args) as (runner, _start_s):
        remote, dask_s, dask_load = _timed(lambda: fit(runner))
        where = runner.describe()
    same = (result.fitted_values == remote.fitted_values and _same_records(result.before, remote.before)
            and _same_records(result.after, remote.after)
            and [e.error for e in result.history] == [e.error for e in remote.history])
    print(f"calibration to {reference.name}: {len(result.history)} evaluations (--max-evaluations "
          f"{args.max_evaluations}; srs_sweep's default is 40) of {len(result.fit_cells)} cells x "
          f"{result.fit_duration_s:g} s, before and after {len(reference.cells)} x {reference.duration_s:g} s:")
    print(f"  local pool, {args.workers} workers: {local_s:.1f} s wall (load average {local_load:.1f} at the start)")
    print(f"  {where}: {dask_s:.1f} s wall (load average {dask_load:.1f} at the start)")
    print(f"  fitted values, every evaluation's error and the records before and after identical: "
          f"{'yes' if same else 'NO'} (RMS log error {result.error_before:.4f} -> {result.error_after:.4f})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2, help="local processes and Dask workers (default 2)")
    parser.add_argument("--duration-s", type=float, default=paper_table().duration_s)
    parser.add_argument("--max-evaluations", type=int, default=6)
    parser.add_argument("--no-calibration", action="store_true")
    parser.add_argument("--scheduler", help="a running Dask cluster (default: a LocalCluster started here)")
    args = parser.parse_args()
    config = load_sim_config()
    print(f"{os.cpu_count()} cores; 1-minute load average {os.getloadavg()[0]:.1f} at the start; the machine is "
          "shared, so the wall times are noisy")
    _sweeps(args, config)
    if not args.no_calibration:
        _calibrations(args, config)


if __name__ == "__main__":
    main()
