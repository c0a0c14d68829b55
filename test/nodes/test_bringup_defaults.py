"""srs_bringup's options default to the nodes' parameter specs (one source, as the launch file's): in-process."""

import dataclasses
from pathlib import Path

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
