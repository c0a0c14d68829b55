"""The sweep grid (gaits x amplitudes x frequencies, one run time) and the parallel offline runner.

:class:`SweepGrid` validates what a user asks for (known gaits, ``0 < A <= max_pressure_bar``,
frequencies in :data:`~srs_ros.core.robot.CYCLE_FREQUENCY_RANGE_HZ`, non-empty lists, a run time > 0)
and lists its cells in the paper's order; the paper's own grid is that of its Table I
(``SweepGrid.of_table(paper_table())``, :mod:`srs_ros.experiments.table`). :class:`OfflineRunner` runs
cells on the simulated robot (:func:`srs_ros.sim.experiment.run_experiment`, faster than real time) in a
pool of worker processes, one per core by default, or on any :class:`concurrent.futures.Executor` such
as a Dask cluster's (:mod:`srs_ros.experiments.cluster`); a run that diverges becomes a failed
:class:`~srs_ros.experiments.table.RunRecord` with the reason, never a velocity, and a run whose worker
is lost is submitted again. Runs are deterministic for a given configuration, whatever the number of
workers or machines (:func:`code_fingerprint` keeps a worker with other code out). Each worker fits a
cell's gait cycle once and keeps it for later runs (calibration runs the same cells many times).
"""

from __future__ import annotations

import hashlib
import multiprocessing
import os
import socket
import sys
import warnings
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import (
    FIRST_COMPLETED,
    BrokenExecutor,
    CancelledError,
    Executor,
    Future,
    ProcessPoolExecutor,
    wait,
)
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

from srs_ros.core.errors import ClusterError, InvalidInputError, SrsError
from srs_ros.core.gait.library import list_gaits
from srs_ros.core.gait.request import FREQUENCY_FIELD, MAX_RUN_S, SAMPLES_FIELD, amplitude_field, gait_field
from srs_ros.core.gait.trajectory import GaitCycle, PoorFitWarning, generate_cycle
from srs_ros.core.robot import RobotDescription, config_dir, default_robot
from srs_ros.core.schema import Field, refusal
from srs_ros.experiments.table import Cell, MeasuredTable, RunRecord, cell_key, paper_table
from srs_ros.sim.config import SimConfig
from srs_ros.sim.experiment import run_experiment

#: Shapes fitted per gait cycle (the trajectory server's default).
CYCLE_SAMPLES = SAMPLES_FIELD.default
#: Where a refused grid value says it is.
WHERE = "sweep grid"


def _values(name: str, values: Iterable[Any], field: Field) -> list[Any]:
    """``values`` checked with ``field`` (``amplitudes[2]`` named on a refusal), repeats dropped, order kept."""
    values = list(values)
    if not values:
        raise refusal(WHERE, name, values, f"at least one value, each {field.expected}", InvalidInputError)
    checked = [field.check(v, WHERE, f"{name}[{i}]", InvalidInputError) for i, v in enumerate(values)]
    # repeats as the cells key them (1e-6): 2 and 2.0000001 ran the same cell twice (a helper's review)
    return list(dict.fromkeys(round(v, 6) if isinstance(v, float) else v for v in checked))


@dataclass(frozen=True)
class SweepGrid:
    """Gaits x amplitudes (bar) x frequencies (Hz), each run ``duration_s`` long; validated on creation."""

    gaits: tuple[str, ...]
    amplitudes_bar: tuple[float, ...]
    frequencies_hz: tuple[float, ...]
    duration_s: float

    @classmethod
    def create(cls, gaits: Iterable[str], amplitudes_bar: Iterable[float], frequencies_hz: Iterable[float],
               duration_s: float | None = None, robot: RobotDescription | None = None) -> SweepGrid:
        """A validated grid (default run time: the paper's); :class:`InvalidInputError` names a bad value."""
        robot = robot or default_robot()
        duration = DURATION_FIELD.check(paper_table().duration_s if duration_s is None else duration_s, WHERE,
                                        error=InvalidInputError)
        return cls(tuple(_values("gaits", gaits, gait_field(list_gaits()))),
                   tuple(_values("amplitudes", amplitudes_bar, amplitude_field(robot))),
                   tuple(_values("frequencies", frequencies_hz, FREQUENCY_FIELD)), duration)

    @classmethod
    def of_table(cls, table: MeasuredTable, duration_s: float | None = None) -> SweepGrid:
        """The grid of a measured table's cells at its run time; ``SweepGrid.of_table(paper_table())``: the paper's."""
        return cls.create(table.gaits, table.amplitudes_bar, table.frequencies_hz,
                          table.duration_s if duration_s is None else duration_s)

    def cells(self) -> list[Cell]:
        """Every cell, gait by gait, then amplitude, then frequency (Table I's order)."""
        return [cell_key(g, a, f) for g in self.gaits for a in self.amplitudes_bar for f in self.frequencies_hz]

    def __len__(self) -> int:
        return len(self.gaits) * len(self.amplitudes_bar) * len(self.frequencies_hz)


