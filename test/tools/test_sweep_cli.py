"""``srs_sweep`` offline: a small grid end to end, calibration on a tiny table, and bad input refused with exit 2."""

import csv
import dataclasses

import pytest
import yaml

from srs_ros.experiments.calibration import table_error
from srs_ros.experiments.sweep import SweepGrid, run_cell
from srs_ros.experiments.table import TABLE_COLUMNS, load_measured_table, paper_table, read_table_csv
from srs_ros.sim.config import load_sim_config
from srs_ros.tools import sweep_cli
from srs_ros.tools.sweep_cli import main

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow(seconds=6)
def test_offline_sweep_of_a_small_grid_writes_the_table_figures_and_prints_the_papers_layout(tmp_path, capsys):
    out = tmp_path / "sweep"
    code = main(["--gait", "inward_rolling", "--gait", "serpentine", "--amplitudes", "1", "4", "--frequencies", "1",
                 "0.5", "--duration-s", "1.5", "--workers", "2", "--out", str(out)])
    printed = capsys.readouterr()
    assert code == 0, printed.err
    with (out / "table.csv").open() as stream:
        rows = list(csv.DictReader(stream))
    assert list(rows[0]) == list(TABLE_COLUMNS)
    assert [(r["gait"], r["amplitude_bar"], r["frequency_hz"]) for r in rows] == [
        ("inward_rolling", "1", "1"), ("inward_rolling", "1", "0.5"), ("inward_rolling", "4", "1"),
        ("inward_rolling", "4", "0.5"), ("serpentine", "1", "1"), ("serpentine", "1", "0.5"), ("serpentine", "4", "1"),
        ("serpentine", "4", "0.5")]
    assert (rows[2]["paper_vx_cm_s"], rows[2]["paper_vy_cm_s"]) == ("5.61", "10.11")
    assert all(r["status"] == "ok" for r in rows)
    assert all(float(r["vx_cm_s"]) == 0.0 == float(r["vy_cm_s"]) for r in rows if r["amplitude_bar"] == "1")  # deadzone
    records = read_table_csv(out / "table.csv")
    assert records[2].speed_cm_s > 2.0  # inward rolling at 4 bar, 1 Hz rolls
    # The pool gives what one run in this process gives (deterministic, in the grid's order).
    alone = run_cell(("inward_rolling", 4.0, 1.0), 1.5, load_sim_config(), keep_track=False)
    assert (round(alone.vx_cm_s, 3), round(alone.vy_cm_s, 3)) == (records[2].vx_cm_s, records[2].vy_cm_s)
    for name in ("table.png", "paths_inward_rolling.png", "paths_serpentine.png"):
        assert (out / name).read_bytes()[:8] == PNG
    assert "sim v_x / v_y  paper v_x / v_y" in printed.out and " 5.61 / 10.11 " in printed.out
    assert "8 runs (simulated offline, 1.5 s each, 2 workers" in printed.out
    assert "simulated runs" in printed.err and "8/8" in printed.err  # the progress bar, on stderr


def _lab_table(tmp_path, rows, duration_s=1.5):
    path = tmp_path / "lab_table.yaml"
    path.write_text(yaml.safe_dump({"measured_table": {
        "name": "a lab's table", "velocity_definition": "displacement / run time", "duration_s": duration_s,
        "signed": False, "columns": ["gait", "amplitude_bar", "frequency_hz", "vx_cm_s", "vy_cm_s"], "rows": rows}}))
    return path


