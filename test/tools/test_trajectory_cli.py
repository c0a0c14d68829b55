"""The srs_trajectory tool: CSV and PNG outputs, the gait list, and exit code 2 with a message on bad arguments."""

import csv
import struct

import pytest

from srs_ros.plotting import DPI, FIGURE_SIZE_IN
from srs_ros.tools.trajectory_cli import main


def _png_size(path):
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", data[16:24])


def test_writes_csv_and_both_figures(tmp_path, capsys):
    out, plot = tmp_path / "traj.csv", tmp_path / "traj.png"
    code = main(["--gait", "inward_rolling", "--amplitude-bar", "4", "--frequency-hz", "1", "--samples", "16",
                 "--out", str(out), "--plot", str(plot)])
    assert code == 0
    assert "inward_rolling" in capsys.readouterr().out
    with out.open() as stream:
        rows = list(csv.DictReader(stream))
    assert len(rows) == 16
    assert list(rows[0])[:2] == ["phase", "time_s"] and "m3_pma3" in rows[0] and "fit_error_mm" in rows[0]
    assert max(float(r[f"m{i}_pma{j}_bar"]) for r in rows for i in (1, 2, 3) for j in (1, 2, 3)) == pytest.approx(4.0)
    expected = (int(FIGURE_SIZE_IN[0] * DPI), int(FIGURE_SIZE_IN[1] * DPI))
    for name in ("traj_shapes.png", "traj_joints.png"):
        path = tmp_path / name
        assert path.stat().st_size > 10_000
        assert _png_size(path) == expected


@pytest.mark.parametrize("argv", [["--list"], ["--gait", "list"]])
def test_lists_gaits_and_parameters(argv, capsys):
    assert main(argv) == 0
    text = capsys.readouterr().out
    for name in ("serpentine", "inward_rolling", "outward_rolling", "sidewinding", "helical_rolling", "radius_m"):
        assert name in text


@pytest.mark.parametrize("argv,message", [
    (["--gait", "slither", "--amplitude-bar", "2", "--frequency-hz", "1"], "unknown gait"),
    (["--gait", "serpentine", "--amplitude-bar", "5", "--frequency-hz", "1"], "amplitude_bar"),
    (["--gait", "serpentine", "--amplitude-bar", "0", "--frequency-hz", "1"], "amplitude_bar"),
    (["--gait", "serpentine", "--amplitude-bar", "2", "--frequency-hz", "-1"], "frequency_hz"),
    (["--gait", "serpentine", "--amplitude-bar", "2", "--frequency-hz", "1", "--samples", "4"], "samples"),
    (["--gait", "inward_rolling", "--amplitude-bar", "2", "--frequency-hz", "1", "--param", "radius_m=9"],
     "radius_m"),
    (["--gait", "inward_rolling", "--amplitude-bar", "2", "--frequency-hz", "1", "--param", "radius_m"],
     "NAME=VALUE"),
])
def test_bad_values_exit_2_with_a_message(argv, message, capsys):
    assert main(argv) == 2
    assert message in capsys.readouterr().err


@pytest.mark.parametrize("argv", [
    ["--gait", "serpentine"],
    ["--gait", "serpentine", "--amplitude-bar", "two", "--frequency-hz", "1"],
    ["--gait", "serpentine", "--amplitude-bar", "2", "--frequency-hz", "1", "--plot", "x.jpg"],
])
def test_bad_arguments_exit_2(argv, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    assert "error" in capsys.readouterr().err


def test_strict_exits_3_on_poor_samples(tmp_path, capsys):
    code = main(["--gait", "serpentine", "--amplitude-bar", "2", "--frequency-hz", "1", "--samples", "8",
                 "--param", "body_wavelengths=2", "--param", "poor_fit_mm=1", "--strict"])
    assert code == 3
    assert "warning" in capsys.readouterr().err


def test_a_robot_file_that_cannot_be_read_is_said_so_and_plot_cycles_is_bounded(tmp_path, capsys):
    """A helper's review: an unreadable --robot was "cannot write output"; --plot-cycles 1000000 asked for 14 GB."""
    robot = tmp_path / ("r" * 300 + ".yaml")  # a name too long for the file system
    assert main(["--gait", "serpentine", "--amplitude-bar", "2", "--frequency-hz", "1", "--robot", str(robot)]) == 2
    err = capsys.readouterr().err
    assert f"cannot read --robot {robot}" in err and "cannot write" not in err, err
    with pytest.raises(SystemExit) as exit_info:
        main(["--gait", "serpentine", "--amplitude-bar", "2", "--frequency-hz", "1", "--plot-cycles", "1000000"])
    assert exit_info.value.code == 2
    assert "--plot-cycles 1000000: expected an integer from 1 to 1000" in capsys.readouterr().err


def test_the_frequency_help_gives_the_range_taken(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    assert "cycle frequency: a number in [0.01, 5] (Hz)" in " ".join(capsys.readouterr().out.split())


def test_samples_beyond_the_local_top_or_the_machines_memory_exit_2_with_what_to_do(monkeypatch, capsys):
    """--samples 100000 (then the top) ended in a MemoryError traceback, exit 1 (a helper's review)."""
    from srs_ros.tools import trajectory_cli

    args = ["--gait", "inward_rolling", "--amplitude-bar", "4", "--frequency-hz", "1"]
    assert main([*args, "--samples", "20000"]) == 2
    assert "samples is 20000; expected an integer in [8, 10000]" in capsys.readouterr().err

    def out_of_memory(*_args, **_kwargs):
        raise MemoryError

    monkeypatch.setattr(trajectory_cli, "generate_cycle", out_of_memory)
    assert main([*args, "--samples", "10000"]) == 2
    assert "--samples 10000 needs more memory than this machine gives; use fewer samples" in capsys.readouterr().err


def test_outputs_that_cannot_be_written_are_refused_before_the_fit_and_nothing_is_left(tmp_path, capsys):
    """A plot in an unwritable folder, or a metadata path that is a folder, failed after the CSV was written: exit 2
    with a CSV left behind, once without its metadata (a helper's review)."""
    base = ["--gait", "inward_rolling", "--amplitude-bar", "4", "--frequency-hz", "1", "--samples", "16"]
    assert main([*base, "--out", str(tmp_path / "a.csv"), "--plot", "/proc/nodir/a.png"]) == 2
    assert "--plot (shapes) /proc/nodir/a_shapes.png: cannot write there" in capsys.readouterr().err
    (tmp_path / "b.csv.yaml").mkdir()
    assert main([*base, "--out", str(tmp_path / "b.csv")]) == 2
    assert "--out's metadata" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.csv.yaml"]


def test_an_output_on_the_robot_file_it_reads_is_refused(tmp_path, capsys):
    """``--robot r.yaml --out r.yaml`` replaced the robot description with the CSV (a review of the day's changes)."""
    from srs_ros.core.robot import config_dir

    robot = tmp_path / "r.yaml"
    robot.write_text((config_dir() / "robot.yaml").read_text())
    before = robot.read_text()
    assert main(["--gait", "inward_rolling", "--amplitude-bar", "3", "--frequency-hz", "1", "--samples", "16",
                 "--robot", str(robot), "--out", str(robot)]) == 2
    assert f"--out {robot}: the same file as --robot" in capsys.readouterr().err and robot.read_text() == before
