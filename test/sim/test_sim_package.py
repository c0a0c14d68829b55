"""srs_ros/sim is ROS-free: a world, a camera and experiments usable without rclpy."""

import ast
from pathlib import Path

SIM = Path(__file__).resolve().parents[2] / "srs_ros" / "sim"


def test_the_sim_package_has_no_ros_imports():
    offenders = []
    for path in SIM.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else (
                [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            offenders += [f"{path.name}: {n}" for n in names
                          if n.split(".")[0] in {"rclpy", "launch", "launch_ros"} or n.split(".")[0].endswith("_msgs")]
    assert len(list(SIM.glob("*.py"))) >= 5 and offenders == []
