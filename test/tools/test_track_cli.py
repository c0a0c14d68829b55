"""srs_track on a short synthetic MJPG video: CSV track, Table I velocity within 2 %, a Fig. 7-style plot."""

import csv
import subprocess

import numpy as np
import pytest
from srs_testing import script_path

from srs_ros.core.vision.camera_calibration import save_calibration
from srs_ros.sim.scene import SyntheticCamera, SyntheticScene, constant_velocity_poses, write_video
from srs_ros.tools import track_cli

VELOCITY_M_S = (0.04, 0.025)


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    folder = tmp_path_factory.mktemp("track")
    scene = SyntheticScene()
    times, poses = constant_velocity_poses(2.0, 15.0, (-0.15, -0.1, 0.7), VELOCITY_M_S)
    video = write_video(folder / "run.avi", scene, poses, 15.0)
    calibration = save_calibration(scene.camera.calibration(), folder / "cal.yaml")
    return folder, video, calibration, times, poses


def read_rows(path):
    with open(path, newline="") as stream:
        reader = csv.reader(stream)
        header = next(reader)
        return header, np.array([[float(v) for v in row] for row in reader])


def test_offline_tool_writes_track_velocity_and_plot(recording, capsys):
    folder, video, calibration, times, poses = recording
    out, plot = folder / "track.csv", folder / "track.png"
    code = track_cli.main([str(video), "--calibration", str(calibration), "--out", str(out), "--plot", str(plot)])
    printed = capsys.readouterr().out
    assert code == 0, printed
    header, rows = read_rows(out)
    assert header == ["time_s", "x_m", "y_m", "yaw_rad"]
    assert len(rows) == len(times)
    np.testing.assert_allclose(rows[:, 0], times, atol=1e-3)
    np.testing.assert_allclose(rows[:, 1:3], poses[:, :2], atol=0.002)
    np.testing.assert_allclose(rows[:, 3], poses[:, 2], atol=np.radians(1.0))
    line = next(p for p in printed.splitlines() if p.startswith("traveling velocity"))
    vx, vy = (float(v) for v in line.split(": ")[1].split(" cm/s")[0].split(" / "))
    np.testing.assert_allclose([vx, vy], 100 * np.array(VELOCITY_M_S), rtol=0.02)
    assert plot.stat().st_size > 10_000 and plot.read_bytes()[:4] == b"\x89PNG"