@pytest.mark.slow(seconds=4)
def test_calibration_on_a_tiny_table_writes_a_loadable_sim_yaml_and_the_error_does_not_grow(tmp_path, capsys):
    table = _lab_table(tmp_path, [["inward_rolling", 4.0, 1.0, 5.61, 10.11], ["outward_rolling", 4.0, 1.0, 6.56, 6.75],
                                  ["serpentine", 1.0, 1.0, 0.0, 0.0]])
    out = tmp_path / "cal"
    code = main(["--calibrate", str(table), "--fit", "friction_coefficient", "--max-evaluations", "2",
                 "--fit-duration-s", "1", "--workers", "2", "--no-progress", "--out", str(out)])
    printed = capsys.readouterr()
    assert code == 0, printed.err
    assert "evaluation 1/2" in printed.err and "evaluation 2/2" in printed.err and "evaluation 3" not in printed.err
    config = load_sim_config(out / "sim.yaml")  # a valid sim.yaml
    header = (out / "sim.yaml").read_text().splitlines()[0]
    assert header.startswith("# Simulation fitted by srs_sweep --calibrate to a lab's table")
    reference = load_measured_table(table)
    before, after = read_table_csv(out / "table_before.csv"), read_table_csv(out / "table_after.csv")
    assert [r.cell for r in before] == [r.cell for r in after] == list(reference.cells)
    assert table_error(after, reference) <= table_error(before, reference) + 1e-3  # rounding of the CSV
    fitted = next(line for line in printed.out.splitlines() if line.startswith(("fitted:", "the best fit")))
    if fitted.startswith("fitted:"):
        assert f"friction_coefficient 0.8 -> {config.contact.friction_coefficient:g}" in fitted
    else:
        assert config.contact.friction_coefficient == 0.8
    for line in ("inward_rolling       4     1 |    11.56 |", "serpentine           1     1 |     0.00 |"):
        assert line in printed.out  # each cell's error before and after
    assert "RMS log speed error:" in printed.out and "[met] 1 bar cells do not move" in printed.out
    evaluations = (out / "evaluations.csv").read_text().splitlines()
    assert evaluations[0] == "index,friction_coefficient,error,wall_time_s" and len(evaluations) == 3
    assert (out / "calibration.txt").read_text().startswith("Calibration of ")


def test_without_grid_options_the_sweep_runs_the_grid_of_the_papers_table(tmp_path, monkeypatch):
    """The paper's grid is its Table I (config/paper_table1.yaml), in one place: a changed table changes the sweep."""
    paper = SweepGrid.of_table(paper_table())
    assert (paper.gaits, paper.amplitudes_bar, paper.frequencies_hz, paper.duration_s, len(paper)) == (
        ("serpentine", "inward_rolling", "outward_rolling"), (1.0, 2.0, 3.0, 4.0), (0.25, 0.5, 0.75, 1.0), 15.0, 48)
    smaller = dataclasses.replace(paper_table(), cells={("outward_rolling", 2.0, 0.5): (1.0, 2.0)}, duration_s=3.0)
    monkeypatch.setattr(sweep_cli, "paper_table", lambda: smaller)
    swept = []
    monkeypatch.setattr(sweep_cli, "_offline", lambda args, grid, reference, out, runner: swept.append(grid) or 0)
    assert main(["--out", str(tmp_path / "out")]) == 0
    assert swept == [SweepGrid.create(["outward_rolling"], [2.0], [0.5], 3.0)]


@pytest.mark.parametrize("args, expected", [
    (["--gait", "slithering"], "gaits[0] is 'slithering'; expected one of ["),
    (["--gait", "serpentine", "--amplitudes", "4.5"], "amplitudes[0] is 4.5; expected a number in (0, 4] (bar)"),
    (["--gait", "serpentine", "--amplitudes"], "amplitudes is []; expected at least one value"),
    (["--gait", "serpentine", "--frequencies"], "frequencies is []; expected at least one value"),
    (["--gait", "serpentine", "--friction", "sticky"], "friction is 'sticky'"),
])
def test_bad_input_exits_2_with_the_reason_and_writes_nothing(tmp_path, capsys, args, expected):
    out = tmp_path / "out"
    assert main([*args, "--duration-s", "1", "--out", str(out)]) == 2
    assert expected in capsys.readouterr().err
    assert not out.exists()


def test_a_malformed_measured_table_exits_2_before_anything_runs(tmp_path, capsys):
    bad = _lab_table(tmp_path, [["serpentine", 2.0, 0.5, 1.0]])
    out = tmp_path / "cal"
    assert main(["--calibrate", str(bad), "--out", str(out)]) == 2
    assert "rows[0]" in capsys.readouterr().err and not out.exists()
    assert main(["--calibrate", str(tmp_path / "missing.yaml"), "--out", str(out)]) == 2
    assert "no such file" in capsys.readouterr().err
    assert main(["--reference", str(bad), "--gait", "serpentine", "--out", str(out)]) == 2
    assert not out.exists()
    assert main(["--calibrate", str(_lab_table(tmp_path, [["serpentine", 2.0, 0.5, 0.1, 0.1]])), "--fit", "grip",
                 "--out", str(out)]) == 2
    assert "unknown fit parameter 'grip'" in capsys.readouterr().err
    assert not out.exists()  # an empty folder was left (a helper's review)
    assert main(["--calibrate", str(_lab_table(tmp_path, [["serpentine", 2.0, 0.5, 0.1, 0.1]])), "--fit-duration-s",
                 "0", "--out", str(out)]) == 2  # 0 was taken as the table's run time
    assert "--fit-duration-s 0: expected seconds in (0, 3600]" in capsys.readouterr().err and not out.exists()