#: The run time of one cell.
DURATION_FIELD = Field("duration_s", float, minimum=0.0, maximum=MAX_RUN_S, above_minimum=True, unit="s",
                       description="run time")


# ------------------------------------------------------------------------------------------
# One run in a worker process
# ------------------------------------------------------------------------------------------
@lru_cache(maxsize=256)
def _cycle(gait: str, amplitude_bar: float, frequency_hz: float, samples: int) -> GaitCycle:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PoorFitWarning)  # a serpenoid is never fitted exactly; the fit is reported
        return generate_cycle(gait, amplitude_bar, frequency_hz, samples)


def run_cell(cell: Cell, duration_s: float, config: SimConfig, keep_track: bool = True,
             samples: int = CYCLE_SAMPLES) -> RunRecord:
    """One run of ``cell`` on the simulated robot; a diverged simulation gives a failed record with the reason."""
    gait, amplitude_bar, frequency_hz = cell
    try:
        cycle = _cycle(gait, amplitude_bar, frequency_hz, samples)
        result = run_experiment(gait, amplitude_bar, frequency_hz, duration_s, config, cycle=cycle)
    except SrsError as exc:
        return RunRecord.failed(cell, f"{type(exc).__name__}: {exc}")
    v = result.velocity
    return RunRecord(gait, amplitude_bar, frequency_hz, v.vx_cm_s, v.vy_cm_s, v.displacement_x_m, v.displacement_y_m,
                     track=result.track if keep_track else None)


def default_workers() -> int:
    """One worker per core."""
    return max(1, os.cpu_count() or 1)


# ------------------------------------------------------------------------------------------
# What a run's result depends on besides its arguments (every worker of a cluster must match)
# ------------------------------------------------------------------------------------------
#: The code a run executes (folders and files of srs_ros; their .py files are hashed) and the files it reads.
RUN_CODE = ("core", "sim", "experiments/sweep.py", "experiments/table.py")
RUN_CONFIG_FILES = ("robot.yaml", "gaits.yaml", "rigs/mock.yaml")  # the mock rig: the command rate of a run


def _files(root: Path, parts: Sequence[str]) -> list[Path]:
    """The .py files of ``parts`` (folders or files under ``root``), in a fixed order."""
    files: list[Path] = []
    for part in parts:
        path = root / part
        files += sorted(path.rglob("*.py")) if path.is_dir() else [path]
    return files


@lru_cache(maxsize=1)
def code_fingerprint() -> dict[str, str]:
    """srs_ros's version with a hash of the code and files a run uses, and the versions of the libraries under it."""
    import mujoco
    import numpy
    import scipy

    import srs_ros

    root = Path(srs_ros.__file__).resolve().parent
    digest = hashlib.sha256()
    for path in _files(root, RUN_CODE):
        digest.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes())
    for name in RUN_CONFIG_FILES:
        digest.update(name.encode() + b"\0" + (config_dir() / name).read_bytes())
    return {"srs_ros": f"{srs_ros.__version__} (code {digest.hexdigest()[:12]})", "mujoco": mujoco.__version__,
            "numpy": numpy.__version__, "scipy": scipy.__version__}


def fingerprint_mismatch(where: str, found: dict[str, str], expected: dict[str, str]) -> str:
    """The message for a worker whose :func:`code_fingerprint` is ``found`` where ``expected`` was asked for."""
    differences = ", ".join(f"{key} {found.get(key)} there, {value} here" for key, value in expected.items()
                            if found.get(key) != value)
    return (f"{where} runs other code than this machine ({differences}): its runs would not match a local run. "
            "Install the same srs_ros (and mujoco, numpy, scipy) on every machine of the cluster (docs/cluster.md), "
            "or stop that worker.")


