"""srs_sim: one simulated run -> track CSV, Table I velocity, real-time factor, plot, video; exit 2 on bad input."""

import csv
import subprocess

import cv2
import numpy as np
import pytest
import yaml
from srs_testing import script_path

from srs_ros.sim.config import default_sim_config_path
from srs_ros.tools import sim_cli


def read_rows(path):
    with open(path, newline="") as stream:
        reader = csv.reader(stream)
        return next(reader), np.array([[float(v) for v in row] for row in reader])


def test_a_run_writes_the_track_prints_the_velocity_and_saves_plot_and_video(tmp_path, capsys):
    out, plot, video = tmp_path / "run.csv", tmp_path / "run.png", tmp_path / "run.avi"
    code = sim_cli.main(["--gait", "inward_rolling", "--amplitude-bar", "3", "--frequency-hz", "1", "--duration-s", "2",
                         "--out", str(out), "--plot", str(plot), "--video", str(video)])
    printed = capsys.readouterr().out
    assert code == 0, printed
    header, rows = read_rows(out)
    assert header == ["time_s", "x_m", "y_m", "yaw_rad"]
    assert len(rows) == 61 and rows[0, 0] == 0.0 and rows[-1, 0] == pytest.approx(2.0)
    velocity_line = next(line for line in printed.splitlines() if line.startswith("traveling velocity"))
    vx, vy = (float(v) for v in velocity_line.split(": ")[1].split(" cm/s")[0].split(" / "))
    displacement = rows[-1, 1:3] - rows[0, 1:3]
    np.testing.assert_allclose([vx, vy], 100 * displacement / 2.0, atol=0.01)   # Table I: displacement / time
    assert "displacement: x" in printed and "real-time factor" in printed
    assert plot.read_bytes()[:4] == b"\x89PNG"
    capture = cv2.VideoCapture(str(video))
    frames = int(capture.get(cv2.CAP_PROP_FRAME_COUNT))
    ok, frame = capture.read()
    capture.release()
    assert ok and frame.shape == (480, 640, 3) and frames == 61


def test_a_record_rate_that_does_not_divide_the_run_still_records_and_measures_its_end(tmp_path, capsys):
    out = tmp_path / "run.csv"  # 1.1 s at 7 Hz: frames at 0, 1/7 ... 7/7 s, then the end; it stopped at 1 s
    code = sim_cli.main(["--gait", "inward_rolling", "--amplitude-bar", "3", "--frequency-hz", "1",
                         "--duration-s", "1.1", "--record-rate-hz", "7", "--out", str(out)])
    printed = capsys.readouterr().out
    _, rows = read_rows(out)
    assert code == 0 and len(rows) == 9 and rows[-1, 0] == pytest.approx(1.1, abs=1e-3)
    assert rows[-2, 0] == pytest.approx(1.0, abs=1e-3) and "over 1.10 s" in printed


def test_friction_and_sim_config_options_reach_the_world(tmp_path, capsys):
    data = yaml.safe_load(default_sim_config_path().read_text())
    data["sim"]["contact"]["friction_along_body"] = 0.25
    config = tmp_path / "sim.yaml"
    config.write_text(yaml.safe_dump(data))
    code = sim_cli.main(["--gait", "serpentine", "--amplitude-bar", "2", "--frequency-hz", "0.5", "--duration-s", "0.5",
                         "--out", str(tmp_path / "s.csv"), "--friction", "anisotropic", "--sim-config", str(config)])
    assert code == 0
    assert "anisotropic friction 0.25 along / 0.9 across" in capsys.readouterr().out


@pytest.mark.parametrize("args", [
    ["--gait", "moonwalk", "--amplitude-bar", "4", "--frequency-hz", "1"],
    ["--gait", "serpentine", "--amplitude-bar", "-1", "--frequency-hz", "1"],
    ["--gait", "serpentine", "--amplitude-bar", "4", "--frequency-hz", "nan"],
    ["--gait", "serpentine", "--amplitude-bar", "5", "--frequency-hz", "1"],
    ["--gait", "serpentine", "--amplitude-bar", "4", "--frequency-hz", "1", "--friction", "sticky"],
    ["--gait", "serpentine", "--amplitude-bar", "4", "--frequency-hz", "1", "--sim-config", "/nonexistent.yaml"],
])
def test_bad_arguments_exit_2_with_a_message(args, tmp_path, capsys):
    try:
        code = sim_cli.main([*args, "--duration-s", "0.2", "--out", str(tmp_path / "x.csv")])
    except SystemExit as exit_info:   # argparse's own errors
        code = exit_info.code
    assert code == 2
    message = capsys.readouterr().err
    assert "srs_sim" in message or "usage" in message
    assert not (tmp_path / "x.csv").exists()


