"""launch/srs.launch.py, evaluated with a stand-in for launch/launch_ros (test/fakes/launch_api, no ROS install
here): arguments accept 3 and 3.0, hardware_node is a LifecycleNode, namespace and use_sim_time reach every node;
and trajectory_server runs with what launch hands it, an integer amplitude included."""

import json
import os
import subprocess
import sys
from pathlib import Path
from xml.etree import ElementTree

import numpy as np
import pytest
import yaml
from srs_testing import ros_args
from trajectory_msgs.msg import JointTrajectory

from srs_ros.core.gait.library import list_gaits
from srs_ros.core.gait.request import FREQUENCY_FIELD, gait_field
from srs_ros.core.rig import SIM_COLOR_PRESET, SYSTEM_RIG
from srs_ros.core.robot import amplitude_field, default_robot
from srs_ros.ros.interfaces import DDS_PROFILE_FILE, TRAJECTORY_TOPIC, latched_qos

ROOT = Path(__file__).resolve().parents[1]
FAKES = ROOT / "test" / "fakes" / "launch_api"


@pytest.fixture(scope="module")
def ament_prefix(tmp_path_factory):
    """An ament prefix in which ``get_package_share_directory('srs_ros')`` finds the repo's config."""
    prefix = tmp_path_factory.mktemp("ament_prefix")
    marker = prefix / "share" / "ament_index" / "resource_index" / "packages" / "srs_ros"
    marker.parent.mkdir(parents=True)
    marker.write_text("")
    (prefix / "share" / "srs_ros").mkdir()
    (prefix / "share" / "srs_ros" / "config").symlink_to(ROOT / "config")
    return prefix


def evaluate(ament_prefix, *arguments, prelude=None):
    """The nodes the launch file starts; ``prelude`` (a Python file) runs first in the launch's own process."""
    # The launch file imports srs_ros (its defaults come from the specs): this checkout's, after the stand-in.
    env = dict(os.environ, AMENT_PREFIX_PATH=str(ament_prefix), PYTHONPATH=os.pathsep.join([str(FAKES), str(ROOT)]))
    command = [str(FAKES / "evaluate_launch.py"), str(ROOT / "launch" / "srs.launch.py"), *arguments]
    command = [str(prelude), *command] if prelude else command
    done = subprocess.run([sys.executable, *command], capture_output=True, text=True, env=env, timeout=60, cwd=FAKES)
    if done.returncode:
        raise RuntimeError(done.stderr)
    return {node["name"]: node for node in json.loads(done.stdout)["nodes"]}


def test_defaults_run_the_simulated_robot_with_hardware_node_as_a_lifecycle_node(ament_prefix):
    nodes = evaluate(ament_prefix)
    assert sorted(nodes) == ["camera_tracker", "gait_player", "hardware_node", "sim_world", "trajectory_server"]
    assert nodes["camera_tracker"]["parameters"]["color_preset"] == SIM_COLOR_PRESET == "sim_bands"
    assert nodes["hardware_node"]["kind"] == "LifecycleNode"
    assert nodes["trajectory_server"]["kind"] == nodes["gait_player"]["kind"] == "Node"
    server = nodes["trajectory_server"]["parameters"]
    assert server["amplitude_bar"] == 4.0 and isinstance(server["amplitude_bar"], float)
    assert server["gait"] == "inward_rolling"
    for node in nodes.values():
        assert node["namespace"] == "" and node["parameters"]["use_sim_time"] is False
        assert all(Path(f).is_file() for f in node["parameter_files"]), node["parameter_files"]
    assert nodes["hardware_node"]["parameters"]["autostart"] is True
    assert Path(nodes["hardware_node"]["parameters"]["rig_file"]).name == "sim.yaml"
    real = evaluate(ament_prefix, "sim:=false", "camera:=false", "rig_file:=/etc/srs/can.yaml")
    assert sorted(real) == ["gait_player", "hardware_node", "trajectory_server"]


def test_the_camera_profile_is_installed_beside_the_launch_and_fast_dds_can_read_it(ament_prefix):
    """config/fastdds_camera_shm.xml, opt-in (docs/navigation.md): a shared-memory segment a camera image fits in."""
    installed = ament_prefix / "share" / "srs_ros" / "config" / DDS_PROFILE_FILE
    space = "{http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles}"
    root = ElementTree.parse(installed).getroot()  # an XML comment with "--" in it would already fail here
    transports = {t.find(f"{space}type").text: t for t in root.iter(f"{space}transport_descriptor")}
    assert int(transports["SHM"].find(f"{space}segment_size").text) >= 4 * 640 * 480 * 3
    assert "UDPv4" in transports  # other hosts still reach the nodes
    assert root.find(f".//{space}participant").get("is_default_profile") == "true"


def test_navigate_adds_the_navigator_and_leaves_the_gait_to_it(ament_prefix):
    plain = evaluate(ament_prefix)
    assert "navigator" not in plain and plain["gait_player"]["parameters"]["autostart"] is True
    nodes = evaluate(ament_prefix, "navigate:=true", "namespace:=snake1")
    navigator = nodes["navigator"]
    assert navigator["executable"] == "navigator" and navigator["namespace"] == "snake1"
    assert navigator["parameters"]["calibration_preset"] == "sim_bands"  # the tracker's calibration, as its preset
    assert navigator["parameters"]["amplitude_bar"] == 4.0  # the robot's limit, the navigator's default too
    assert [Path(f).name for f in navigator["parameter_files"]] == ["navigator.yaml"]
    assert all(Path(f).is_file() for f in navigator["parameter_files"])
    assert nodes["gait_player"]["parameters"]["autostart"] is False  # the navigator starts and stops it
    assert nodes["hardware_node"]["parameters"]["autostart"] is True
    real = evaluate(ament_prefix, "navigate:=true", "camera_preset:=", "sim:=false", "amplitude_bar:=3")
    assert real["navigator"]["parameters"]["calibration_preset"] == ""  # config/camera_calibration.yaml
    assert real["navigator"]["parameters"]["amplitude_bar"] == 3.0  # a gentler launch: it cruised at 4 bar


