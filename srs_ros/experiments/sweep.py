"""The sweep grid (gaits x amplitudes x frequencies, one run time) and the parallel offline runner.

:class:`SweepGrid` validates what a user asks for (known gaits, ``0 < A <= max_pressure_bar``,
frequencies in :data:`~srs_ros.core.robot.CYCLE_FREQUENCY_RANGE_HZ`, non-empty lists, a run time > 0)
and lists its cells in the paper's order; the paper's own grid is that of its Table I
(``SweepGrid.of_table(paper_table())``, :mod:`srs_ros.experiments.table`). :class:`OfflineRunner` runs
cells on the simulated robot (:func:`srs_ros.sim.experiment.run_experiment`, faster than real time) in a
pool of worker processes, one per core by default; a run that diverges becomes a failed
:class:`~srs_ros.experiments.table.RunRecord` with the reason, never a velocity. Runs are deterministic
for a given configuration, whatever the number of workers. Each worker fits a cell's gait cycle once and
keeps it for later runs (calibration runs the same cells many times).
"""

from __future__ import annotations

import multiprocessing
import os
import warnings
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

from srs_ros.core.errors import InvalidInputError, SrsError
from srs_ros.core.gait.library import list_gaits
from srs_ros.core.gait.request import FREQUENCY_FIELD, SAMPLES_FIELD, amplitude_field, gait_field
from srs_ros.core.gait.trajectory import GaitCycle, PoorFitWarning, generate_cycle
from srs_ros.core.robot import RobotDescription, default_robot
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
    return list(dict.fromkeys(checked))


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
DURATION_FIELD = Field("duration_s", float, minimum=0.0, above_minimum=True, unit="s", description="run time")


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


class OfflineRunner:
    """Runs cells on the simulated robot in ``workers`` processes (1: in this process); reuse it for many batches.

    Use as a context manager, or call :meth:`close`. Worker processes are started with ``spawn`` (no state
    inherited from the caller, such as threads or an rclpy context).
    """

    def __init__(self, workers: int | None = None):
        workers = default_workers() if workers is None else int(workers)
        if workers < 1:
            raise InvalidInputError(f"workers: {workers}; expected 1 or more processes.")
        self.workers = workers
        self._pool: ProcessPoolExecutor | None = None

    def __enter__(self) -> OfflineRunner:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Stop the worker processes (pending runs are cancelled)."""
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def run(self, cells: Sequence[Cell], duration_s: float, config: SimConfig, keep_track: bool = True,
            on_result: Callable[[RunRecord], None] | None = None) -> list[RunRecord]:
        """Run every cell; records in the order of ``cells``; ``on_result`` is called as each run finishes."""
        cells = list(cells)
        if self.workers == 1 or len(cells) == 1:
            records = []
            for cell in cells:
                records.append(run_cell(cell, duration_s, config, keep_track))
                if on_result is not None:
                    on_result(records[-1])
            return records
        if self._pool is None:
            self._pool = ProcessPoolExecutor(self.workers, mp_context=multiprocessing.get_context("spawn"))
        futures: list[Future] = [self._pool.submit(run_cell, cell, duration_s, config, keep_track) for cell in cells]
        if on_result is not None:
            for future in as_completed(futures):
                on_result(future.result())
        return [future.result() for future in futures]


def run_offline_sweep(grid: SweepGrid, config: SimConfig, workers: int | None = None,
                      on_result: Callable[[RunRecord], None] | None = None) -> list[RunRecord]:
    """Every run of ``grid`` on the simulated robot, in parallel; records in the grid's order."""
    with OfflineRunner(workers) as runner:
        return runner.run(grid.cells(), grid.duration_s, config, on_result=on_result)
