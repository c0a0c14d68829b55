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

from srs_ros.ros.interfaces import DDS_PROFILE_FILE

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


def test_core_and_sim_have_no_ros_imports_in_any_subfolder():
    offenders = []
    paths = sorted((ROOT / "srs_ros" / "core").rglob("*.py")) + sorted((ROOT / "srs_ros" / "sim").rglob("*.py"))
    assert {"gait", "actuation", "vision"} <= {p.parent.name for p in paths}  # the walk reaches the domain folders
    for path in paths:
        for node in ast.walk(ast.parse(path.read_text())):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else (
                [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            offenders += [f"{path.relative_to(ROOT)}: {n}" for n in names
                          if n.split(".")[0] in {"rclpy", "launch", "launch_ros"} or n.split(".")[0].endswith("_msgs")]
    assert offenders == []


def test_package_xml_is_format_3_with_runtime_dependencies():
    root = ET.parse(ROOT / "package.xml").getroot()
    assert root.get("format") == "3" and root.findtext("name") == "srs_ros"
    assert root.find("export/build_type").text == "ament_python"
    deps = {e.text for e in root.findall("exec_depend")}
    assert {"rclpy", "std_srvs", "sensor_msgs", "trajectory_msgs", "diagnostic_msgs", "lifecycle_msgs",
            "python3-numpy", "python3-scipy", "python3-yaml"} <= deps


# ------------------------------------------------------------------------------------------
# package.xml against rosdep: every key resolves on Jazzy, every import is declared, nothing more
# ------------------------------------------------------------------------------------------
#: Keys that rosdep resolves on Jazzy (a snapshot of ros/rosdistro's rosdep/base.yaml, rosdep/python.yaml and
#: jazzy/distribution.yaml, kept in the repo; refresh it from rosdistro when the distribution moves on).
ROSDEP_KEYS = ROOT / "test" / "data" / "rosdep-keys-jazzy.txt"
#: Top-level Python module -> rosdep key, for every third-party import of the package, its tests, launch
#: files, benchmarks and setup.py. None: no rosdep key exists (documented in package.xml instead).
IMPORT_KEYS = {
    "numpy": "python3-numpy", "scipy": "python3-scipy", "yaml": "python3-yaml",
    "matplotlib": "python3-matplotlib", "cv2": "python3-opencv", "can": "python3-can",
    "cantools": "python3-cantools-pip", "mujoco": "python3-mujoco-pip", "rosbags": "python3-rosbags-pip",
    "tqdm": "python3-tqdm",
    "nidaqmx": None, "dask": None, "distributed": None, "pytest": "python3-pytest", "hypothesis": "python3-hypothesis",
    "setuptools": "python3-setuptools", "ament_index_python": "ament_index_python", "rclpy": "rclpy",
    "launch": "launch", "launch_ros": "launch_ros", "rcl_interfaces": "rcl_interfaces",
    "builtin_interfaces": "builtin_interfaces",
}
#: Tools the tests run rather than import: pytest-timeout (setup.cfg ``timeout``), pytest-xdist (scripts/test.sh
#: ``-n 2``), ruff, colcon.
TOOL_KEYS = {"python3-pytest-timeout", "python3-pytest-xdist", "python3-ruff-pip", "python3-colcon-common-extensions"}
#: The package's own modules and test helpers (not dependencies).
OWN_MODULES = {"srs_ros", "srs_testing", "conftest"}


def _declared_keys():
    root = ET.parse(ROOT / "package.xml").getroot()
    kinds = ("depend", "exec_depend", "build_depend", "buildtool_depend", "test_depend", "build_export_depend")
    return {e.text.strip() for kind in kinds for e in root.findall(kind)}


def _third_party_imports():
    """Top-level module -> files importing it, over every Python file of the repo (not .venv, build trees)."""
    folders = ("srs_ros", "test", "launch", "benchmarks")
    files = [ROOT / "setup.py"] + [p for d in folders for p in (ROOT / d).rglob("*.py")
                                   if "fakes" not in p.parts]  # stand-ins for packages that cannot be installed here
    local = {p.stem for p in files} | {p.name for d in folders for p in (ROOT / d).rglob("*")  # test packages
                                       if p.is_dir() and "fakes" not in p.parts}
    found: dict[str, set[str]] = {}
    for path in files:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                top = name.split(".")[0]
                if top not in sys.stdlib_module_names and top not in OWN_MODULES and top not in local:
                    found.setdefault(top, set()).add(str(path.relative_to(ROOT)))
    return found


def _key_of(module):
    if module.endswith(("_msgs", "_srvs")):
        return module
    return IMPORT_KEYS[module]


def test_every_package_xml_key_resolves_with_rosdep_on_jazzy():
    known = set(ROSDEP_KEYS.read_text().split())
    unknown = sorted(_declared_keys() - known)
    assert unknown == [], (f"package.xml keys that rosdep cannot resolve on Jazzy: {unknown}; pick keys from "
                           f"{ROSDEP_KEYS.relative_to(ROOT)} (e.g. python3-<name>-pip for PyPI packages)")


def test_every_third_party_import_is_declared_in_package_xml():
    imports = _third_party_imports()
    unmapped = sorted(m for m in imports if not m.endswith(("_msgs", "_srvs")) and m not in IMPORT_KEYS)
    assert unmapped == [], f"imports with no rosdep key in IMPORT_KEYS (add one): {unmapped}"
    declared = _declared_keys()
    missing = {m: _key_of(m) for m in imports if _key_of(m) and _key_of(m) not in declared}
    assert missing == {}, f"imported but not declared in package.xml (module: key): {missing}"


def test_package_xml_declares_nothing_the_code_and_tests_do_not_use():
    used = {_key_of(m) for m in _third_party_imports()} | TOOL_KEYS
    extra = sorted(_declared_keys() - used)
    assert extra == [], f"package.xml declares keys that nothing imports or runs: {extra}"



def test_setup_cfg_puts_scripts_under_lib():
    cfg = configparser.ConfigParser()
    cfg.read(ROOT / "setup.cfg")
    assert cfg["develop"]["script_dir"] == "$base/lib/srs_ros"
    assert cfg["install"]["install_scripts"] == "$base/lib/srs_ros"


@pytest.mark.parametrize("script", sorted(SCRIPTS))
def test_every_console_script_has_a_main(script):
    module_name, func = SCRIPTS[script].split(":")
    assert callable(getattr(importlib.import_module(module_name), func))


@pytest.mark.slow
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
    assert (share / "config" / DDS_PROFILE_FILE).is_file()  # the opt-in camera profile (docs/navigation.md)
    assert sorted(p.name for p in (share / "launch").glob("*.launch.py")) == ["srs.launch.py"]
    assert (prefix / "share" / "ament_index" / "resource_index" / "packages" / "srs_ros").is_file()
    # the test harness is for the development install only (test/pyproject.toml), never in a ROS install
    assert sorted(p.name for p in (tmp_path / "install").iterdir() if p.is_dir()) == ["srs_ros"]
    assert not [str(p) for p in (tmp_path / "install").rglob("srs_testing*")]


# ------------------------------------------------------------------------------------------
# Documents that belong to the package
# ------------------------------------------------------------------------------------------
def _text_files():
    folders = ("srs_ros", "launch", "config", "docs", "scripts", "benchmarks")
    paths = [ROOT / "README.md", ROOT / "package.xml", ROOT / "setup.py"]
    return paths + [p for d in folders for p in (ROOT / d).rglob("*") if p.is_file() and p.suffix != ".pyc"]


def test_license_file_is_the_apache_2_text_that_the_package_claims():
    root = ET.parse(ROOT / "package.xml").getroot()
    assert root.findtext("license") == "Apache-2.0"
    text = (ROOT / "LICENSE").read_text()
    assert "Apache License" in text and "Version 2.0, January 2004" in text and "END OF TERMS AND CONDITIONS" in text
    assert len(text) > 11000  # the full text, not a pointer to it


def test_nothing_points_outside_the_repository():
    offenders = [str(p.relative_to(ROOT)) for p in _text_files()
                 if "../shared" in p.read_text(errors="ignore") or "CONVENTIONS.md" in p.read_text(errors="ignore")]
    assert offenders == []


def test_readme_names_the_image_topic_that_camera_tracker_subscribes_to():
    from srs_ros.ros.interfaces import IMAGE_TOPIC

    readme = (ROOT / "README.md").read_text()
    assert f"`{IMAGE_TOPIC}` (sensor_msgs/Image" in readme and "`image` (sensor_msgs/Image)" not in readme
