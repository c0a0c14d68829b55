"""config/<node>.yaml are generated from the nodes' parameter specs and stay equal to them (one source of defaults)."""

import shutil

import pytest
import yaml

from srs_ros.core.robot import config_dir
from srs_ros.ros.parameters import params_file_key
from srs_ros.tools.node_config import NODES, config_text, main, node_specs, robot_dependent


@pytest.mark.parametrize("node", NODES)
def test_the_shipped_params_file_is_the_one_generated_from_the_specs(node):
    path = config_dir() / f"{node}.yaml"
    assert path.read_text(encoding="utf-8") == config_text(node), (
        f"{path} differs from {node}'s parameter specs: run python -m srs_ros.tools.node_config")


@pytest.mark.parametrize("node", NODES)
def test_the_file_holds_every_declared_parameter_at_its_default_with_its_type(node):
    values = yaml.safe_load((config_dir() / f"{node}.yaml").read_text())[params_file_key(node)]["ros__parameters"]
    specs = [spec for spec in node_specs(node) if spec.name not in robot_dependent(node)]
    assert values == {spec.name: spec.default for spec in specs}
    assert all(type(values[spec.name]) is type(spec.default) for spec in specs)  # 4.0 stays a double for ROS


def test_the_trajectory_server_file_leaves_the_gaits_own_parameters_to_gaits_yaml():
    names = {spec.name for spec in node_specs("trajectory_server")}
    assert {"gait", "amplitude_bar", "frequency_hz", "samples", "robot_description_file"} <= names
    assert not any("." in name for name in names)


def test_the_trajectory_server_file_suits_a_robot_with_a_lower_limit(ros_domain, tmp_path):
    """The file set amplitude_bar 4.0, the default robot's limit: a robot limited to 3 bar could not start with the
    file the launch file passes (a helper's review). Its default, the robot's limit, is now only a comment."""
    import rclpy
    from rclpy.context import Context

    from srs_ros.nodes.trajectory_server import TrajectoryServer

    assert robot_dependent("trajectory_server") == {"amplitude_bar"} and robot_dependent("gait_player") == set()
    robot = tmp_path / "robot.yaml"
    text = (config_dir() / "robot.yaml").read_text()
    robot.write_text(text.replace("max_pressure_bar: 4.0", "max_pressure_bar: 3.0"))
    context = Context()
    rclpy.init(context=context, domain_id=ros_domain, args=[
        "--ros-args", "--params-file", str(config_dir() / "trajectory_server.yaml"),
        "-p", f"robot_description_file:={robot}", "-p", "generate_on_start:=false"])
    try:
        server = TrajectoryServer(context=context)
        assert server.get_parameter("amplitude_bar").value == 3.0
        server.destroy_node()
    finally:
        rclpy.shutdown(context=context)


def test_check_names_a_drifted_file_and_the_generator_mends_it(tmp_path, capsys):
    for node in NODES:
        shutil.copy(config_dir() / f"{node}.yaml", tmp_path)
    assert main(["--check", "--config-dir", str(tmp_path)]) == 0
    drifted = tmp_path / "gait_player.yaml"
    drifted.write_text(drifted.read_text().replace("rate_hz: 200.0", "rate_hz: 100.0"))
    assert main(["--check", "--config-dir", str(tmp_path)]) == 1
    assert str(drifted) in capsys.readouterr().err
    assert main(["--config-dir", str(tmp_path)]) == 0
    assert drifted.read_text() == config_text("gait_player")


def test_a_block_keyed_as_the_shipped_files_are_applies_to_the_node_in_a_namespace(launch_node, ros_client, tmp_path):
    """`ros2 launch ... namespace:=snake1` runs /snake1/gait_player: a bare `gait_player:` block (the shipped files'
    key until stop 57) means /gait_player only and was silently not applied there (a helper's review)."""
    path = config_dir() / "gait_player.yaml"
    changed = tmp_path / "gait_player.yaml"
    changed.write_text(path.read_text().replace("rate_hz: 200.0", "rate_hz: 123.0"))
    launch_node("gait_player", ["--ros-args", "-r", "__ns:=/snake1", "--params-file", str(changed)])
    ros_client.spin_until(lambda: "/snake1/gait_player/get_parameters" in dict(
        ros_client.node.get_service_names_and_types()), 15.0, "/snake1/gait_player")
    assert ros_client.get_parameters("/snake1/gait_player", ["rate_hz"]) == {"rate_hz": 123.0}


@pytest.mark.parametrize("check", [False, True])
def test_a_config_dir_that_is_not_a_folder_is_refused_with_the_reason(tmp_path, capsys, check):
    """A missing folder gave a FileNotFoundError traceback, and --check said every file differed (a helper's review)."""
    missing = tmp_path / "missing" / "sub"
    with pytest.raises(SystemExit) as stop:
        main(["--config-dir", str(missing), *(["--check"] if check else [])])
    assert stop.value.code == 2 and f"--config-dir {missing}: not a folder" in capsys.readouterr().err
    assert not missing.exists()
