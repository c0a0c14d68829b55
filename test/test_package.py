"""The package itself: lint, layout, package.xml, console scripts, and a real colcon build."""

import ast
import configparser
import importlib
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _console_scripts():
    tree = ast.parse((ROOT / "setup.py").read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Dict):
            for key, value in zip(node.keys, node.values):
                if isinstance(key, ast.Constant) and key.value == "console_scripts":
                    return [entry.value for entry in value.elts]
    raise AssertionError("setup.py declares no console_scripts")


SCRIPTS = {line.split("=")[0].strip(): line.split("=")[1].strip() for line in _console_scripts()}


def _venv_tool(name):
    tool = Path(sys.executable).with_name(name)
    return str(tool) if tool.exists() else shutil.which(name)


def test_ruff_lint_is_clean():
    result = subprocess.run([_venv_tool("ruff"), "check", "srs_ros", "test", "benchmarks", "launch"],
                            cwd=ROOT, capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr


def test_core_has_no_ros_imports():
    offenders = []
    for path in (ROOT / "srs_ros" / "core").glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else (
                [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            offenders += [f"{path.name}: {n}" for n in names
                          if n.split(".")[0] in {"rclpy", "launch", "launch_ros"} or n.split(".")[0].endswith("_msgs")]
    assert offenders == []


def test_package_xml_is_format_3_with_runtime_dependencies():
    root = ET.parse(ROOT / "package.xml").getroot()
    assert root.get("format") == "3" and root.findtext("name") == "srs_ros"
    assert root.find("export/build_type").text == "ament_python"
    deps = {e.text for e in root.findall("exec_depend")}
    assert {"rclpy", "std_srvs", "sensor_msgs", "trajectory_msgs", "diagnostic_msgs", "lifecycle_msgs",
            "python3-numpy", "python3-scipy", "python3-yaml"} <= deps


def test_setup_cfg_puts_scripts_under_lib():
    cfg = configparser.ConfigParser()
    cfg.read(ROOT / "setup.cfg")
    assert cfg["develop"]["script_dir"] == "$base/lib/srs_ros"
    assert cfg["install"]["install_scripts"] == "$base/lib/srs_ros"


@pytest.mark.parametrize("script", sorted(SCRIPTS))
def test_every_console_script_has_a_main(script):
    module_name, func = SCRIPTS[script].split(":")
    assert callable(getattr(importlib.import_module(module_name), func))


def test_colcon_build_installs_scripts_config_and_launch(tmp_path):
    colcon = _venv_tool("colcon")
    assert colcon, "colcon is not installed (pip install -e '.[test]')"
    result = subprocess.run(
        [colcon, "--log-base", str(tmp_path / "log"), "build", "--base-paths", str(ROOT),
         "--build-base", str(tmp_path / "build"), "--install-base", str(tmp_path / "install")],
        cwd=tmp_path, capture_output=True, text=True, timeout=300,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    prefix = tmp_path / "install" / "srs_ros"
    for script in SCRIPTS:
        assert (prefix / "lib" / "srs_ros" / script).is_file(), script
    share = prefix / "share" / "srs_ros"
    assert (share / "package.xml").is_file()
    assert (share / "config" / "robot.yaml").is_file()
    assert (share / "config" / "rigs" / "mock.yaml").is_file()
    assert sorted(p.name for p in (share / "launch").glob("*.launch.py")) == ["srs.launch.py"]
    assert (prefix / "share" / "ament_index" / "resource_index" / "packages" / "srs_ros").is_file()
