"""CPU share of the `sim_world` node in real time, with the whole simulated loop running as separate processes.

Starts sim_world (camera at 30 fps), hardware_node on the sim rig, trajectory_server, gait_player (inward
rolling 4 bar 1 Hz) and camera_tracker (sim bands), lets them run, and reads each process's CPU time from
/proc: the share of one core each used over the measuring window (target for sim_world: <= 30 %). Also
prints the camera frames, tracked poses and ground-truth poses received per second here, and the frames
camera_tracker received and tracked per second (from its diagnostics).

Run: python benchmarks/bench_sim_world_node.py [--duration-s 20] [--camera-rate-hz 30] [--dds-profile default|camera]
     [--camera-encoding bayer_rggb8|bgr8] [--watch-images] [--sim-world-param NAME=VALUE ...]

Also prints sim_world's CPU by thread (main: the executor's callbacks; the physics thread; Fast DDS's own).
"""

import argparse
import os
import tempfile
import time
from pathlib import Path

import yaml
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import Image
from srs_testing import RosSession, launch_sim_loop

from srs_ros.ros.interfaces import diagnostic_values

CLOCK_TICKS = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid: int) -> float:
    """utime + stime of a process (s)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS


def thread_cpu_seconds(pid: int) -> dict[str, float]:
    """utime + stime of each thread of a process (s), by thread name (threads of one name summed).

    Python threads carry the process's name, so they are named by their thread id ("main" for the first).
    """
    seconds: dict[str, float] = {}
    process_name = Path(f"/proc/{pid}/comm").read_text().strip()
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            name = (task / "comm").read_text().strip()
            if name == process_name:
                name = "main" if task.name == str(pid) else f"thread {task.name}"
            fields = (task / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:  # the thread ended meanwhile
            continue
        seconds[name] = seconds.get(name, 0.0) + (int(fields[11]) + int(fields[12])) / CLOCK_TICKS
    return seconds


def tracker_frames(diagnostics) -> tuple[float, int, int]:
    """(stamp s, frames received, frames tracked) of camera_tracker's newest diagnostics."""
    for array in reversed(diagnostics):
        for status in array.status:
            values = diagnostic_values(status)
            if status.name.startswith("camera_tracker") and "frames" in values:
                stamp_s = array.header.stamp.sec + array.header.stamp.nanosec * 1e-9
                return stamp_s, int(values["frames"]), int(values["tracked_frames"])
    raise RuntimeError("no camera_tracker diagnostics with a frame count")


def parse_assignment(text: str) -> tuple[str, object]:
    """``NAME=VALUE`` -> (name, value), the value read as YAML (as ``ros2 run ... -p`` reads it)."""
    name, sep, value = text.partition("=")
    if not sep or not name:
        raise SystemExit(f"--sim-world-param {text!r}: expected NAME=VALUE, e.g. markers_rate_hz=0")
    return name, yaml.safe_load(value)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration-s", type=float, default=20.0, help="measuring window, s (default 20)")
    parser.add_argument("--camera-rate-hz", type=float, default=30.0, help="sim_world camera rate (default 30)")
    parser.add_argument("--dds-profile", choices=("default", "camera"), default="default",
                        help="default: Fast DDS's defaults, as launch/srs.launch.py starts the nodes (a 512 KB "
                             "shared-memory segment); camera: the opt-in config/fastdds_camera_shm.xml")
    parser.add_argument("--camera-encoding", choices=("bayer_rggb8", "bgr8"), default="bayer_rggb8",
                        help="sim_world's image encoding (default bayer_rggb8, 0.3 MB a frame; bgr8 0.9 MB)")
    parser.add_argument("--watch-images", action="store_true",
                        help="also subscribe to image_raw here (a second reader, as a viewer would be; sim_world "
                             "then delivers every frame twice). Default: camera_tracker is the only reader, as in "
                             "the main job, and its diagnostics give the frame rate")
    parser.add_argument("--sim-world-param", action="append", default=[], metavar="NAME=VALUE",
                        help="another sim_world parameter (YAML value), e.g. markers_rate_hz=0; repeatable")
    args = parser.parse_args()
    sim_world = {"camera_rate_hz": args.camera_rate_hz, "camera_encoding": args.camera_encoding}
    sim_world.update(parse_assignment(text) for text in args.sim_world_param)
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    with RosSession(tempfile.mkdtemp(prefix="bench_sim_world_node_")) as session:  # stops every process at the end
        processes = launch_sim_loop(session.launch, {"sim_world": sim_world,
                                                     "trajectory_server": {"samples": 64}},
                                    dds_profile=args.dds_profile == "camera")
        client = session.client
        images = client.subscribe(Image, "image_raw", 1) if args.watch_images else []
        tracked = client.subscribe(PoseStamped, "robot_pose")
        truth = client.subscribe(PoseStamped, "sim/ground_truth_pose")
        diagnostics = client.subscribe(DiagnosticArray, "/diagnostics")
        client.spin_until(lambda: len(tracked) > 10, 60.0, "tracked poses (the loop running)")
        client.spin_for(2.0)  # past start-up
        counts = (len(images), len(tracked), len(truth))
        tracker_start = tracker_frames(diagnostics)
        start = {name: cpu_seconds(p.process.pid) for name, p in processes.items()}
        sim_threads_start = thread_cpu_seconds(processes["sim_world"].process.pid)
        started_s = time.monotonic()
        client.spin_for(args.duration_s)
        span_s = time.monotonic() - started_s
        print(f"simulated loop, {span_s:.1f} s window, camera {args.camera_rate_hz:g} fps {args.camera_encoding}, "
              f"DDS profile "
              f"{args.dds_profile} "
              f"({os.cpu_count()} cores, load {os.getloadavg()[0]:.2f}):")
        for name, proc in processes.items():
            share = 100.0 * (cpu_seconds(proc.process.pid) - start[name]) / span_s
            target = "  (target <= 30 %)" if name == "sim_world" else ""
            print(f"  {name:18s} {share:5.1f} % of a core{target}")
        sim_threads = thread_cpu_seconds(processes["sim_world"].process.pid)
        busiest = sorted(sim_threads, key=lambda n: sim_threads[n] - sim_threads_start.get(n, 0.0), reverse=True)
        print("  sim_world by thread: " + ", ".join(
            f"{n} {100.0 * (sim_threads[n] - sim_threads_start.get(n, 0.0)) / span_s:.1f} %" for n in busiest[:5]))
        rates = [(len(x) - c) / span_s for x, c in zip((images, tracked, truth), counts)]
        watched = "" if args.watch_images else " (not watched)"
        print(f"  received here: images {rates[0]:.1f}/s{watched}, tracked poses {rates[1]:.1f}/s, ground truth "
              f"{rates[2]:.1f}/s")
        tracker_end = tracker_frames(diagnostics)
        tracker_span_s = tracker_end[0] - tracker_start[0]
        print(f"  camera_tracker: {(tracker_end[1] - tracker_start[1]) / tracker_span_s:.1f} images/s received, "
              f"{(tracker_end[2] - tracker_start[2]) / tracker_span_s:.1f}/s tracked (its diagnostics; fewer "
              "tracked than received: the robot rolled out of view)")


if __name__ == "__main__":
    main()
