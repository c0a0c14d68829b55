"""Table I as data: the paper's 48 cells, measured tables refused with the reason, table.csv and the paper's layout."""

import math
import re

import pytest
import yaml

from srs_ros.core.errors import ConfigurationError, InvalidInputError
from srs_ros.experiments.sweep import SweepGrid
from srs_ros.experiments.table import (
    TABLE_COLUMNS,
    RunRecord,
    format_table,
    load_measured_table,
    paper_table,
    read_table_csv,
    write_table_csv,
)


def test_the_paper_table_holds_all_48_cells_with_the_velocity_definition():
    table = paper_table()
    assert len(table.cells) == 48 and table.duration_s == 15.0 and not table.signed
    assert table.gaits == ["serpentine", "inward_rolling", "outward_rolling"]
    assert table.amplitudes_bar == [1.0, 2.0, 3.0, 4.0] and table.frequencies_hz == [0.25, 0.5, 0.75, 1.0]
    assert "displacement divided by the run time" in table.velocity_definition
    assert table.velocity("inward_rolling", 4, 1.0) == (5.61, 10.11)
    assert table.velocity("outward_rolling", 3, 0.5) == (5.69, 0.12)
    assert table.velocity("serpentine", 2, 0.75) == (0.14, 0.21)
    assert all(table.velocity(g, 1, f) == (0.0, 0.0) for g in table.gaits for f in table.frequencies_hz)
    # Inward rolling is faster than outward in every moving cell of the paper.
    assert all(table.speed_cm_s(("inward_rolling", a, f)) > table.speed_cm_s(("outward_rolling", a, f))
               for a in (2.0, 3.0, 4.0) for f in table.frequencies_hz)


def _table_file(tmp_path, rows, **section):
    data = {"measured_table": {"name": "lab", "velocity_definition": "d / t", "duration_s": 15.0, "signed": False,
                               "columns": ["gait", "amplitude_bar", "frequency_hz", "vx_cm_s", "vy_cm_s"],
                               "rows": rows, **section}}
    path = tmp_path / "table.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize("rows, section, expected", [
    ([["crawling", 2, 0.5, 1, 1]], {}, "measured_table.rows[0].gait is 'crawling'; expected one of"),
    ([["serpentine", 5, 0.5, 1, 1]], {}, "measured_table.rows[0].amplitude_bar is 5; expected a number in (0, 4]"),
    ([["serpentine", 2, 9, 1, 1]], {}, "measured_table.rows[0].frequency_hz is 9; expected a number in [0.01, 5]"),
    ([["serpentine", 2, 0.5, "fast", 1]], {}, "measured_table.rows[0].vx_cm_s is 'fast'"),
    ([["serpentine", 2, 0.5, -1, 1]], {}, "rows[0].vx_cm_s is -1; expected a magnitude >= 0"),
    ([["serpentine", 2, 0.5, 1]], {}, "measured_table.rows[0] is ['serpentine', 2, 0.5, 1]; expected a list"),
    ([["serpentine", 2, 0.5, 1, 1], ["serpentine", 2.0, 0.50, 2, 2]], {}, "rows[1] is .* appears twice"),
    ([], {}, "measured_table.rows is []; expected a non-empty list of rows"),
    ([["serpentine", 2, 0.5, 1, 1]], {"duration_s": 0}, "measured_table.duration_s is 0; expected a number in (0, "),
    ([["serpentine", 2, 0.5, 1, 1]], {"duration_s": 5000}, "measured_table.duration_s is 5000; expected a number in "
                                                            "(0, 3600]"),  # a calibration's runs all failed, exit 0
    ([["serpentine", 2, 0.5, 1, 1]], {"columns": ["gait", "A", "f", "vx", "vy"]}, "measured_table.columns is"),
    ([["serpentine", 2, 0.5, 1, 1]], {"rate": 2}, "measured_table.rate is not a known key"),
])
def test_a_malformed_measured_table_is_refused_with_what_is_wrong(tmp_path, rows, section, expected):
    with pytest.raises(ConfigurationError, match=re.escape(expected).replace(r"\.\*", ".*")):
        load_measured_table(_table_file(tmp_path, rows, **section))


def test_a_signed_lab_table_loads(tmp_path):
    table = load_measured_table(_table_file(tmp_path, [["inward_rolling", 3, 0.5, -2.5, 4.0]], signed=True))
    assert table.velocity("inward_rolling", 3.0, 0.5) == (-2.5, 4.0) and table.speed_cm_s(("inward_rolling", 3.0, 0.5))
    assert math.isclose(table.speed_cm_s(("inward_rolling", 3.0, 0.5)), math.hypot(2.5, 4.0))


@pytest.mark.parametrize("gaits, amplitudes, frequencies, duration, expected", [
    (["slithering"], [2], [0.5], 15, r"gaits\[0\] is 'slithering'; expected one of \['helical_rolling'"),
    (["serpentine"], [4.5], [0.5], 15, r"amplitudes\[0\] is 4.5; expected a number in \(0, 4\] \(bar\)"),
    (["serpentine"], [2, 0], [0.5], 15, r"amplitudes\[1\] is 0; expected a number in \(0, 4\]"),
    (["serpentine"], [], [0.5], 15, r"amplitudes is \[\]; expected at least one value"),
    (["serpentine"], [2], [], 15, r"frequencies is \[\]; expected at least one value"),
    ([], [2], [0.5], 15, r"gaits is \[\]; expected at least one value"),
    (["serpentine"], [2], [0.5], 0, r"duration_s is 0; expected a number in \(0, 3600\] \(s\)"),
    (["serpentine"], [2], [0.5], 1e12, r"duration_s is 1000000000000.0; expected a number in \(0, 3600\]"),  # OOM
])
def test_a_bad_grid_is_refused_with_the_reason(gaits, amplitudes, frequencies, duration, expected):
    with pytest.raises(InvalidInputError, match=expected):
        SweepGrid.create(gaits, amplitudes, frequencies, duration)


