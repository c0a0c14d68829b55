"""Node start-up: how long each node's module takes to import, and how long until a started node is discoverable.

For each node: the median wall time of ``python -c 'import srs_ros.nodes.<node>'`` (a fresh interpreter each
trial, ``python -c pass`` subtracted: the interpreter's own start), the heavy libraries that import pulls in,
and the median time from starting the node's process (``python -m srs_ros.nodes.<node>``) until its name is in
the ROS graph as seen by a client already on the domain (the suite starts many node processes: this is what
each launch costs before a test can talk to it). ``python -X importtime -c 'import srs_ros.nodes.<node>'``
says where an import's time goes.

Run: python benchmarks/bench_node_startup.py [--trials 5] [--nodes hardware_node gait_player ...]
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

from srs_testing import RosSession

NODES = ("hardware_node", "gait_player", "trajectory_server", "camera_tracker", "sim_world", "bringup")
#: Libraries that cost tens to hundreds of ms to import; a node should load only those it uses.
HEAVY = ("scipy", "matplotlib", "mujoco", "cv2", "cantools", "dask", "distributed", "nidaqmx", "can")
#: The name each node takes in the graph (bringup: the first of the nodes it runs).
GRAPH_NAME = {"bringup": "hardware_node"}


def import_s(module: str) -> float:
    """Wall time (s) of a fresh interpreter importing ``module``."""
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c", f"import {module}"], check=True)
    return time.perf_counter() - start


def heavy_modules(module: str) -> list[str]:
    """The :data:`HEAVY` libraries importing ``module`` loads."""
    code = f"import sys, {module}; print(' '.join(m for m in {HEAVY!r} if m in sys.modules))"
    return subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout.split()


def discoverable_s(session: RosSession, node: str, timeout_s: float = 60.0) -> float:
    """Seconds from starting ``node``'s process until its name is in the graph (the process is stopped after)."""
    name = GRAPH_NAME.get(node, node)
    args = ["--duration-s", "60"] if node == "bringup" else []
    start = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", f"srs_ros.nodes.{node}", *args], env=session.env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        while name not in session.client.node.get_node_names():
            if proc.poll() is not None or time.perf_counter() - start > timeout_s:
                raise RuntimeError(f"{node} exited ({proc.returncode}) or was not discovered in {timeout_s:g} s")
            session.client.spin_for(0.01)
        return time.perf_counter() - start
    finally:
        proc.send_signal(2)
        try:
            proc.wait(15)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        session.client.spin_until(lambda: name not in session.client.node.get_node_names(), 15.0,
                                  f"{name} gone from the graph")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=5, help="trials per figure (median), default 5")
    parser.add_argument("--nodes", nargs="+", default=list(NODES), choices=NODES, help="nodes to measure")
    args = parser.parse_args()
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    bare_s = statistics.median(import_s("sys") for _ in range(args.trials))
    print(f"node start-up, median of {args.trials} ({os.cpu_count()} cores, load {os.getloadavg()[0]:.2f}); "
          f"interpreter alone {bare_s:.2f} s")
    print(f"{'node':18s} | import s | to graph s | heavy libraries loaded by the import")
    log_dir = tempfile.mkdtemp(prefix="bench_node_startup_")
    os.environ.setdefault("ROS_LOG_DIR", log_dir)
    with RosSession(log_dir, "bench_node_startup") as session:
        for node in args.nodes:
            module = f"srs_ros.nodes.{node}"
            imported_s = statistics.median(import_s(module) for _ in range(args.trials)) - bare_s
            graph_s = statistics.median(discoverable_s(session, node) for _ in range(args.trials))
            print(f"{node:18s} | {imported_s:8.2f} | {graph_s:10.2f} | {' '.join(heavy_modules(module)) or '-'}",
                  flush=True)


if __name__ == "__main__":
    main()