def _run_task(cell: Cell, duration_s: float, config: SimConfig, keep_track: bool, expected: dict[str, str] | None,
              attempt: int) -> RunRecord:
    """One run in a worker, refused if the worker's code is not ``expected``.

    ``attempt`` makes a resubmission a new task for executors that name tasks by their arguments (Dask's pure tasks).
    """
    if expected is not None and code_fingerprint() != expected:
        where = f"the worker on {socket.gethostname()} (pid {os.getpid()})"
        raise ClusterError(fingerprint_mismatch(where, code_fingerprint(), expected))
    return run_cell(cell, duration_s, config, keep_track)


# ------------------------------------------------------------------------------------------
# The runner
# ------------------------------------------------------------------------------------------
#: How often a run lost with its worker is submitted again before it becomes a failed record.
MAX_RESUBMITS = 3


def _lost_with_worker(error: BaseException) -> bool:
    """Whether a run's error means that its worker went away (a killed process, a lost or restarted Dask worker)."""
    if isinstance(error, (CancelledError, BrokenExecutor)):
        return True
    distributed = sys.modules.get("distributed")  # imported by whoever made a Dask executor
    return distributed is not None and isinstance(error, distributed.KilledWorker)


def _lost_at_start(error: BaseException) -> Future:
    """A run that the local pool could not take: its pool broke (a worker died) before or while it started one.

    CPython's pool raises ``BrokenProcessPool`` once it knows, but a worker that dies while the pool spawns the
    next one can make the spawn fail with ``ValueError: bad value(s) in fds_to_keep`` or an ``OSError`` (the
    pool's pipes are being closed). Either way the run is lost with a worker: a future failed with
    ``BrokenProcessPool``, so that it is counted and submitted again to a new pool like any other lost run.
    """
    future: Future = Future()
    future.set_exception(BrokenProcessPool(f"the local pool broke while it took the run ({error_line(error)})"))
    return future


def error_line(error: BaseException) -> str:
    """An error in one short line: its type and first sentence."""
    text = " ".join(str(error).split()).split(". ")[0].rstrip(".")
    text = text if len(text) <= 160 else text[:157] + "..."
    return f"{type(error).__name__}: {text}" if text else type(error).__name__


def cell_name(cell: Cell) -> str:
    return f"{cell[0]} {cell[1]:g} bar {cell[2]:g} Hz"


def _print_stderr(text: str) -> None:
    print(f"srs_ros: {text}", file=sys.stderr, flush=True)


def _worker_context():
    """The local workers' start method: ``forkserver``, a fresh server process that imports the simulation once.

    A new worker then starts in milliseconds instead of importing MuJoCo and srs_ros again (about 1.5 s of CPU).
    The server keeps the environment variables of the moment it started (the first pool of the process); the
    simulation reads none.
    """
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload([__name__])  # this module imports the simulation and the gaits
    return context


