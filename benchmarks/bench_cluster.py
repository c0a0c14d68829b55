"""Benchmark of the offline runs on Dask: the paper's sweep and a calibration, local pool vs a Dask cluster.

Runs the paper's 48-run sweep (3 gaits x 4 amplitudes x 4 frequencies, 15 s, ``config/sim.yaml``) on
``--workers`` local processes (``srs_sweep``'s local pool) and on a ``distributed.LocalCluster`` of as many
worker processes, one thread each, twice: as docs/cluster.md starts workers (``MALLOC_TRIM_THRESHOLD_``
unset) and with Dask's default worker environment (it sets that variable to 65536, which costs page
faults); or once on a running cluster with ``--scheduler tcp://HOST:8786``. It checks that every backend
gives identical records and prints each wall time with the 1-minute load average at its start (the machine
is shared: other jobs stretch the wall time) and the CPU time of the worker processes (less sensitive to
other jobs; it includes starting the processes and importing srs_ros, about 2 s each; not measurable for
a running cluster). Then a calibration to the paper's Table I (``srs_sweep --calibrate``: its 8 s search
runs, before and after 48 x 15 s) on the local pool and the cluster, with ``--max-evaluations`` evaluations:
4 by default instead of the command's 40, so that it stays near 5 minutes per backend on 2 idle cores (the
full one takes about 25 min wall per backend); ``--no-calibration`` skips it. The local pool's wall time
includes starting its processes; the cluster's start is printed apart.

Run: python benchmarks/bench_cluster.py [--workers 2] [--duration-s 15] [--max-evaluations 4]
     [--no-calibration] [--scheduler tcp://HOST:8786]
"""

from __future__ import annotations

import argparse
import os
import time
from contextlib import contextmanager

import dask
import numpy as np
from distributed import LocalCluster
from srs_testing.cpu import descendants_cpu_s

from srs_ros.experiments.calibration import calibrate
from srs_ros.experiments.cluster import WORKER_DASK_CONFIG, runner_for
from srs_ros.experiments.sweep import OfflineRunner, SweepGrid
from srs_ros.experiments.table import paper_table
from srs_ros.sim.config import load_sim_config
from srs_ros.tools.sweep_cli import DEFAULT_FIT_DURATION_S


def _children_cpu_s() -> float:
    """CPU time of this process's descendants: the local pool's workers (children of its forkserver, which
    ``RUSAGE_CHILDREN`` never counted: 0 s), a LocalCluster's."""
    return descendants_cpu_s()


@contextmanager
def _local(args):
    yield OfflineRunner(args.workers), 0.0


@contextmanager
def _dask(args, tuned: bool = True):
    """A runner on ``--scheduler``, or on a LocalCluster of ``--workers`` processes; the time to start it."""
    started = time.perf_counter()
    if args.scheduler:
        with runner_for(args.scheduler, args.workers) as runner:
            yield runner, time.perf_counter() - started
        return
    with dask.config.set(WORKER_DASK_CONFIG if tuned else {}):
        cluster = LocalCluster(n_workers=args.workers, processes=True, threads_per_worker=1, dashboard_address=":0")
    with cluster, runner_for(cluster.scheduler_address, args.workers, log=lambda _text: None) as runner:
        yield runner, time.perf_counter() - started


def _measure(backend, work, label: str, remote: bool):
    """``work(runner)`` on ``backend``; its result and a line with the wall and CPU times and the load."""
    load, cpu_s = os.getloadavg()[0], _children_cpu_s()
    with backend as (runner, start_s):
        started = time.perf_counter()
        result = work(runner)
        wall_s = time.perf_counter() - started
        where = runner.describe()
        runner.close()
    cpu = "n/a (workers elsewhere)" if remote else f"{_children_cpu_s() - cpu_s:.0f} s"
    start = f"; its start, {start_s:.1f} s, not counted" if start_s else ""
    return result, f"  {label or where}: {wall_s:.1f} s wall, worker CPU {cpu} (load average {load:.1f}{start})"


def _same_records(a, b) -> bool:
    return a == b and all((x.track is None and y.track is None) or np.array_equal(x.track, y.track)
                          for x, y in zip(a, b))


def _sweeps(args, config) -> None:
    grid = SweepGrid.of_table(paper_table(), args.duration_s)

    def sweep(runner):
        return runner.run(grid.cells(), grid.duration_s, config)

    local, line = _measure(_local(args), sweep, f"local pool, {args.workers} workers", False)
    lines, same = [line], []
    backends = [(_dask(args), "")] if args.scheduler else [
        (_dask(args), f"LocalCluster, {args.workers} workers, MALLOC_TRIM_THRESHOLD_ unset (docs/cluster.md)"),
        (_dask(args, tuned=False), f"LocalCluster, {args.workers} workers, Dask's default worker environment")]
    for backend, label in backends:
        records, line = _measure(backend, sweep, label, bool(args.scheduler))
        lines.append(line)
        same.append(_same_records(local, records))
    print(f"sweep, {len(grid)} runs x {grid.duration_s:g} s:", *lines, sep="\n")
    print(f"  records identical to the local pool's: {'yes' if all(same) else 'NO'}; "
          f"{sum(not r.ok for r in local)} failed")


def _calibrations(args, config) -> None:
    reference = paper_table()

    def fit(runner):
        return calibrate(reference, config, fit_duration_s=DEFAULT_FIT_DURATION_S,
                         max_evaluations=args.max_evaluations, runner=runner)

    local, local_line = _measure(_local(args), fit, f"local pool, {args.workers} workers", False)
    remote, remote_line = _measure(_dask(args), fit, "", bool(args.scheduler))
    same = (local.fitted_values == remote.fitted_values and _same_records(local.before, remote.before)
            and _same_records(local.after, remote.after)
            and [e.error for e in local.history] == [e.error for e in remote.history])
    print(f"calibration to the paper's Table I: {len(local.history)} evaluations (--max-evaluations "
          f"{args.max_evaluations}; srs_sweep's default is 40) of {len(local.fit_cells)} cells x "
          f"{local.fit_duration_s:g} s, before and after {len(reference.cells)} x {reference.duration_s:g} s:")
    print(local_line, remote_line, sep="\n")
    print(f"  fitted values, every evaluation's error and the records before and after identical: "
          f"{'yes' if same else 'NO'} (RMS log error {local.error_before:.4f} -> {local.error_after:.4f})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2, help="local processes and Dask workers (default 2)")
    parser.add_argument("--duration-s", type=float, default=paper_table().duration_s)
    parser.add_argument("--max-evaluations", type=int, default=4)
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
