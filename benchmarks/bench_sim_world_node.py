"""CPU share of the `sim_world` node in real time, with the whole simulated loop running as separate processes.

Starts sim_world (camera at 30 fps), hardware_node on the sim rig, trajectory_server, gait_player (inward
rolling 4 bar 1 Hz) and camera_tracker (sim bands), lets them run, and reads each process's CPU time from
/proc: the share of one core each used over the measuring window (target for sim_world: <= 30 %). Also
prints the camera frames, tracked poses and ground-truth poses received per second here, and the frames
camera_tracker received and tracked per second (from its diagnostics).

Run: python benchmarks/bench_sim_world_node.py [--duration-s 20] [--camera-rate-hz 30] [--dds-profile default|camera]
     [--camera-encoding bayer_rggb8|bgr8]
"""

import argparse
import os
import tempfile
import time
from pathlib import Path

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


def tracker_frames(diagnostics) -> tuple[float, int, int]:
    """(stamp s, frames received, frames tracked) of camera_tracker's newest diagnostics."""
    for array in reversed(diagnostics):
        for status in array.status:
            values = diagnostic_values(status)
            if status.name.startswith("camera_tracker") and "frames" in values:
                stamp_s = array.header.stamp.sec + array.header.stamp.nanosec * 1e-9
                return stamp_s, int(values["frames"]), int(values["tracked_frames"])
    raise RuntimeError("no camera_tracker diagnostics with a frame count")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration-s", type=float, default=20.0, help="measuring window, s (default 20)")
    parser.add_argument("--camera-rate-hz", type=float, default=30.0, help="sim_world camera rate (default 30)")
    parser.add_argument("--dds-profile", choices=("default", "camera"), default="default",
                        help="default: Fast DDS's defaults, as launch/srs.launch.py starts the nodes (a 512 KB "
                             "shared-memory segment); camera: the opt-in config/fastdds_camera_shm.xml")
    parser.add_argument("--camera-encoding", choices=("bayer_rggb8", "bgr8"), default="bayer_rggb8",
                        help="sim_world's image encoding (default bayer_rggb8, 0.3 MB a frame; bgr8 0.9 MB)")
    args = parser.parse_args()
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    with RosSession(tempfile.mkdtemp(prefix="bench_sim_world_node_")) as session:  # stops every process at the end
        processes = launch_sim_loop(session.launch, {"sim_world": {"camera_rate_hz": args.camera_rate_hz,
                                                                   "camera_encoding": args.camera_encoding},
                                                     "trajectory_server": {"samples": 64}},
                                    dds_profile=args.dds_profile == "camera")
        client = session.client
        images = client.subscribe(Image, "image_raw", 1)
        tracked = client.subscribe(PoseStamped, "robot_pose")
        truth = client.subscribe(PoseStamped, "sim/ground_truth_pose")
        diagnostics = client.subscribe(DiagnosticArray, "/diagnostics")
        client.spin_until(lambda: len(tracked) > 10, 60.0, "tracked poses (the loop running)")
        client.spin_for(2.0)  # past start-up
        counts = (len(images), len(tracked), len(truth))
        tracker_start = tracker_frames(diagnostics)
        start = {name: cpu_seconds(p.process.pid) for name, p in processes.items()}
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
        rates = [(len(x) - c) / span_s for x, c in zip((images, tracked, truth), counts)]
        print(f"  received here: images {rates[0]:.1f}/s, tracked poses {rates[1]:.1f}/s, ground truth "
              f"{rates[2]:.1f}/s")
        tracker_end = tracker_frames(diagnostics)
        tracker_span_s = tracker_end[0] - tracker_start[0]
        print(f"  camera_tracker: {(tracker_end[1] - tracker_start[1]) / tracker_span_s:.1f} images/s received, "
              f"{(tracker_end[2] - tracker_start[2]) / tracker_span_s:.1f}/s tracked (its diagnostics; fewer "
              "tracked than received: the robot rolled out of view)")


if __name__ == "__main__":
    main()
