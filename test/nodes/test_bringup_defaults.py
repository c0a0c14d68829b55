"""srs_bringup's options default to the nodes' parameter specs (one source, as the launch file's): in-process."""

import dataclasses
from pathlib import Path
from types import SimpleNamespace

import pytest
import yaml

from srs_ros.core import rig
from srs_ros.core.gait import request
from srs_ros.core.gait.library import list_gaits
from srs_ros.core.robot import amplitude_field, default_robot
from srs_ros.nodes import bringup, gait_player
from srs_ros.nodes.trajectory_server import base_parameters


def test_the_defaults_are_the_trajectory_server_and_gait_player_specs():
    args = bringup.build_parser().parse_args([])
    server = {spec.name: spec.default for spec in base_parameters(default_robot(), sorted(list_gaits()))}
    player = {spec.name: spec.default for spec in gait_player.PARAMETERS}
    assert (args.gait, args.amplitude_bar, args.frequency_hz, args.samples) == (
        server["gait"], server["amplitude_bar"], server["frequency_hz"], server["samples"])
    assert (args.rate_hz, args.realtime_priority) == (player["rate_hz"], player["realtime_priority"])
    assert Path(args.rig) == rig.rig_path(rig.SYSTEM_RIG) and Path(args.rig).is_file()
    assert args.amplitude_bar == amplitude_field(default_robot()).default == default_robot().max_pressure_bar


def test_a_changed_spec_changes_the_default(monkeypatch):
    monkeypatch.setattr(request, "DEFAULT_GAIT", "serpentine")
    monkeypatch.setattr(request, "FREQUENCY_FIELD", dataclasses.replace(request.FREQUENCY_FIELD, default=0.5))
    monkeypatch.setattr(request, "SAMPLES_FIELD", dataclasses.replace(request.SAMPLES_FIELD, default=32))
    monkeypatch.setattr(gait_player, "PARAMETERS", tuple(
        dataclasses.replace(s, default=300.0) if s.name == "rate_hz" else s for s in gait_player.PARAMETERS))
    monkeypatch.setattr(rig, "SYSTEM_RIG", "mock")
    args = bringup.build_parser().parse_args([])
    assert (args.gait, args.frequency_hz, args.samples, args.rate_hz, Path(args.rig).name) == (
        "serpentine", 0.5, 32, 300.0, "mock.yaml")


def test_the_camera_tracker_gets_the_sim_colour_preset_of_core_rig_as_the_launch_file_does(monkeypatch):
    """One source for the preset (srs_ros.core.rig.SIM_COLOR_PRESET): bringup's params file follows a change of it."""
    args = bringup.build_parser().parse_args([])
    assert read_params(bringup._params_file(args, []))["camera_tracker"]["color_preset"] == rig.SIM_COLOR_PRESET
    assert rig.SIM_COLOR_PRESET in rig.COLOR_PRESETS and "" in rig.COLOR_PRESETS
    monkeypatch.setattr(rig, "SIM_COLOR_PRESET", "")
    assert read_params(bringup._params_file(args, []))["camera_tracker"]["color_preset"] == ""


def read_params(path: str) -> dict:
    """A params file bringup wrote, by node name (then removed, as bringup does)."""
    try:
        data = yaml.safe_load(Path(path).read_text())
    finally:
        Path(path).unlink()
    return {key.removeprefix("/**/"): value["ros__parameters"] for key, value in data.items()}


def params_of(args) -> dict:
    """The parameters srs_bringup hands its nodes (its temporary params file, read and removed)."""
    path = Path(bringup._params_file(args, []))
    try:
        return {name.removeprefix("/**/"): block["ros__parameters"]
                for name, block in yaml.safe_load(path.read_text()).items()}
    finally:
        path.unlink()


def test_navigating_leaves_the_gait_to_the_navigator_and_patrol_defaults_to_the_sim_waypoints():
    args, _ = bringup._parse_arguments(["--patrol"])
    assert args.waypoint == [list(p) for p in bringup.SIM_PATROL_XY_M]
    params = params_of(args)
    assert params["gait_player"]["autostart"] is False
    assert params["navigator"] == {"calibration_preset": "sim_bands", "loop_path": True, "amplitude_bar": 4.0,
                                   "sim_config_file": ""}
    # --amplitude-bar 3 with --navigate: the navigator cruised at 4 bar regardless (a helper's review)
    assert params_of(bringup._parse_arguments(["--navigate", "--amplitude-bar", "3"])[0])["navigator"][
        "amplitude_bar"] == 3.0
    assert params_of(bringup._parse_arguments([])[0])["gait_player"]["autostart"] is True
    own, _ = bringup._parse_arguments(["--patrol", "--waypoint", "0.1", "0.2", "--waypoint", "-0.3", "0"])
    assert own.waypoint == [[0.1, 0.2], [-0.3, 0.0]]


def test_patrol_options_that_cannot_work_are_refused_with_what_to_do(capsys):
    for argv, reason in ((["--waypoint", "0.1", "0.2"], "--waypoint X_M Y_M is a patrol waypoint: add --patrol"),
                         (["--patrol", "--rig", str(rig.rig_path("mock"))], "needs its waypoints (--waypoint X_M")):
        with pytest.raises(SystemExit) as refused:
            bringup._parse_arguments(argv)
        assert refused.value.code == 2 and reason in capsys.readouterr().err


