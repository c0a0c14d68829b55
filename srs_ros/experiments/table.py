"""Table I as data: measured tables (the paper's or a lab's), run records, the CSV and the paper's layout.

A *measured table* (``config/paper_table1.yaml``, :func:`load_measured_table`) holds one velocity
``(v_x, v_y)`` per cell ``(gait, amplitude_bar, frequency_hz)``, the run time and whether the velocities
are signed. A *run record* (:class:`RunRecord`) is one run of a sweep: its signed traveling velocity and
displacement in the floor frame, and ``status`` ("ok" or why it failed). :func:`write_table_csv` writes the
sweep's ``table.csv`` with the measured values beside the simulated or tracked ones, and
:func:`format_table` prints it in the paper's layout (rows amplitude x frequency, two columns per gait).

Velocities follow the paper's definition (:func:`srs_ros.core.vision.tracking.traveling_velocity`): X and Y
displacement divided by the run time, cm/s. Because a camera's floor axes are arbitrary with respect to
the robot, tables are compared on the resultant speed ``hypot(v_x, v_y)``.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from srs_ros.core.files import write_atomically
from srs_ros.core.gait.library import list_gaits
from srs_ros.core.gait.request import FREQUENCY_FIELD, MAX_RUN_S, amplitude_field, gait_field
from srs_ros.core.robot import RobotDescription, config_dir, default_robot, read_yaml
from srs_ros.core.schema import Field, Table, document, read_csv_rows, refusal

#: After a run over ROS is vented, the wait before its end pose is taken (s): the body settles (srs_sweep --ros).
ROS_SETTLE_S = 2.0

#: The paper's Table I in ``config/``.
PAPER_TABLE_FILE = "paper_table1.yaml"
#: Columns of a measured table's rows.
MEASURED_COLUMNS = ("gait", "amplitude_bar", "frequency_hz", "vx_cm_s", "vy_cm_s")
#: Columns of a sweep's ``table.csv``: the run, its velocity and displacement, the measured velocity of the
#: cell (empty where the measured table has none) and the run's status ("ok", or "failed: " or "skipped: " and why).
TABLE_COLUMNS = ("gait", "amplitude_bar", "frequency_hz", "vx_cm_s", "vy_cm_s", "dx_m", "dy_m",
                 "paper_vx_cm_s", "paper_vy_cm_s", "status")
#: Status of a run that went through; the words that begin the status of one that failed or was not made by choice.
OK, FAILED, SKIPPED = "ok", "failed", "skipped"

Cell = tuple[str, float, float]


def cell_key(gait: str, amplitude_bar: float, frequency_hz: float) -> Cell:
    """The key of a cell: gait and amplitude / frequency rounded to 1e-6 (so 0.5 and 0.50 are one cell)."""
    return str(gait), round(float(amplitude_bar), 6), round(float(frequency_hz), 6)


@dataclass(frozen=True)
class MeasuredTable:
    """Velocities measured per cell (cm/s); ``signed`` false when only magnitudes are known (the paper)."""

    name: str
    velocity_definition: str
    duration_s: float
    signed: bool
    cells: Mapping[Cell, tuple[float, float]]
    source: str = "<dict>"

    def velocity(self, gait: str, amplitude_bar: float, frequency_hz: float) -> tuple[float, float] | None:
        """``(v_x, v_y)`` of the cell, or None where the table has no such cell."""
        return self.cells.get(cell_key(gait, amplitude_bar, frequency_hz))

    def speed_cm_s(self, cell: Cell) -> float:
        """Resultant speed of a cell (cm/s)."""
        return math.hypot(*self.cells[cell])

    @property
    def gaits(self) -> list[str]:
        """The table's gaits in their first order of appearance."""
        return list(dict.fromkeys(c[0] for c in self.cells))

    @property
    def amplitudes_bar(self) -> list[float]:
        return sorted({c[1] for c in self.cells})

    @property
    def frequencies_hz(self) -> list[float]:
        return sorted({c[2] for c in self.cells})


