"""Offline runs on a Dask cluster: ``--scheduler tcp://HOST:8786``, or the local pool of processes without it.

:func:`runner_for` gives the :class:`~srs_ros.experiments.sweep.OfflineRunner` that a sweep, a calibration
or a model study runs its cells with: the local pool (no scheduler, as ``srs_sweep`` always did) or the
workers of a running Dask cluster (``dask scheduler`` on one machine, ``dask worker tcp://HOST:8786`` on
each; docs/cluster.md). Both take the runner's one code path, a :class:`concurrent.futures.Executor`
(here Dask's ``Client.get_executor()``): progress per run finished anywhere, runs lost with their worker
submitted again, records identical to a local run. Before the first run every connected worker must
show the code fingerprint of this machine (:func:`~srs_ros.experiments.sweep.code_fingerprint`).

Dask is imported here only, and only when a scheduler is given: it is optional (``pip install
'srs_ros[cluster]'``). :func:`add_runner_arguments` and :func:`runner_from_args` give any command line
``--workers`` and ``--scheduler`` as ``srs_sweep`` has them.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable

from srs_ros.core.errors import ClusterError, InvalidInputError
from srs_ros.experiments.sweep import OfflineRunner, code_fingerprint, default_workers, fingerprint_mismatch

#: How long to try to reach the scheduler, and to wait for the workers asked for (s).
CONNECT_TIMEOUT_S = 10.0
WORKER_WAIT_S = 60.0
INSTALL_HINT = "pip install 'srs_ros[cluster]' (Dask: dask and distributed)"
#: Dask's nanny starts its workers with glibc's ``MALLOC_TRIM_THRESHOLD_`` at 65536: freed memory goes back to
#: the system at once, which costs a run's start page faults (measured: up to 1.7x the CPU time of a 1 s run,
#: nothing measurable for 15 s runs). The Dask setting that leaves it unset, for ``dask.config.set`` (a
#: LocalCluster) or a worker machine's ``~/.config/dask/srs_ros.yaml`` (docs/cluster.md):
WORKER_DASK_CONFIG = {"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}


class DaskRunner(OfflineRunner):
    """An :class:`OfflineRunner` on the workers of a Dask cluster, through its client's executor (closed with it)."""

    def __init__(self, client, address: str, log: Callable[[str], None] | None = None):
        super().__init__(executor=client.get_executor(pure=False), log=log)
        self.client, self.address = client, address

    def describe(self) -> str:
        workers = self.client.scheduler_info()["workers"].values()
        threads = sum(w.get("nthreads", 0) for w in workers)
        return f"{len(workers)} workers ({threads} threads) of the Dask cluster at {self.address}"

    def close(self) -> None:
        super().close()
        self.client.close()

    def check_usable(self) -> None:
        """A client that lost its scheduler cancels its runs and takes new ones that never run: stop instead."""
        if self.client.status != "running":
            raise self.unusable(f"the connection is {self.client.status}")

    def unusable(self, why: str) -> ClusterError:
        return ClusterError(f"lost the Dask scheduler at {self.address} ({why}): it stopped, or the network "
                            "between here and it failed; the runs of this batch are lost. Start it again with its "
                            "workers (docs/cluster.md) and run again, or leave out --scheduler.")


def runner_for(scheduler: str | None, workers: int | None = None, log: Callable[[str], None] | None = None,
               connect_timeout_s: float = CONNECT_TIMEOUT_S, worker_wait_s: float = WORKER_WAIT_S) -> OfflineRunner:
    """``workers`` local processes without ``scheduler``; with it, the Dask cluster at that address.

    ``scheduler``: ``tcp://HOST:8786``; the runner is returned once ``workers`` (default 1) of its workers
    are connected. :class:`~srs_ros.core.errors.ClusterError` says what to do when Dask is not installed, the scheduler
    cannot be reached, too few workers join or a worker runs other code.
    """
    if not scheduler:
        return OfflineRunner(workers, log=log)
    if workers is not None and workers < 1:
        raise InvalidInputError(f"workers: {workers}; expected 1 or more Dask workers to wait for.")
    client = connect(scheduler, connect_timeout_s)
    try:
        wait_for_workers(client, scheduler, workers or 1, worker_wait_s)
        check_workers(client, scheduler)
    except BaseException:
        client.close()
        raise
    return DaskRunner(client, scheduler, log)


