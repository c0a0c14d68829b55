"""Node start-up: importing a node's module loads no heavy library the node does not use at start.

The suite and a lab start many node processes; scipy cost every gait_player, trajectory_server and srs_bringup
start 0.4-0.9 s, OpenCV every node 40-90 ms (figures: benchmarks/bench_node_startup.py). Each import runs in a
fresh interpreter, as a node process starts.
"""

import subprocess
import sys

import pytest

#: Libraries of 0.1-0.9 s import time that no node needs at import.
NEVER = ("scipy", "matplotlib", "dask", "distributed", "cantools", "can", "nidaqmx")
#: node module -> the heavy libraries it may load (what it uses from its first callback on).
ALLOWED = {
    "hardware_node": (),
    "gait_player": (),
    "trajectory_server": (),
    "camera_tracker": ("cv2",),
    "sim_world": ("mujoco", "cv2"),
    "bringup": (),  # the simulated world's modules load when the sim rig's nodes are made
}
HEAVY = (*NEVER, "mujoco", "cv2")


def loaded_after_import(module: str) -> list[str]:
    code = f"import sys, {module}; print(' '.join(m for m in {HEAVY!r} if m in sys.modules))"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    return result.stdout.split()


@pytest.mark.parametrize("node", sorted(ALLOWED))
def test_importing_a_node_loads_only_the_heavy_libraries_it_uses(node):
    loaded = loaded_after_import(f"srs_ros.nodes.{node}")
    assert set(loaded) <= set(ALLOWED[node]), f"srs_ros.nodes.{node} loads {sorted(set(loaded) - set(ALLOWED[node]))}"


def test_the_guard_sees_a_heavy_import():
    """The check itself: a module that does load scipy is caught (so an empty list above means something)."""
    assert "scipy" in loaded_after_import("srs_ros.core.actuation.identification")