def test_a_folder_with_an_earlier_sweeps_results_is_refused_before_anything_runs(tmp_path, capsys):
    """A second sweep into a folder mixed its table with the first one's plots (a helper's review)."""
    out = tmp_path / "sweep"
    out.mkdir()
    (out / "paths_serpentine.png").write_bytes(b"an earlier sweep's plot")
    assert main(["--gait", "inward_rolling", "--amplitudes", "2", "--frequencies", "1", "--duration-s", "1",
                 "--out", str(out)]) == 2
    assert "holds an earlier run's results (paths_serpentine.png); use a new folder" in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == ["paths_serpentine.png"]


def test_a_calibration_whose_runs_failed_exits_1_and_ctrl_c_writes_the_runs_done(tmp_path, capsys, monkeypatch):
    """--calibrate said 0 with every run failed; an offline sweep stopped by Ctrl-C wrote nothing, though its help
    says what was done is written (a helper's review). In this process (--workers 1), a stand-in run_cell."""
    from srs_ros.experiments import sweep as sweep_module
    from srs_ros.experiments.table import RunRecord

    monkeypatch.setattr(sweep_module, "run_cell", lambda cell, *_a, **_k: RunRecord.failed(cell, "a stand-in"))
    table = _lab_table(tmp_path, [["inward_rolling", 4.0, 1.0, 5.61, 10.11]])
    assert main(["--calibrate", str(table), "--fit", "friction_coefficient", "--max-evaluations", "1",
                 "--fit-duration-s", "1", "--workers", "1", "--no-progress", "--out", str(tmp_path / "cal")]) == 1
    capsys.readouterr()

    def interrupted_after_two(cell, *_args, **_kwargs):
        if len(calls) == 2:
            raise KeyboardInterrupt
        calls.append(cell)
        return RunRecord.failed(cell, "a stand-in run")

    calls = []
    monkeypatch.setattr(sweep_module, "run_cell", interrupted_after_two)
    out = tmp_path / "sweep"
    assert main(["--gait", "inward_rolling", "--amplitudes", "2", "3", "4", "--frequencies", "1", "--duration-s", "1",
                 "--workers", "1", "--no-progress", "--out", str(out)]) == 130
    assert [r.cell for r in read_table_csv(out / "table.csv")] == calls  # the two runs done, in the grid's order


def test_a_calibration_stopped_by_ctrl_c_writes_its_evaluations_so_far_and_no_sim_yaml(tmp_path, capsys,
                                                                                       monkeypatch):
    """Ctrl-C during --calibrate wrote nothing: an hour of a cluster's search lost (a helper's review)."""
    from srs_ros.experiments import sweep as sweep_module
    from srs_ros.experiments.table import RunRecord

    def interrupted_at_the_fourth(cell, duration_s, config, *_args, **_kwargs):
        calls.append(cell)  # the full-length run before, then one run an evaluation
        if len(calls) == 4:
            raise KeyboardInterrupt
        speed_cm_s = 10.0 * config.contact.friction_coefficient
        return RunRecord(*cell, speed_cm_s, 0.0, speed_cm_s * duration_s / 100, 0.0)

    calls = []
    monkeypatch.setattr(sweep_module, "run_cell", interrupted_at_the_fourth)
    out = tmp_path / "cal"
    assert main(["--calibrate", str(_lab_table(tmp_path, [["inward_rolling", 4.0, 1.0, 5.61, 10.11]])), "--fit",
                 "friction_coefficient", "--max-evaluations", "6", "--fit-duration-s", "1", "--workers", "1",
                 "--no-progress", "--out", str(out)]) == 130
    rows = (out / "evaluations.csv").read_text().splitlines()
    assert rows[0] == "index,friction_coefficient,error,wall_time_s"
    assert [r.split(",")[0] for r in rows[1:]] == ["1", "2"]
    assert float(rows[1].split(",")[1]) == 0.8 and not (out / "sim.yaml").exists()
    assert "interrupted after 2 evaluations; the best so far, error" in capsys.readouterr().err