@pytest.mark.parametrize("argv, reason", [
    (["--status-period-s", "0"], "--status-period-s 0: expected seconds > 0"),
    (["--status-period-s", "nan"], "--status-period-s nan: expected seconds > 0"),
    (["--duration-s", "-5"], "--duration-s -5: expected seconds >= 0 (0 = until Ctrl-C)"),
    (["--duration-s", "nan"], "--duration-s nan: expected seconds >= 0"),
    (["--video", "/no/such/folder/run.avi"], "--video /no/such/folder/run.avi: its folder does not exist"),
    (["--patrol", "--rig", "config/rigs/simm.yaml"], "simm.yaml"),
])
def test_options_that_cannot_work_are_refused_before_anything_starts(argv, reason, capsys):
    """A helper's review: a 0 s status period made a timer always due on the real-time executor; a negative or NaN
    duration meant "until Ctrl-C"; an unwritable --video ended the world thread later; a misspelled rig with --patrol
    was said to be "a rig other than the simulated robot"."""
    with pytest.raises(SystemExit) as refused:
        bringup._parse_arguments(argv)
    err = capsys.readouterr().err
    assert refused.value.code == 2 and reason in err, err
    assert "needs its waypoints" not in err


def test_the_rate_check_reads_the_players_rate_however_it_was_given():
    """``-p rate_hz:=10`` beats --rate-hz's 200 (the params file leaves it out): the check read --rate-hz only."""
    hardware = SimpleNamespace(lifecycle_label=lambda: "active",
                               gate=SimpleNamespace(setpoint_timeout_s=0.1, requires_arm=False))
    player = SimpleNamespace(get_parameter=lambda name: SimpleNamespace(value={"rate_hz": 10.0}[name]))
    args, _ = bringup._parse_arguments(["--ros-args", "-p", "rate_hz:=10"])
    assert args.rate_hz == 200.0
    with pytest.raises(bringup.ConfigurationError, match=r"gait_player's rate_hz 10 \(--rate-hz\) is too slow for the "
                                                         r"rig's setpoint timeout of 0.1 s .*at least 20 Hz"):
        bringup._check_hardware(hardware, player, args)


def test_an_error_in_a_worker_thread_stops_the_whole_bringup(monkeypatch, capfd):
    """The world thread ended by an error (an unwritable video file) left the status line printing and exit 0."""
    import threading

    from srs_ros.ros.process import SHUTDOWN

    monkeypatch.setattr(SHUTDOWN, "requested", "")
    system = SimpleNamespace(failure="")  # the System's own state that its threads' spin writes

    def fails():
        raise bringup.ConfigurationError("--video /proc/run.avi: OpenCV cannot write this file")

    thread = threading.Thread(target=bringup.System._spin, args=(system, fails), name="sim_world")
    thread.start()
    thread.join(5.0)
    assert "the sim_world thread stopped: ConfigurationError: --video /proc/run.avi" in system.failure
    assert SHUTDOWN.requested == system.failure  # the main loop's spin ends on it, and main() exits 1
    assert "venting and exiting with status 1" in capfd.readouterr().err


def test_the_video_keeps_the_cameras_time_line_and_skips_what_it_cannot_write(tmp_path, ros_domain, capsys):
    """Written one for one, 20 images a second made a 30 fps video that ran 1.5 times fast; an image of another
    encoding ended the main job, and one of another size was counted as saved (a helper's review)."""
    import cv2
    import numpy as np
    import rclpy

    from srs_ros.nodes.bringup_nodes import VideoRecorder
    from srs_ros.ros.interfaces import array_to_image_msg, seconds_to_stamp

    rclpy.init(domain_id=ros_domain)
    try:
        recorder = VideoRecorder(str(tmp_path / "run.avi"), 30.0)
        try:
            frame = np.zeros((240, 320, 3), np.uint8)
            for k in range(61):  # 3 s at 20 images a second
                recorder._on_image(array_to_image_msg(frame, seconds_to_stamp(100.0 + k / 20)))
            odd = array_to_image_msg(frame[:, :, 0], seconds_to_stamp(103.1))
            odd.encoding = "16UC1"
            recorder._on_image(odd)
            recorder._on_image(array_to_image_msg(np.zeros((120, 160, 3), np.uint8), seconds_to_stamp(103.2)))
            recorder.close()
        finally:
            recorder.destroy_node()
    finally:
        rclpy.shutdown()
    video = cv2.VideoCapture(str(tmp_path / "run.avi"))
    frames, fps = int(video.get(cv2.CAP_PROP_FRAME_COUNT)), video.get(cv2.CAP_PROP_FPS)
    video.release()
    assert (frames, fps) == (91, 30.0)  # 3 s of video at 30 fps, not 61 frames (2 s)
    assert (recorder.images, recorder.skipped) == (61, 2)
    assert "saved 61 camera images as 91 frames at 30 fps (3.0 s)" in capsys.readouterr().out
