"""``python -m srs_ros.tools.synthetic_scene``: its numbers checked and its outputs written whole, or not at all
(a helper's review: NaN, infinite, zero or negative values gave tracebacks or an empty video, and a failed run had
already overwritten an existing video)."""

import pytest

from srs_ros.tools import synthetic_scene


@pytest.mark.parametrize("flags, said", [
    (["--fps", "nan"], "--fps nan: expected a number in (0, 1000]"),
    (["--fps", "0"], "--fps 0: expected a number in (0, 1000]"),
    (["--duration", "inf"], "--duration inf: expected a number in (0, 3600]"),
    (["--duration", "-1"], "--duration -1: expected a number in (0, 3600]"),
    (["--vx", "nan"], "--vx nan: expected a speed in [-1, 1] m/s"),
])
def test_a_number_that_is_not_one_is_refused_and_an_existing_video_kept(tmp_path, capsys, flags, said):
    video = tmp_path / "keep.avi"
    video.write_bytes(b"an earlier recording")
    with pytest.raises(SystemExit) as stop:
        synthetic_scene.main([str(video), *flags])
    assert stop.value.code == 2 and said in capsys.readouterr().err
    assert video.read_bytes() == b"an earlier recording"


def test_an_unwritable_calibration_is_refused_before_the_video_is_written(tmp_path, capsys):
    video = tmp_path / "keep.avi"
    video.write_bytes(b"an earlier recording")
    assert synthetic_scene.main([str(video), "--duration", "0.2", "--calibration-out", "/proc/cal.yaml"]) == 2
    assert "--calibration-out /proc/cal.yaml: cannot write there" in capsys.readouterr().err
    assert video.read_bytes() == b"an earlier recording"


def test_a_short_demo_writes_its_video_and_calibration(tmp_path, capsys):
    video, calibration = tmp_path / "demo.avi", tmp_path / "demo_cal.yaml"
    assert synthetic_scene.main([str(video), "--duration", "0.2", "--fps", "15",
                                 "--calibration-out", str(calibration)]) == 0
    assert "wrote 4 frames" in capsys.readouterr().out  # 0 to 0.2 s at 15 fps, both ends
    assert video.stat().st_size > 10_000 and "camera_calibration" in calibration.read_text()
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # no partial left