class OfflineRunner:
    """Runs cells on the simulated robot in ``workers`` local processes (1: in this process) or on ``executor``.

    ``executor``: any :class:`concurrent.futures.Executor`, e.g. a Dask cluster's ``Client.get_executor()``
    (:func:`srs_ros.experiments.cluster.runner_for` makes one from a scheduler's address); it is not shut
    down by :meth:`close`. Both run the same way: progress per finished run, records in the order of the
    cells, and a run whose worker is lost (a killed process, a lost Dask worker) submitted again up to
    :data:`MAX_RESUBMITS` times with a message to ``log`` (default: stderr), then a failed record. Local
    worker processes fork from a ``forkserver`` process started afresh (no state inherited from the caller,
    such as threads or an rclpy context) that has imported the simulation once. Use as a context manager, or
    call :meth:`close`; reuse it for many batches.
    """

    def __init__(self, workers: int | None = None, executor: Executor | None = None,
                 log: Callable[[str], None] | None = None):
        if executor is not None and workers is not None:
            raise InvalidInputError(f"workers {workers} and an executor: give one (the executor's workers run the "
                                    "runs).")
        workers = default_workers() if workers is None else int(workers)
        if workers < 1:
            raise InvalidInputError(f"workers: {workers}; expected 1 or more processes.")
        self.workers = None if executor is not None else workers
        self.log = log or _print_stderr
        self._given = executor
        self._pool: ProcessPoolExecutor | None = None

    def __enter__(self) -> OfflineRunner:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def describe(self) -> str:
        """Where the runs run, for a report."""
        return f"{self.workers} workers" if self._given is None else f"a {type(self._given).__name__}"

    def close(self) -> None:
        """Stop the local worker processes (pending runs are cancelled); a given executor is left running."""
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def run(self, cells: Sequence[Cell], duration_s: float, config: SimConfig, keep_track: bool = True,
            on_result: Callable[[RunRecord], None] | None = None) -> list[RunRecord]:
        """Run every cell; records in the order of ``cells``; ``on_result`` is called as each run finishes."""
        cells = list(cells)
        if self._given is None and (self.workers == 1 or len(cells) == 1):
            records = []
            for cell in cells:
                records.append(run_cell(cell, duration_s, config, keep_track))
                if on_result is not None:
                    on_result(records[-1])
            return records
        expected = None if self._given is None else code_fingerprint()  # the local pool runs this installation
        return _Batch(self, cells, (duration_s, config, keep_track, expected), on_result).run()

    def _executor(self) -> Executor:
        if self._given is not None:
            return self._given
        if self._pool is None:
            self._pool = ProcessPoolExecutor(self.workers, mp_context=_worker_context())
        return self._pool

    def _drop_pool(self, broken: Executor) -> None:
        """Replace a broken local pool (a worker process died) by a new one at the next submission."""
        if broken is self._pool:
            self._pool.shutdown(wait=False, cancel_futures=True)
            self._pool = None

    def submit(self, cell: Cell, job: tuple, attempt: int) -> tuple[Future, Executor]:
        """Submit one run: its future and the executor that took it (:meth:`unusable` if it takes none)."""
        self.check_usable()
        executor = self._executor()
        try:
            return executor.submit(_run_task, cell, *job, attempt), executor
        except (RuntimeError, OSError, ValueError) as exc:  # BrokenExecutor is a RuntimeError
            broke = isinstance(exc, BrokenExecutor) or not isinstance(exc, RuntimeError)
            if executor is not self._given and broke:
                return _lost_at_start(exc), executor  # the local pool broke: a lost run, for a new pool
            if isinstance(exc, ValueError):
                raise  # a given executor's own complaint
            raise self.unusable(error_line(exc)) from None  # a shut down executor, a lost connection

    def check_usable(self) -> None:
        """Raise :meth:`unusable` if the executor is known to take no more runs (the local pool always does)."""

    def unusable(self, why: str) -> ClusterError:
        """The error for an executor that takes no more runs."""
        return ClusterError(f"the runner's executor takes no more runs ({why}); expected a working executor: "
                            "make a new one (or a new runner) and run again.")


#: How often a batch looks which of its runs a local pool has started (s): a break is charged to those only.
LOOK_EVERY_S = 0.2