def test_console_script_reports_a_bad_calibration(recording, tmp_path):
    _, video, _, _, _ = recording
    bad = tmp_path / "bad.yaml"
    bad.write_text("something_else: 1\n")
    done = subprocess.run([script_path("srs_track"), str(video), "--calibration", str(bad), "--out",
                           str(tmp_path / "t.csv")], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert "bad.yaml: camera_calibration is missing; expected a mapping with frame_id" in done.stderr


def test_unreadable_video_is_an_error_not_an_empty_track(tmp_path, capsys):
    code = track_cli.main([str(tmp_path / "absent.avi"), "--out", str(tmp_path / "t.csv")])
    assert code == 2
    assert "cannot open it as a video" in capsys.readouterr().err


@pytest.mark.parametrize(("option", "value", "message"), [
    ("--end-window", "nan", "--end-window nan: expected seconds >= 0"),
    ("--end-window", "-1", "--end-window -1.0: expected seconds >= 0"),
    ("--fps", "-5", "--fps -5.0: expected a frame rate in (0, 1000] Hz"),
    ("--fps", "1e300", "--fps 1e+300: expected a frame rate in (0, 1000] Hz"),  # every frame one instant
])
def test_a_window_or_frame_rate_that_is_not_one_is_refused(tmp_path, capsys, option, value, message):
    """`--end-window nan` printed a velocity of nan / nan cm/s with exit 0; `--fps -5` said the file had no frame
    rate (a helper's config review)."""
    with pytest.raises(SystemExit) as stop:
        track_cli.main([str(tmp_path / "run.avi"), "--out", str(tmp_path / "t.csv"), option, value])
    assert stop.value.code == 2 and message in capsys.readouterr().err


def test_an_out_path_that_is_a_folder_is_refused_before_the_video_is_tracked(tmp_path, capsys):
    assert track_cli.main([str(tmp_path / "absent.avi"), "--out", str(tmp_path)]) == 2
    assert "is a folder; expected a file path in it" in capsys.readouterr().err  # not the video's error


def test_a_video_of_another_size_than_the_calibration_stops_with_both_sizes(recording, tmp_path, capsys):
    """A video of another size was tracked into wrong poses and a wrong Table I velocity, without a word."""
    _, _, calibration, _, poses = recording
    small = SyntheticScene(camera=SyntheticCamera(width_px=320, height_px=240))
    video = write_video(tmp_path / "small.avi", small, poses[:3], 15.0)
    code = track_cli.main([str(video), "--calibration", str(calibration), "--out", str(tmp_path / "t.csv")])
    err = capsys.readouterr().err
    assert code == 2
    assert f"srs_track: {video}, frame 0: image is 320 x 240 px but the calibration {calibration} is for 640 x 480 px" \
           in err, err
    assert not (tmp_path / "t.csv").exists()


@pytest.mark.parametrize(("flags", "message"), [
    (["--position-ratio", "nan"], "srs_track: error: --position-ratio nan: expected a number in [0, 1]"),
    (["--tail-id", "77"], "srs_track: error: --tail-id is 77; expected an id of DICT_4X4_50, 0..49"),
    (["--tail-id", "3", "--head-id", "3"], "srs_track: error: --head-id is 3; expected an id other than --tail-id 3"),
])
def test_a_bad_tracker_flag_is_refused_once_by_its_flag_before_the_video_is_read(tmp_path, capsys, flags, message):
    """`--position-ratio nan` said `srs_track: srs_track: position_ratio is nan` (the prefix twice, the YAML key)."""
    with pytest.raises(SystemExit) as stop:
        track_cli.main([str(tmp_path / "absent.avi"), "--out", str(tmp_path / "t.csv"), *flags])
    err = capsys.readouterr().err
    assert stop.value.code == 2 and message in err and "srs_track: srs_track" not in err, err


def test_the_frames_tracked_so_far_are_shown_on_stderr(recording, tmp_path, capsys):
    """srs_track printed nothing until the whole video was tracked."""
    _, video, calibration, times, _ = recording
    assert track_cli.main([str(video), "--calibration", str(calibration), "--out", str(tmp_path / "t.csv")]) == 0
    err = capsys.readouterr().err
    assert "run.avi: 100%" in err and f"{len(times)}/{len(times)}" in err and "frame" in err, err


@pytest.mark.parametrize("victim", ["the video", "--calibration"])
def test_an_output_on_an_input_is_refused_and_the_input_kept(recording, tmp_path, capsys, victim):
    """``--out run.avi`` replaced the recording with the CSV (a helper's review), ``--out cal.yaml`` the calibration
    (a review of the day's changes)."""
    _, video, calibration, _, _ = recording
    source = video if victim == "the video" else calibration
    copy = tmp_path / f"victim{source.suffix}"
    copy.write_bytes(source.read_bytes())
    video_in, calibration_in = (copy, calibration) if victim == "the video" else (video, copy)
    assert track_cli.main([str(video_in), "--calibration", str(calibration_in), "--out", str(copy)]) == 2
    assert f"--out {copy}: the same file as {victim}" in capsys.readouterr().err
    assert copy.read_bytes() == source.read_bytes()


def test_a_plot_on_the_csvs_path_is_refused(recording, tmp_path, capsys):
    _, video, calibration, _, _ = recording
    out = tmp_path / "t.png"
    assert track_cli.main([str(video), "--calibration", str(calibration), "--out", str(out), "--plot", str(out)]) == 2
    assert "--plot" in capsys.readouterr().err and not out.exists()


@pytest.mark.parametrize("plot", ["x.jpg2", "noext"])
def test_a_plot_that_is_not_a_png_is_refused_before_the_video_is_tracked(recording, tmp_path, capsys, plot):
    """Matplotlib failed with a traceback after the CSV was written, or wrote ``noext.png`` and named ``noext``."""
    _, video, calibration, _, _ = recording
    with pytest.raises(SystemExit) as stop:
        track_cli.main([str(video), "--calibration", str(calibration), "--out", str(tmp_path / "t.csv"),
                        "--plot", str(tmp_path / plot)])
    assert stop.value.code == 2 and "expected a .png path" in capsys.readouterr().err
    assert not (tmp_path / "t.csv").exists()


def test_an_end_window_the_track_cannot_hold_leaves_no_csv(recording, tmp_path, capsys):
    """The CSV was written, over any earlier one, before the velocity check refused the run (a helper's review)."""
    _, video, calibration, _, _ = recording
    out = tmp_path / "t.csv"
    assert track_cli.main([str(video), "--calibration", str(calibration), "--out", str(out),
                           "--end-window", "30"]) == 2
    assert "end window" in capsys.readouterr().err and not out.exists()