@pytest.mark.slow
def test_the_console_script_shows_progress_on_long_runs(tmp_path):
    result = subprocess.run([script_path("srs_sim"), "--gait", "inward_rolling", "--amplitude-bar", "2",
                             "--frequency-hz", "1", "--duration-s", "6", "--out", str(tmp_path / "r.csv")],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert "simulated   6.0 / 6 s" in result.stderr
    assert "traveling velocity" in result.stdout


def test_a_duration_out_of_range_is_refused_before_any_file_is_made(tmp_path, capsys):
    """--duration-s 4000 --video run.avi exited 2 after making an empty video file (a helper's review)."""
    video = tmp_path / "run.avi"
    with pytest.raises(SystemExit) as refused:
        sim_cli.main(["--gait", "inward_rolling", "--amplitude-bar", "3", "--frequency-hz", "1", "--duration-s", "4000",
                      "--video", str(video), "--out", str(tmp_path / "r.csv")])
    assert refused.value.code == 2 and "--duration-s 4000: expected seconds in (0, 3600]" in capsys.readouterr().err
    assert not video.exists()


@pytest.mark.parametrize(("args", "said"), [
    (["--amplitude-bar", "4.5"], "amplitude_bar is 4.5; expected a number in (0, 4]"),
    (["--frequency-hz", "9"], "frequency_hz is 9"),
    (["--record-rate-hz", "1e12"], "--record-rate-hz: 1e+12 Hz is above the physics' rate, 500 Hz"),
    (["--record-rate-hz", "1000"], "--record-rate-hz: 1000 Hz is above the physics' rate, 500 Hz"),
])
def test_a_bad_gait_or_record_rate_leaves_an_existing_video_untouched(args, said, tmp_path, capsys):
    """The video was opened (emptied) before the gait's arguments were checked; 1e12 Hz asked for 109 TiB in a
    traceback, and 1000 Hz wrote pairs of frames of one step (a helper's review)."""
    video = tmp_path / "keep.avi"
    video.write_bytes(b"a video recorded yesterday")
    options = {"--gait": "inward_rolling", "--amplitude-bar": "3", "--frequency-hz": "1", "--duration-s": "1"}
    options.update(zip(args[::2], args[1::2]))
    code = sim_cli.main([*(x for pair in options.items() for x in pair), "--video", str(video),
                         "--out", str(tmp_path / "r.csv")])
    assert code == 2 and said in capsys.readouterr().err
    assert video.read_bytes() == b"a video recorded yesterday" and sorted(p.name for p in tmp_path.iterdir()) == [
        "keep.avi"]


@pytest.mark.parametrize("stop", [KeyboardInterrupt, "diverged"])
def test_a_run_interrupted_or_diverged_leaves_no_partial_video_and_exits_130_or_2(stop, tmp_path, monkeypatch,
                                                                                  capsys):
    """Ctrl-C printed a traceback and left a 9 MB partial video; a divergence left one silently (a review)."""
    from srs_ros.core.errors import SimulationError

    real_run = sim_cli.run_experiment

    def stopped_after_frames(*args, on_frame=None, **kwargs):
        def frame(state):
            on_frame(state)
            frames.append(state)
            if len(frames) == 5:
                raise KeyboardInterrupt if stop is KeyboardInterrupt else SimulationError("the simulation diverged")
        return real_run(*args, on_frame=frame, **kwargs)

    frames = []
    monkeypatch.setattr(sim_cli, "run_experiment", stopped_after_frames)
    video = tmp_path / "run.avi"
    video.write_bytes(b"an older video")
    code = sim_cli.main(["--gait", "inward_rolling", "--amplitude-bar", "3", "--frequency-hz", "1", "--duration-s", "1",
                         "--video", str(video), "--out", str(tmp_path / "r.csv")])
    err = capsys.readouterr().err
    assert (code, len(frames)) == ((130, 5) if stop is KeyboardInterrupt else (2, 5)), err
    assert ("interrupted; nothing written" if stop is KeyboardInterrupt else "no video written") in err
    assert video.read_bytes() == b"an older video" and sorted(p.name for p in tmp_path.iterdir()) == ["run.avi"]