#: The ``measured_table:`` section of a measured table file (its rows: :func:`row_fields`).
MEASURED_TABLE = Table("measured_table", (
    Field("name", str, None, description="where the table comes from (default: the file)"),
    Field("velocity_definition", str, "", description="how the velocities were measured"),
    Field("duration_s", float, minimum=0.0, maximum=MAX_RUN_S, above_minimum=True, unit="s",
          description="run time of every cell"),
    Field("signed", bool, False, description="true if the velocities carry the sign of the displacement"),
    Field("columns", list, item=str, expected_text=f"{list(MEASURED_COLUMNS)}", description="the row layout"),
    Field("rows", list, nonempty=True, expected_text=f"a non-empty list of rows {list(MEASURED_COLUMNS)}",
          description="one row per cell"),
), description="a mapping of name, velocity_definition, duration_s, signed, columns, rows; see "
               f"config/{PAPER_TABLE_FILE}")


def row_fields(robot: RobotDescription, gait_names: Iterable[str]) -> tuple[Field, ...]:
    """The columns of a measured table's row (:data:`MEASURED_COLUMNS`): a cell and its velocity (cm/s)."""
    return (gait_field(gait_names), amplitude_field(robot), FREQUENCY_FIELD,
            Field("vx_cm_s", float, unit="cm/s"), Field("vy_cm_s", float, unit="cm/s"))


def measured_table_from_dict(data: Any, source: str = "<dict>", robot: RobotDescription | None = None
                             ) -> MeasuredTable:
    """Validate a parsed measured table (``measured_table:``); a :class:`ConfigurationError` says what is wrong."""
    section_ = MEASURED_TABLE.read(document(data, "measured_table", source, what=MEASURED_TABLE.description,
                                             sections=MEASURED_TABLE.names), source)
    if list(section_["columns"]) != list(MEASURED_COLUMNS):
        raise refusal(source, MEASURED_TABLE.key("columns"), list(section_["columns"]), f"{list(MEASURED_COLUMNS)}")
    columns = row_fields(robot or default_robot(), list_gaits())
    cells: dict[Cell, tuple[float, float]] = {}
    for index, row in enumerate(section_["rows"]):
        key = MEASURED_TABLE.key(f"rows[{index}]")
        if not isinstance(row, Sequence) or isinstance(row, str) or len(row) != len(columns):
            raise refusal(source, key, row, f"a list {list(MEASURED_COLUMNS)}")
        gait, amplitude, frequency, vx, vy = (f.check(v, source, f"{key}.{f.name}") for f, v in zip(columns, row))
        if not section_["signed"] and (vx < 0 or vy < 0):
            name, value = ("vx_cm_s", row[3]) if vx < 0 else ("vy_cm_s", row[4])  # as written
            raise refusal(source, f"{key}.{name}", value,
                          "a magnitude >= 0 in a table of magnitudes; set 'signed: true' if the signs are meant")
        cell = cell_key(gait, amplitude, frequency)
        if cell in cells:
            raise refusal(source, key, list(row), f"one row per cell; cell {cell} appears twice")
        cells[cell] = (vx, vy)
    return MeasuredTable(name=section_["name"] or source, velocity_definition=section_["velocity_definition"],
                         duration_s=section_["duration_s"], signed=section_["signed"], cells=cells, source=source)


def load_measured_table(path: str | Path | None = None, robot: RobotDescription | None = None) -> MeasuredTable:
    """Read and validate a measured table (default: the paper's Table I, ``config/paper_table1.yaml``)."""
    path = Path(path) if path else config_dir() / PAPER_TABLE_FILE
    return measured_table_from_dict(read_yaml(path), str(path), robot)


def paper_table() -> MeasuredTable:
    """The paper's Table I (all 48 cells), and so the paper's grid: its gaits, amplitudes, frequencies, run time."""
    return load_measured_table()