def test_values_that_key_one_cell_are_one_run():
    """2 and 2.0000001 bar key the same cell (1e-6) and ran it twice, two identical rows (a helper's review)."""
    grid = SweepGrid.create(["serpentine"], [2, 2.0000001, 3], [0.5, 0.5000001], 1.0)
    assert grid.cells() == [("serpentine", 2.0, 0.5), ("serpentine", 3.0, 0.5)]


def test_the_grid_lists_cells_in_the_papers_order():
    grid = SweepGrid.create(["outward_rolling", "serpentine"], [4, 2, 2.0], [1, 0.25], 3)
    assert grid.amplitudes_bar == (4.0, 2.0)  # repeats dropped, order kept
    assert grid.cells()[:3] == [("outward_rolling", 4.0, 1.0), ("outward_rolling", 4.0, 0.25),
                                ("outward_rolling", 2.0, 1.0)] and len(grid) == len(grid.cells()) == 8


def test_table_csv_round_trip_with_the_papers_values_and_failures(tmp_path):
    records = [RunRecord("inward_rolling", 4.0, 1.0, -3.2, 9.5, -0.48, 1.425),
               RunRecord.failed(("inward_rolling", 4.0, 0.5), "SimulationError: diverged\n at t = 3 s"),
               RunRecord("sidewinding", 2.0, 0.5, 0.0, -0.0, 0.0, -0.0)]
    path = write_table_csv(tmp_path / "table.csv", records, paper_table())
    lines = path.read_text().splitlines()
    assert lines[0] == ",".join(TABLE_COLUMNS)
    assert lines[1] == "inward_rolling,4,1,-3.200,9.500,-0.4800,1.4250,5.61,10.11,ok"
    assert lines[2] == "inward_rolling,4,0.5,,,,,4.16,9.11,failed: SimulationError: diverged at t = 3 s"
    assert lines[3] == "sidewinding,2,0.5,0.000,0.000,0.0000,0.0000,,,ok"  # no paper cell; no "-0.000"
    back = read_table_csv(path)
    assert [r.cell for r in back] == [r.cell for r in records] and back[0].vx_cm_s == -3.2
    assert not back[1].ok and math.isnan(back[1].vx_cm_s)
    assert [p.name for p in tmp_path.iterdir()] == ["table.csv"]  # no temporary file left behind


@pytest.mark.parametrize(("line", "said"), [
    ("inward_rolling,4,1,fast,9.5,0,0,,,ok", "table.csv:2: vx_cm_s is 'fast'; expected a number, or empty (cm/s)."),
    ("inward_rolling,4,nan,1,1,0,0,,,ok", "table.csv:2: frequency_hz is nan; expected a number > 0 (Hz)."),
    ("inward_rolling,4,1,1,1,0,0,,,", "table.csv:2: status is ''; expected a non-empty string."),
    ("inward_rolling,4,1,1,1,0,0,,ok", "table.csv:2: the row is 'inward_rolling,4,1,1,1,0,0,,ok'; expected 10 "
                                       "cells, one a column."),
])
def test_a_table_csv_with_a_bad_cell_is_refused_with_its_line_and_column(tmp_path, line, said):
    """read_table_csv raised a bare ValueError for a cell that is not a number (and took 'nan' as a frequency)."""
    path = tmp_path / "table.csv"
    path.write_text(",".join(TABLE_COLUMNS) + "\n" + line + "\n", encoding="utf-8")
    with pytest.raises(ConfigurationError) as raised:
        read_table_csv(path)
    assert str(raised.value) == f"{tmp_path}/{said}"
    path.write_bytes(b"gait\xff\n")
    with pytest.raises(ConfigurationError, match="cannot be read as CSV"):
        read_table_csv(path)


def test_the_printed_table_has_the_papers_layout():
    records = [RunRecord(g, a, f, 1.0 * a, -2.0 * f, 0.15 * a, -0.3 * f) for g in ("serpentine", "inward_rolling")
               for a in (2.0, 4.0) for f in (0.25, 1.0)]
    records[-1] = RunRecord.failed(records[-1].cell, "no pose")
    text = format_table(records, paper_table())
    lines = text.splitlines()
    assert "serpentine" in lines[2] and "inward_rolling" in lines[2] and lines[2].index("serpentine") < lines[2].index(
        "inward_rolling")
    assert "sim v_x / v_y" in lines[3] and "paper v_x / v_y" in lines[3]
    row = next(line for line in lines if line.startswith("    4.0   0.25"))
    assert " 4.00 /  0.50 " in row and " 0.76 /  0.36 " in row and " 3.12 /  7.55 " in row
    assert "failed" in next(line for line in lines if line.startswith("    4.0   1.00"))
    assert lines[-1] == "inward_rolling 4 bar 1 Hz: failed: no pose"


def test_cells_that_the_papers_decimals_would_round_are_printed_with_all_their_digits():
    """2.25 bar 0.125 Hz and 2.2 bar 0.12 Hz printed alike as "2.2 0.12" (a helper's review)."""
    records = [RunRecord("serpentine", a, f, 1.0, 1.0, 0.1, 0.1) for a, f in ((2.25, 0.125), (2.2, 0.12))]
    lines = format_table(records, None).splitlines()
    assert any(line.startswith("   2.25  0.125 |") for line in lines), lines
    assert any(line.startswith("    2.2   0.12 |") for line in lines), lines