def test_an_unwritable_output_folder_exits_2(tmp_path, capsys):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    assert main(["--gait", "serpentine", "--amplitudes", "2", "--frequencies", "1", "--duration-s", "1",
                 "--out", str(blocker / "sweep")]) == 2
    assert "cannot write there" in capsys.readouterr().err
    assert blocker.read_text() == "not a folder"


def test_ctrl_c_before_a_runs_bag_is_opened_does_not_say_the_bag_keeps_anything(tmp_path):
    """A Ctrl-C while waiting for the rig (before the bag exists) was recorded as "its bag keeps what was
    recorded" (a helper's review); once the bag is open it is."""
    import argparse

    from tqdm import tqdm

    class Interrupted:
        """A RosSweep stand-in: its run is interrupted, before or after opening its bag (``open_bag``)."""

        def __init__(self, open_bag: bool):
            self.open_bag = open_bag

        def run(self, cell, duration_s, bag, go):
            if self.open_bag:
                bag.mkdir()
            raise KeyboardInterrupt

    grid = SweepGrid.create(["inward_rolling"], [4.0], [1.0], duration_s=5.0)
    args = argparse.Namespace(yes=True, on_failure="continue")
    said = {}
    for open_bag in (False, True):
        bags = tmp_path / f"bags_{open_bag}"
        bags.mkdir()
        with tqdm(disable=True) as bar:
            records, code = sweep_cli._run_cells(Interrupted(open_bag), grid, bags, args, bar)
        assert code == sweep_cli.EXIT_INTERRUPTED and len(records) == 1
        said[open_bag] = records[0].status
    assert said[False] == "failed: interrupted (Ctrl-C); before its bag was opened: no bag", said
    assert said[True] == "failed: interrupted (Ctrl-C); its bag keeps what was recorded", said


@pytest.mark.parametrize("argv, message", [
    (["--calibrate", "config/paper_table1.yaml", "--gait", "bogus_gait"],
     "--gait: --calibrate does not read it (only --ros and the offline sweep); leave it out"),
    (["--calibrate", "config/paper_table1.yaml", "--duration-s", "-5"], "--duration-s: --calibrate does not read it"),
    (["--ros", "--friction", "garbage"], "--friction: --ros does not read it (only --calibrate and the offline sweep)"),
    (["--ros", "--workers", "64"], "--workers: --ros does not read it"),
    (["--ros", "--settle-s", "-3"], "--settle-s -3: expected seconds >= 0"),
    (["--settle-s", "1"], "--settle-s: the offline sweep does not read it (only --ros)"),
    (["--max-evaluations", "5"], "--max-evaluations: the offline sweep does not read it (only --calibrate)"),
])
def test_options_the_chosen_mode_would_ignore_are_refused_before_anything_runs(argv, message, tmp_path, capsys):
    """Each was ignored without a word, even an invalid value; --calibrate then ran its 48 cells (a helper's review)."""
    with pytest.raises(SystemExit) as refused:
        main([*argv, "--out", str(tmp_path / "out")])
    assert refused.value.code == 2 and message in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_runs_the_operator_skipped_are_not_failures_in_the_summary_the_table_or_the_exit_code(tmp_path, capsys):
    from srs_ros.experiments.table import RunRecord

    made = RunRecord("inward_rolling", 2.0, 1.0, 1.5, 0.5, 0.15, 0.05)
    skipped = RunRecord.skipped(("inward_rolling", 3.0, 1.0), "no go from the operator")
    code = sweep_cli._finish([made, skipped], paper_table(), tmp_path, "tracked", 1.0, "over ROS")
    out = capsys.readouterr().out
    assert code == sweep_cli.EXIT_OK and "2 runs (over ROS) in 1.0 s wall time; 0 failed, 1 skipped" in out
    assert "    skipped    " in out and "inward_rolling 3 bar 1 Hz: skipped: no go from the operator" in out
    assert [r.outcome for r in read_table_csv(tmp_path / "table.csv")] == ["ok", "skipped"]
    failed = RunRecord.failed(("inward_rolling", 3.0, 1.0), "no pose")
    assert sweep_cli._finish([made, failed], paper_table(), tmp_path, "tracked", 1.0, "") == sweep_cli.EXIT_FAILED_RUNS