# ------------------------------------------------------------------------------------------
# Run records
# ------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class RunRecord:
    """One run: signed traveling velocity (cm/s) and displacement (m) in the floor frame, and its status.

    ``track`` (optional, ``(n, 4)``: ``time_s, x_m, y_m, yaw_rad``) is the path for the figures; it is not
    part of the table. A failed run has NaN figures and ``status`` saying why.
    """

    gait: str
    amplitude_bar: float
    frequency_hz: float
    vx_cm_s: float = math.nan
    vy_cm_s: float = math.nan
    dx_m: float = math.nan
    dy_m: float = math.nan
    status: str = OK
    track: np.ndarray | None = field(default=None, compare=False, repr=False)

    @property
    def cell(self) -> Cell:
        return cell_key(self.gait, self.amplitude_bar, self.frequency_hz)

    @property
    def ok(self) -> bool:
        return self.status == OK

    @property
    def outcome(self) -> str:
        """``ok``, ``skipped`` (the operator said no: not a failure) or ``failed``."""
        return OK if self.ok else SKIPPED if self.status.startswith(f"{SKIPPED}:") else FAILED

    @property
    def speed_cm_s(self) -> float:
        """Resultant speed (cm/s); NaN for a failed run."""
        return math.hypot(self.vx_cm_s, self.vy_cm_s)

    @classmethod
    def failed(cls, cell: Cell, reason: str, track: np.ndarray | None = None) -> RunRecord:
        """A run that gave no velocity, with the reason (one line)."""
        text = " ".join(str(reason).split()) or "unknown failure"
        return cls(*cell, status=f"{FAILED}: {text}", track=track)

    @classmethod
    def skipped(cls, cell: Cell, reason: str) -> RunRecord:
        """A run not made by choice (the operator's "no"): no figures, and not a failure."""
        return cls(*cell, status=f"{SKIPPED}: {' '.join(str(reason).split())}")

    def without_track(self) -> RunRecord:
        return replace(self, track=None)


def _number(value: float, digits: int) -> str:
    if value is None or not math.isfinite(value):
        return ""
    return f"{value if round(value, digits) else 0.0:.{digits}f}"  # no "-0.000"


def table_rows(records: Iterable[RunRecord], reference: MeasuredTable | None) -> list[list[str]]:
    """The CSV rows (strings) of ``records``, the measured velocity beside each run where the table has the cell."""
    rows = []
    for r in records:
        measured = reference.velocity(*r.cell) if reference else None
        rows.append([r.gait, f"{r.amplitude_bar:g}", f"{r.frequency_hz:g}", _number(r.vx_cm_s, 3),
                     _number(r.vy_cm_s, 3), _number(r.dx_m, 4), _number(r.dy_m, 4),
                     "" if measured is None else f"{measured[0]:.2f}", "" if measured is None else f"{measured[1]:.2f}",
                     r.status])
    return rows


def write_table_csv(path: str | Path, records: Iterable[RunRecord], reference: MeasuredTable | None) -> Path:
    """Write ``table.csv`` (:data:`TABLE_COLUMNS`) atomically."""
    stream = io.StringIO()
    writer = csv.writer(stream, lineterminator="\n")
    writer.writerow(TABLE_COLUMNS)
    writer.writerows(table_rows(records, reference))
    return write_atomically(path, stream.getvalue())


def _measured(name: str, unit: str, what: str) -> Field:
    return Field(name, float, None, unit=unit, description=f"{what}; empty for a run that failed or a cell not in "
                 "the table", expected_text="a number, or empty")


#: The columns of a sweep's ``table.csv`` (:data:`TABLE_COLUMNS`), as :func:`read_table_csv` checks them.
TABLE_CSV_SCHEMA = Table("table.csv", (
    Field("gait", str, nonempty=True), Field("amplitude_bar", float, minimum=0.0, unit="bar"),
    Field("frequency_hz", float, minimum=0.0, above_minimum=True, unit="Hz"),
    _measured("vx_cm_s", "cm/s", "travelling velocity along x"), _measured("vy_cm_s", "cm/s", "along y"),
    _measured("dx_m", "m", "displacement along x"), _measured("dy_m", "m", "along y"),
    _measured("paper_vx_cm_s", "cm/s", "the reference table's v_x"),
    _measured("paper_vy_cm_s", "cm/s", "the reference table's v_y"),
    Field("status", str, nonempty=True)))
