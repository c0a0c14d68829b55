"""Figures of a sweep: the table as grouped bars per gait, and the paths of every run like the paper's Fig. 7.

:func:`plot_table` draws one panel per gait: the resultant speed of each cell (amplitude x frequency) as a
bar, beside the measured table's (the paper's) where it has the cell; a failed run is marked with an x.
:func:`plot_paths` draws one gait's runs as a grid of floor paths (rows amplitude, columns frequency), each
from its start, on one scale so that distances compare. Matplotlib with the Agg backend (files only).
Both write the PNG atomically and return its path.
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from srs_ros.core.files import write_atomically  # noqa: E402
from srs_ros.experiments.table import FAILED, MeasuredTable, RunRecord, cell_key  # noqa: E402

DPI = 100
#: Bar colours: this sweep, the measured table.
SWEEP_COLOUR = "tab:blue"
MEASURED_COLOUR = "tab:orange"


def _save(fig, path: str | Path) -> Path:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=DPI)
    plt.close(fig)
    return write_atomically(path, buffer.getvalue())


def _grid_axes(records: Sequence[RunRecord]) -> tuple[list[str], list[float], list[float]]:
    gaits = list(dict.fromkeys(r.gait for r in records))
    return gaits, sorted({r.amplitude_bar for r in records}), sorted({r.frequency_hz for r in records})


def plot_table(path: str | Path, records: Sequence[RunRecord], reference: MeasuredTable | None,
               label: str = "simulated") -> Path:
    """``table.png``: per gait, the resultant speed of every cell (cm/s) as bars, this sweep beside the table."""
    gaits, amplitudes, frequencies = _grid_axes(records)
    by_cell = {r.cell: r for r in records}
    fig, axes = plt.subplots(len(gaits), 1, figsize=(max(8.0, 0.9 * len(amplitudes) * len(frequencies)),
                                                      3.2 * len(gaits)), squeeze=False)
    ref_label = "measured" if reference is None else ("paper" if "Table I" in reference.name else "measured")
    for ax, gait in zip(axes[:, 0], gaits):
        cells = [cell_key(gait, a, f) for a in amplitudes for f in frequencies]
        x = np.arange(len(cells))
        ours = np.array([by_cell[c].speed_cm_s if c in by_cell else math.nan for c in cells])
        theirs = np.array([reference.speed_cm_s(c) if reference and c in reference.cells else math.nan
                           for c in cells])
        ax.bar(x - 0.2, np.nan_to_num(ours), 0.4, color=SWEEP_COLOUR, label=label)
        if reference is not None:
            ax.bar(x + 0.2, np.nan_to_num(theirs), 0.4, color=MEASURED_COLOUR, label=ref_label)
        failed = [i for i, c in enumerate(cells) if c in by_cell and by_cell[c].outcome == FAILED]
        if failed:
            ax.plot(x[failed] - 0.2, np.zeros(len(failed)), "x", color="tab:red", markersize=9, label="failed run")
        ax.set_xticks(x, [f"{c[1]:g} bar\n{c[2]:g} Hz" for c in cells], fontsize="x-small")
        for boundary in range(len(frequencies), len(cells), len(frequencies)):
            ax.axvline(boundary - 0.5, color="0.8", lw=0.8)
        ax.set_ylabel("speed (cm/s)")
        ax.set_title(f"{gait}: resultant traveling velocity sqrt(v_x^2 + v_y^2)", fontsize="medium")
        ax.grid(True, axis="y", alpha=0.3)
        ax.legend(loc="upper left", fontsize="small")
    fig.tight_layout()
    return _save(fig, path)


def plot_paths(path: str | Path, records: Sequence[RunRecord], gait: str) -> Path:
    """``paths_<gait>.png``: the floor path of each run of ``gait`` from its start (cm), rows A, columns f."""
    runs = [r for r in records if r.gait == gait]
    _, amplitudes, frequencies = _grid_axes(runs)
    by_cell = {r.cell: r for r in runs}
    tracks = [r.track for r in runs if r.track is not None and len(r.track)]
    span_cm = max([float(np.nanmax(np.abs(100.0 * (t[:, 1:3] - t[0, 1:3])))) for t in tracks] + [1.0]) * 1.1
    fig, axes = plt.subplots(len(amplitudes), len(frequencies), squeeze=False,
                             figsize=(2.6 * len(frequencies) + 1.0, 2.6 * len(amplitudes) + 0.8))
    for i, amplitude in enumerate(amplitudes):
        for j, frequency in enumerate(frequencies):
            ax = axes[i, j]
            record = by_cell.get(cell_key(gait, amplitude, frequency))
            ax.set_xlim(-span_cm, span_cm)
            ax.set_ylim(-span_cm, span_cm)
            ax.set_aspect("equal")
            ax.grid(True, alpha=0.3)
            ax.tick_params(labelsize="x-small")
            title = f"{amplitude:g} bar, {frequency:g} Hz"
            if record is None:
                ax.set_title(title + ": not run", fontsize="small")
                continue
            if record.track is not None and len(record.track):
                xy_cm = 100.0 * (record.track[:, 1:3] - record.track[0, 1:3])
                ax.plot(xy_cm[:, 0], xy_cm[:, 1], "-", color=SWEEP_COLOUR, lw=1.2)
                ax.plot(0.0, 0.0, "o", color="tab:green", markersize=4)
                ax.plot(xy_cm[-1, 0], xy_cm[-1, 1], "s", color="tab:red", markersize=4)
            note = f"{record.speed_cm_s:.2f} cm/s" if record.ok else record.outcome
            ax.set_title(f"{title}: {note}", fontsize="small", color="black" if record.ok else "tab:red")
            if i == len(amplitudes) - 1:
                ax.set_xlabel("X (cm)", fontsize="small")
            if j == 0:
                ax.set_ylabel("Y (cm)", fontsize="small")
    fig.suptitle(f"{gait}: path of each run from its start\n(floor frame; green start, red end)", fontsize="medium")
    fig.tight_layout()
    return _save(fig, path)
