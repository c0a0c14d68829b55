"""srs_navigate: arguments, a refused goal, a run that gives up, the CSV and the plot it writes."""

import csv

import pytest

from srs_ros.tools.navigate_cli import main


def test_a_goal_outside_the_view_is_refused_with_the_reason_before_any_run(tmp_path, capsys):
    """Checked when its turn came, after every goal before it was driven (minutes), it exited 1; with every goal
    refused, --plot ended in a traceback (a helper's review). Now exit 2 before anything runs."""
    for goals in (["--goal", "4", "0"], ["--goal", "0.3", "0", "--goal", "4", "0"], ["--goal", "nan", "0"]):
        code = main([*goals, "--out", str(tmp_path / "run.csv"), "--plot", str(tmp_path / "run.png")])
        captured = capsys.readouterr()
        assert code == 2, captured
        assert f"srs_navigate: error: --goal {len(goals) // 3} of {len(goals) // 3}: goal (" in captured.err
        assert ("outside the camera's calibrated floor area" in captured.err) != ("nan" in goals), captured.err
        assert captured.out == ""


def test_a_short_run_writes_the_track_and_the_plot(tmp_path, capsys):
    out_csv, plot = tmp_path / "run.csv", tmp_path / "run.png"
    code = main(["--goal", "0.0", "0.6", "--out", str(out_csv), "--plot", str(plot), "--timeout-s", "3"])
    text = capsys.readouterr().out
    assert code == 1 and "cancelled after" in text and "gave up after 3 s" in text
    with out_csv.open() as stream:
        rows = list(csv.DictReader(stream))
    assert len(rows) >= 90 and {r["state"] for r in rows} >= {"driving", "cancelled"}
    assert rows[10]["direction"] in ("inward_rolling", "outward_rolling")
    assert plot.stat().st_size > 10_000


@pytest.mark.parametrize("argv, message", [
    (["--goal", "0", "0.5", "--out", "x.csv", "--setting", "goal_tolerance_m=-1"], "goal_tolerance_m is -1"),
    (["--goal", "0", "0.5", "--out", "x.csv", "--setting", "tolerance"], "expected NAME=VALUE"),
    (["--goal", "0", "0.5", "--out", "x.csv", "--friction", "sticky"], "friction is 'sticky'"),
])
def test_bad_settings_exit_2_with_a_message(argv, message, capsys):
    assert main(argv) == 2
    assert message in capsys.readouterr().err


def test_integer_boolean_and_list_settings_are_taken_as_ros2_param_set_reads_them(tmp_path, capsys):
    """Every value was read as a float: 3 cycles became 3.0 (refused), true and a list could not be given at all."""
    code = main(["--goal", "4", "0", "--out", str(tmp_path / "run.csv"), "--setting", "axis_move_max_cycles=3",
                 "--setting", "stop_cycle_ahead=false", "--setting", "turn_levels_rad=[-0.5, 0.0, 0.5]",
                 "--setting", "goal_tolerance_m=3e-2"])  # YAML 1.1 reads 3e-2 as text: still a number
    captured = capsys.readouterr()
    # the settings taken: the goal is what is refused, after them and before any run
    assert code == 2 and "--goal 1 of 1: goal (4.000, 0.000) m is" in captured.err, captured.err
    assert main(["--goal", "0", "0.5", "--out", "x.csv", "--setting", "stop_cycle_ahead=[1"]) == 2
    assert "--setting 'stop_cycle_ahead=[1': the value cannot be read" in capsys.readouterr().err


def test_bad_arguments_exit_2(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["--goal", "0", "--out", "x.csv"])
    assert exit_info.value.code == 2
    with pytest.raises(SystemExit) as exit_info:
        main(["--goal", "0", "0.5", "--out", "x.csv", "--plot", "x.jpg"])
    assert exit_info.value.code == 2 and "expected a .png path" in capsys.readouterr().err


@pytest.mark.parametrize("stop", [KeyboardInterrupt, "diverged"])
def test_a_run_interrupted_or_failed_leaves_no_partial_video(stop, tmp_path, monkeypatch, capsys):
    """Ctrl-C printed a traceback and left an 11 MB partial video; a divergence left one too (a helper's review).
    The run here stands in for run_navigation: a few frames, then the interruption."""
    from srs_ros.core.errors import SimulationError
    from srs_ros.tools import navigate_cli

    def stopped_after_frames(goals, config, settings, on_frame=None, **_kwargs):
        import numpy as np

        for _ in range(5):
            on_frame.write(np.zeros((480, 640, 3), np.uint8))
        raise KeyboardInterrupt if stop is KeyboardInterrupt else SimulationError("the simulation diverged")

    monkeypatch.setattr(navigate_cli, "run_navigation", stopped_after_frames)
    video = tmp_path / "nav.avi"
    video.write_bytes(b"an older video")
    code = main(["--goal", "0.0", "0.6", "--out", str(tmp_path / "nav.csv"), "--video", str(video)])
    err = capsys.readouterr().err
    assert code == (130 if stop is KeyboardInterrupt else 2), err
    assert ("interrupted; nothing written" if stop is KeyboardInterrupt else "no video written") in err
    assert video.read_bytes() == b"an older video" and sorted(p.name for p in tmp_path.iterdir()) == ["nav.avi"]


def test_a_run_that_ends_keeps_its_video(tmp_path, capsys):
    video = tmp_path / "nav.avi"
    assert main(["--goal", "0.0", "0.6", "--out", str(tmp_path / "nav.csv"), "--video", str(video),
                 "--timeout-s", "1"]) == 1
    assert video.stat().st_size > 10_000 and sorted(p.name for p in tmp_path.iterdir()) == ["nav.avi", "nav.csv"]