assert TABLE_CSV_SCHEMA.names == TABLE_COLUMNS


def read_table_csv(path: str | Path) -> list[RunRecord]:
    """Read a sweep's ``table.csv`` back into run records (the reference table's columns are dropped).

    Every row is checked by :data:`TABLE_CSV_SCHEMA`; a refusal names the file, the line and the cell.
    """
    def number(value: float | None) -> float:
        return math.nan if value is None else value

    return [RunRecord(row["gait"], row["amplitude_bar"], row["frequency_hz"], number(row["vx_cm_s"]),
                      number(row["vy_cm_s"]), number(row["dx_m"]), number(row["dy_m"]), row["status"])
            for row in read_csv_rows(path, TABLE_CSV_SCHEMA)]


# ------------------------------------------------------------------------------------------
# The paper's layout
# ------------------------------------------------------------------------------------------
def _pair(values: tuple[float, float] | None, width: int, no_figure: str = FAILED) -> str:
    if values is None:
        return "--".center(width)
    vx, vy = values
    if not (math.isfinite(vx) and math.isfinite(vy)):
        return no_figure.center(width)
    return f"{abs(vx):5.2f} / {abs(vy):5.2f}".center(width)


def _label(value: float, decimals: int) -> str:
    """``value`` with ``decimals`` as the paper prints it, or all its digits where those would round it (2.25)."""
    return f"{value:.{decimals}f}" if round(value, decimals) == value else f"{value:g}"


def format_table(records: Sequence[RunRecord], reference: MeasuredTable | None, label: str = "sim") -> str:
    """Text in Table I's layout: rows amplitude x frequency, per gait ``v_x / v_y`` of the runs and the table's.

    Magnitudes (cm/s), as the paper prints them; the CSV keeps the signs. Failed runs show ``failed`` and
    are listed under the table with their reasons; so are runs the operator skipped (``skipped``).
    """
    gaits = list(dict.fromkeys(r.gait for r in records))
    by_cell = {r.cell: r for r in records}
    amplitudes = sorted({r.amplitude_bar for r in records})
    frequencies = sorted({r.frequency_hz for r in records})
    ref_name = "paper" if reference is None or "Table I" in reference.name else "measured"
    width = max(15, len(label) + 10, len(ref_name) + 10)
    head1 = f"{'A (bar)':>7} {'f (Hz)':>6} |" + "|".join(f" {g:^{2 * width + 1}} " for g in gaits) + "|"
    head2 = f"{'':>7} {'':>6} |" + "|".join(f" {label + ' v_x / v_y':^{width}} {ref_name + ' v_x / v_y':^{width}} "
                                            for _ in gaits) + "|"
    rule = "-" * len(head1)
    lines = ["Traveling velocity (cm/s, magnitudes of X and Y displacement / run time)", rule, head1, head2, rule]
    for amplitude in amplitudes:
        for frequency in frequencies:
            cells = []
            for gait in gaits:
                record = by_cell.get(cell_key(gait, amplitude, frequency))
                ours = None if record is None else (record.vx_cm_s, record.vy_cm_s)
                theirs = reference.velocity(gait, amplitude, frequency) if reference else None
                no_figure = FAILED if record is None else record.outcome
                cells.append(f" {_pair(ours, width, no_figure)} {_pair(theirs, width)} ")
            lines.append(f"{_label(amplitude, 1):>7} {_label(frequency, 2):>6} |" + "|".join(cells) + "|")
        lines.append(rule)
    failures = [r for r in records if not r.ok]
    for r in failures:
        lines.append(f"{r.gait} {r.amplitude_bar:g} bar {r.frequency_hz:g} Hz: {r.status}")
    return "\n".join(lines)