class _Batch:
    """One call of :meth:`OfflineRunner.run` on an executor: the futures in flight and the records so far."""

    def __init__(self, runner: OfflineRunner, cells: list[Cell], job: tuple,
                 on_result: Callable[[RunRecord], None] | None):
        self.runner, self.cells, self.job, self.on_result = runner, cells, job, on_result
        self.records: list[RunRecord | None] = [None] * len(cells)
        self.pending: dict[Future, tuple[int, int, Executor]] = {}  # future -> cell index, attempt, executor
        #: Runs lost when a local pool broke with others in it, to run again one at a time (cell index, attempt).
        self.suspects: list[tuple[int, int]] = []
        self._alone: Future | None = None  # the suspect running alone in a fresh pool
        self._started: set[Future] = set()  # the futures seen started (handed to a worker) at the last look
        self._spared: dict[int, int] = {}  # cell index -> breaks it was lost in while seen queued, not started

    def run(self) -> list[RunRecord]:
        try:
            for index in range(len(self.cells)):
                self._submit(index, 0)
            while self.pending or self.suspects:
                if self.suspects and not self.pending:
                    self._submit(*self.suspects.pop(0), alone=True)
                self._started = {future for future in self.pending if future.running()}
                done, _ = wait(self.pending, timeout=LOOK_EVERY_S, return_when=FIRST_COMPLETED)
                for future in done:
                    self._finished(future, *self.pending.pop(future))
        finally:
            for future in self.pending:
                future.cancel()
        return self.records

    def _submit(self, index: int, attempt: int, alone: bool = False) -> None:
        future, executor = self.runner.submit(self.cells[index], self.job, attempt)
        self.pending[future] = (index, attempt, executor)
        self._alone = future if alone else self._alone

    def _finished(self, future: Future, index: int, attempt: int, executor: Executor) -> None:
        try:
            record = future.result()
        except Exception as exc:  # noqa: BLE001 - anything but a lost worker is raised again
            if not _lost_with_worker(exc):
                if isinstance(exc, SrsError) or self.runner._given is None:
                    raise
                # From another machine's worker, e.g. one that joined after the check with an older srs_ros (a
                # TypeError traceback before; a helper's review): said as the cluster's problem, exit 2.
                raise ClusterError(f"{cell_name(self.cells[index])} failed on a worker of the cluster "
                                   f"({error_line(exc)}); that worker may run other srs_ros code than this one: "
                                   "install the same srs_ros on every worker (docs/cluster.md), or stop that "
                                   "worker, then run again.") from exc
            record = self._lost(index, attempt, executor, exc, alone=future is self._alone,
                                started=future in self._started or not self._started)
        if record is not None:
            self.records[index] = record
            if self.on_result is not None:
                self.on_result(record)

    def _lost(self, index: int, attempt: int, executor: Executor, error: Exception, alone: bool = False,
              started: bool = True) -> RunRecord | None:
        """A run lost with its worker: submitted again (None) or, after :data:`MAX_RESUBMITS`, a failed record.

        A local pool that breaks fails every run in it, and which one broke it is not known. The runs still queued
        could not have: they go to the new pool as they were. Those seen started (at most workers + 1) are not
        charged an attempt but run again one at a time, each alone in a fresh pool, where a run that breaks it is
        the one. (Charging them all failed healthy runs queued beside a run that kills its worker every time.) A run
        lost while seen queued more than :data:`MAX_RESUBMITS` times is a suspect too, so a run that breaks the pool
        between two looks is found all the same.
        """
        if isinstance(error, BrokenExecutor):
            self.runner._drop_pool(executor)
            if not alone and not started and self._spared.get(index, 0) < MAX_RESUBMITS:
                self._spared[index] = self._spared.get(index, 0) + 1
                self._submit(index, attempt)
                self.runner.log(f"{cell_name(self.cells[index])}: its worker pool broke before it started "
                                f"({error_line(error)}); submitted again as it was")
                return None
            if not alone:
                self.suspects.append((index, attempt))
                self.runner.log(f"{cell_name(self.cells[index])}: its worker pool broke ({error_line(error)}); "
                                "run again alone to tell which run breaks it")
                return None
        name, reason = cell_name(self.cells[index]), error_line(error)
        if attempt >= MAX_RESUBMITS:
            self.runner.log(f"{name}: lost with its worker {attempt + 1} times ({reason}); given up: a failed run")
            return RunRecord.failed(self.cells[index], f"lost with its worker {attempt + 1} times (last: {reason})")
        if alone:
            self.suspects.insert(0, (index, attempt + 1))  # alone again, before the other suspects
        else:
            self._submit(index, attempt + 1)
        what = "it was cancelled" if isinstance(error, CancelledError) else "its worker was lost"
        self.runner.log(f"{name}: {what} ({reason}); submitted again (attempt {attempt + 2} of {MAX_RESUBMITS + 1})")
        return None


def run_offline_sweep(grid: SweepGrid, config: SimConfig, workers: int | None = None,
                      on_result: Callable[[RunRecord], None] | None = None) -> list[RunRecord]:
    """Every run of ``grid`` on the simulated robot, in parallel; records in the grid's order."""
    with OfflineRunner(workers) as runner:
        return runner.run(grid.cells(), grid.duration_s, config, on_result=on_result)
