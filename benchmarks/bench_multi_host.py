"""Benchmark: the 500 Hz stream across three hosts (network namespaces, DDS over UDP) beside loopback.

Three runs of trajectory_server + gait_player (operator's host) -> hardware_node (robot's host) with
camera_tracker reading a video (camera's host) and the observer beside the hardware node:

- loopback: every process on this host with Fast DDS's defaults (shared memory between processes);
- loopback UDP: every process on this host, UDP only (FASTDDS_BUILTIN_TRANSPORTS=UDPv4);
- 3 hosts: each host a network namespace on a private subnet joined by a bridge, UDP only, discovery
  through ROS_STATIC_PEERS (srs_testing.netns.NetnsLab; root needed).

Prints for each: setpoints published / delivered over DDS / taken by the hardware node / written,
stamp -> backend write latency (p50, worst per-second p99, max), vents, CPU and RSS.
Run: sudo python benchmarks/bench_multi_host.py [--duration-s 60] [--rate-hz 500]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from srs_testing import NetnsLab, fastdds_shm_clean
from srs_testing.stream import Placement, bench_env, camera_video, lab_placement, run_stream, summary_lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--duration-s", type=float, default=60.0)
    parser.add_argument("--rate-hz", type=float, default=500.0)
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="srs_multi_host_"))
    video, calibration = camera_video(folder)
    camera = {"camera_source": video, "camera_args": {"calibration_file": calibration}}
    with bench_env() as env:
        runs = [("loopback shm", Placement(env)),
                ("loopback UDP", Placement(dict(env, FASTDDS_BUILTIN_TRANSPORTS="UDPv4")))]
        for name, placement in runs:
            result = run_stream(placement, args.rate_hz, args.duration_s, log_dir=folder / name.split()[1],
                                **camera)
            fastdds_shm_clean()
            print("\n".join(summary_lines(name, result)), flush=True)
        with NetnsLab(["operator", "robot", "camera"]) as lab:
            result = run_stream(lab_placement(lab, env), args.rate_hz, args.duration_s, log_dir=folder / "hosts",
                                **camera)
        print("\n".join(summary_lines("3 hosts UDP", result)), flush=True)


if __name__ == "__main__":
    main()