def _distributed():
    try:
        import distributed
    except ImportError as exc:
        raise ClusterError(f"--scheduler needs Dask distributed, which is not installed here ({exc}). Install it "
                           f"with {INSTALL_HINT} on this machine and on every worker, or leave out --scheduler to "
                           "run on the local pool.") from None
    return distributed


def _check_address(scheduler: str) -> None:
    """:class:`ClusterError` unless ``scheduler`` reads as ``[tcp://]HOST:PORT`` (or another scheme of Dask's)."""
    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        _scheme, location = parse_address(scheduler)
        _host, port = parse_host_port(location)
        if not 0 < port < 65536:
            raise ValueError(f"port {port} out of range")
    except (ValueError, TypeError) as exc:
        raise ClusterError(f"--scheduler {scheduler!r} is not the address of a Dask scheduler ({exc}); expected "
                           "tcp://HOST:PORT such as tcp://192.168.1.10:8786 (`dask scheduler` prints it at "
                           "start).") from None


def connect(scheduler: str, timeout_s: float = CONNECT_TIMEOUT_S):
    """A ``distributed.Client`` of the scheduler at ``scheduler``; :class:`ClusterError` if it does not answer."""
    distributed = _distributed()
    _check_address(scheduler)
    try:
        return distributed.Client(scheduler, timeout=timeout_s, set_as_default=False)
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        raise ClusterError(f"cannot reach the Dask scheduler at {scheduler!r} ({' '.join(str(exc).split())}); "
                           "expected a running `dask scheduler` at that address, such as tcp://HOST:8786. Start it "
                           "(docs/cluster.md), check the host, port and firewall, or leave out --scheduler to run "
                           "on the local pool.") from None


def wait_for_workers(client, scheduler: str, count: int, timeout_s: float = WORKER_WAIT_S) -> None:
    """Wait until ``count`` workers are connected; :class:`ClusterError` after ``timeout_s``."""
    try:
        client.wait_for_workers(count, timeout=timeout_s)
    except TimeoutError:
        have = len(client.scheduler_info()["workers"])
        raise ClusterError(f"the Dask scheduler at {scheduler} has {have} workers after {timeout_s:g} s; expected "
                           f"{count}. Start `dask worker {scheduler} --nthreads 1` on each machine "
                           "(docs/cluster.md), or ask for fewer with --workers.") from None


def check_workers(client, scheduler: str) -> None:
    """Every connected worker has this machine's code fingerprint; :class:`ClusterError` names one that has not."""
    expected = code_fingerprint()
    found = client.run(code_fingerprint, on_error="return")  # a worker without srs_ros cannot unpickle the call
    broken = {address: there for address, there in found.items() if isinstance(there, BaseException)}
    wrong = {address: there for address, there in found.items() if address not in broken and there != expected}
    others = len(broken) + len(wrong) - 1
    more = f" ({others} more workers too)" if others else ""
    if broken:
        address, error = next(iter(broken.items()))
        raise ClusterError(f"the Dask worker {address}{more} cannot run srs_ros ({type(error).__name__}: "
                           f"{' '.join(str(error).split())}); install the same srs_ros on every worker as here "
                           f"({INSTALL_HINT}; docs/cluster.md), or stop that worker.")
    if wrong:
        address, there = next(iter(wrong.items()))
        raise ClusterError(fingerprint_mismatch(f"the Dask worker {address}{more}", there, expected))


# ------------------------------------------------------------------------------------------
# Command lines
# ------------------------------------------------------------------------------------------
def add_runner_arguments(group: argparse.ArgumentParser | argparse._ArgumentGroup) -> None:
    """``--workers N`` and ``--scheduler tcp://HOST:8786``, as ``srs_sweep`` has them."""
    group.add_argument("--workers", type=int, default=None,
                       help=f"local worker processes (default {default_workers()}, one per core); with --scheduler: "
                            "wait for this many Dask workers before the first run (default 1)")
    group.add_argument("--scheduler", metavar="tcp://HOST:8786",
                       help="run on a Dask cluster: the address of its running `dask scheduler` (docs/cluster.md); "
                            "default: the local pool")


def runner_from_args(args: argparse.Namespace, log: Callable[[str], None] | None = None) -> OfflineRunner:
    """:func:`runner_for` with :func:`add_runner_arguments`' options."""
    return runner_for(args.scheduler, args.workers, log)
