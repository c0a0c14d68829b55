"""srs_track on a short synthetic MJPG video: CSV track, Table I velocity within 2 %, a Fig. 7-style plot."""

import csv
import subprocess

import numpy as np
import pytest
from srs_testing import script_path

from srs_ros.core.vision.camera_calibration import save_calibration
from srs_ros.sim.scene import SyntheticScene, constant_velocity_poses, write_video
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
    ("--fps", "-5", "--fps -5.0: expected a frame rate above 0 Hz"),
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
