"""The camera calibration file through the one schema: the shipped files load, a bad value is refused in the one
format (file, key, value, what is expected), for the YAML file, its lens section and the point-pair CSV."""

from pathlib import Path

import pytest
import yaml

from srs_ros.core.errors import ConfigurationError
from srs_ros.core.robot import config_dir
from srs_ros.core.vision.camera_calibration import load_calibration, load_intrinsics, read_point_pairs

SHIPPED = config_dir() / "camera_calibration.yaml"


@pytest.mark.parametrize("name", ["camera_calibration.yaml", "sim_camera_calibration.yaml"])
def test_the_shipped_calibrations_load(name):
    calibration = load_calibration(config_dir() / name)
    assert calibration.frame_id == "floor" and calibration.image_size_px == (640, 480)
    assert len(calibration.image_px) >= 4 and calibration.rms_error_mm < 0.01


def write_changed(tmp_path: Path, change) -> Path:
    data = yaml.safe_load(SHIPPED.read_text())
    change(data["camera_calibration"])
    path = tmp_path / "cal.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


LENS = {"distortion_model": "plumb_bob", "k": [500.0, 0.0, 320.0, 0.0, 500.0, 240.0, 0.0, 0.0, 1.0],
        "d": [-0.2, 0.05, 0.0, 0.0, 0.0]}


@pytest.mark.parametrize(("change", "refusal"), [
    (lambda c: c.update(frame_id=5), "camera_calibration.frame_id is 5; expected a non-empty string"),
    (lambda c: c.update(image_size_px=[640]),
     "camera_calibration.image_size_px is [640]; expected a list of 2 integers in [1, 100000] (px)"),
    (lambda c: c.update(homography_image_to_floor=[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
     "camera_calibration.homography_image_to_floor is [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]; expected a finite, "
     "invertible 3 x 3 list of rows"),
    (lambda c: c["point_pairs"][2].pop("y_m"), "camera_calibration.point_pairs[2].y_m is missing; expected a number"),
    (lambda c: c["point_pairs"][0].update(u_px="left"),
     "camera_calibration.point_pairs[0].u_px is 'left'; expected a number (finite) (px)"),
    (lambda c: c.update(frame="floor"), "camera_calibration.frame is not a known key; expected one of [frame_id, "),
    (lambda c: c.update(intrinsics={**LENS, "distortion_model": "fisheye"}),
     "camera_calibration.intrinsics.distortion_model is 'fisheye'; expected one of ['plumb_bob', "),
    (lambda c: c.update(intrinsics={**LENS, "d": [0.1, 0.2, 0.3]}),
     "camera_calibration.intrinsics.d is [0.1, 0.2, 0.3]; expected 4 or 5 coefficients for plumb_bob"),
    (lambda c: c.update(intrinsics={**LENS, "k": [0.0] * 9}),
     "camera_calibration.intrinsics.k is [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]; expected 9 numbers, the "
     "camera matrix row by row"),
    (lambda c: (c.pop("homography_image_to_floor"), c.update(point_pairs=c["point_pairs"][:3])),
     "camera_calibration.homography_image_to_floor is missing; expected a finite, invertible 3 x 3 list of rows, or "
     "at least 4 point_pairs to fit it from; run srs_calibrate_camera to create them"),
])
def test_a_bad_value_in_the_calibration_file_is_refused_in_the_one_format(tmp_path, change, refusal):
    path = write_changed(tmp_path, change)
    with pytest.raises(ConfigurationError) as refused:
        load_calibration(path)
    assert str(refused.value).startswith(f"{path}: {refusal}")


def test_a_lens_from_a_ros_camera_calibration_file_names_the_key_it_misses(tmp_path):
    camera = tmp_path / "camera.yaml"
    camera.write_text(yaml.safe_dump({"image_width": 640, "camera_matrix": {"rows": 3, "data": LENS["k"]},
                                      "distortion_model": "plumb_bob"}))
    with pytest.raises(ConfigurationError) as refused:
        load_intrinsics(camera)
    assert str(refused.value) == (f"{camera}: distortion_coefficients.data is missing; expected a list of the "
                                  "distortion coefficients.")
    camera.write_text(yaml.safe_dump({"camera_matrix": {"data": LENS["k"]},
                                      "distortion_coefficients": {"data": LENS["d"]}}))
    assert load_intrinsics(camera).model == "plumb_bob"


@pytest.mark.parametrize(("text", "refusal"), [
    ("u_px,v_px,x_m,y_m\n1,2,0,0\n3,4,x,0\n", "pairs.csv:3: x_m is 'x'; expected a number (finite) (m)."),
    ("u,v,x,y\n1,2,0,0\n", "pairs.csv: the header line is 'u,v,x,y'; expected u_px,v_px,x_m,y_m (in any order)."),
])
def test_a_bad_point_pair_csv_is_refused_with_file_line_and_column(tmp_path, text, refusal):
    pairs = tmp_path / "pairs.csv"
    pairs.write_text(text)
    with pytest.raises(ConfigurationError) as refused:
        read_point_pairs(pairs)
    assert str(refused.value) == f"{tmp_path}/{refusal}"


def test_a_save_that_fails_mid_write_leaves_the_good_calibration_as_it_was(tmp_path, monkeypatch):
    """A full disk cut a good calibration short while srs_calibrate_camera said it was unchanged (a review)."""
    from srs_ros.core.vision.camera_calibration import save_calibration

    good = save_calibration(load_calibration(SHIPPED), tmp_path / "cal.yaml")
    before = good.read_bytes()
    real_write = Path.write_text

    def disk_full(self, text, *args, **kwargs):
        real_write(self, text[: len(text) // 2], *args, **kwargs)
        raise OSError(27, "File too large")

    monkeypatch.setattr(Path, "write_text", disk_full)
    with pytest.raises(OSError):
        save_calibration(load_calibration(SHIPPED), good)
    monkeypatch.undo()
    assert good.read_bytes() == before and load_calibration(good).image_size_px == (640, 480)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cal.yaml"]  # no temporary file left