#: Run before the launch file in its process: every default the launch takes from srs_ros's specs changed.
CHANGED_SPECS = """
import dataclasses, runpy, sys
from srs_ros.core import rig, robot
from srs_ros.core.gait import request
request.DEFAULT_GAIT = "serpentine"
request.FREQUENCY_FIELD = dataclasses.replace(request.FREQUENCY_FIELD, default=0.5)
amplitude_field = robot.amplitude_field
robot.amplitude_field = lambda r: dataclasses.replace(amplitude_field(r), default=2.5)
rig.SYSTEM_RIG = "mock"
rig.SIM_COLOR_PRESET = ""
sys.argv = sys.argv[1:]
runpy.run_path(sys.argv[0], run_name="__main__")
"""


def test_the_defaults_are_read_from_the_specs_so_a_changed_spec_changes_the_launch(ament_prefix, tmp_path):
    nodes = evaluate(ament_prefix)
    server = nodes["trajectory_server"]["parameters"]
    assert (server["gait"], server["amplitude_bar"], server["frequency_hz"]) == (
        gait_field(list_gaits()).default, amplitude_field(default_robot()).default, FREQUENCY_FIELD.default)
    assert Path(nodes["hardware_node"]["parameters"]["rig_file"]).name == f"{SYSTEM_RIG}.yaml"
    prelude = tmp_path / "changed_specs.py"
    prelude.write_text(CHANGED_SPECS)
    nodes = evaluate(ament_prefix, prelude=prelude)
    server = nodes["trajectory_server"]["parameters"]
    assert (server["gait"], server["amplitude_bar"], server["frequency_hz"]) == ("serpentine", 2.5, 0.5)
    assert Path(nodes["hardware_node"]["parameters"]["rig_file"]).name == "mock.yaml"
    assert nodes["camera_tracker"]["parameters"]["color_preset"] == ""


@pytest.mark.parametrize("written", ["3", "3.0"])
def test_amplitude_and_frequency_reach_the_server_as_doubles(ament_prefix, written):
    server = evaluate(ament_prefix, f"amplitude_bar:={written}", "frequency_hz:=1")["trajectory_server"]
    assert server["parameters"]["amplitude_bar"] == 3.0 and isinstance(server["parameters"]["amplitude_bar"], float)
    assert server["parameters"]["frequency_hz"] == 1.0 and isinstance(server["parameters"]["frequency_hz"], float)


def test_namespace_and_sim_time_reach_every_node_including_the_camera(ament_prefix):
    nodes = evaluate(ament_prefix, "namespace:=snake1", "use_sim_time:=true", "camera:=true")
    assert sorted(nodes) == ["camera_tracker", "gait_player", "hardware_node", "sim_world", "trajectory_server"]
    for node in nodes.values():
        assert node["namespace"] == "snake1" and node["parameters"]["use_sim_time"] is True


def test_a_bad_switch_value_is_refused_by_launch(ament_prefix):
    with pytest.raises(RuntimeError) as refused:
        evaluate(ament_prefix, "use_sim_time:=maybe")
    assert """Argument "use_sim_time" provided value "maybe" is not valid. Valid options are: ['true', 'false']""" \
        in str(refused.value)


@pytest.mark.parametrize(("argument", "value", "expected"), [
    ("amplitude_bar", "abc", "a finite number of bar (e.g. amplitude_bar:=3 or amplitude_bar:=3.0)"),
    ("frequency_hz", "nan", "a finite number of Hz (e.g. frequency_hz:=1 or frequency_hz:=1.0)"),
])
def test_a_number_that_is_not_one_stops_the_launch_naming_the_argument(ament_prefix, argument, value, expected):
    """Not launch_ros's bare ``could not convert string to float: 'abc'``, and before any node starts."""
    with pytest.raises(RuntimeError) as refused:
        evaluate(ament_prefix, f"{argument}:={value}")
    assert str(refused.value).strip() == ("[ERROR] [launch]: Caught exception in launch (see debug for traceback): "
                                          f"launch argument {argument}:='{value}' is not valid: expected {expected}")


@pytest.mark.ros
@pytest.mark.parametrize("amplitude", [3, 3.0], ids=["integer", "double"])
def test_trajectory_server_runs_with_what_launch_hands_it(launch_node, ros_client, tmp_path, amplitude):
    """An integer reaches the node when launch reads a bare ``amplitude_bar:=3``; the node accepts it either way."""
    params = tmp_path / "launch_params.yaml"
    params.write_text(yaml.safe_dump({"/**": {"ros__parameters": {"amplitude_bar": amplitude, "frequency_hz": 1}}}))
    files = ["--params-file", str(ROOT / "config" / "trajectory_server.yaml"), "--params-file", str(params)]
    proc = launch_node("trajectory_server", ["--ros-args", *files, *ros_args({"samples": 16})[1:]])
    received = ros_client.subscribe(JointTrajectory, TRAJECTORY_TOPIC, latched_qos())
    ros_client.spin_until(lambda: received, 60.0, "the latched trajectory")
    lengths = np.array([p.positions for p in received[-1].points])
    assert lengths.max() * 100.0 == pytest.approx(3.0, abs=1e-6)  # P = 100 l peaks at the 3 bar amplitude
    assert ros_client.get_parameters("trajectory_server", ["amplitude_bar"]) == {"amplitude_bar": 3.0}
    assert proc.alive(), proc.output()
