"""Benchmark: cross-process gait_player timing and setpoint -> hardware command latency over real DDS.

Starts trajectory_server, gait_player (autostart) and hardware_node (autostart, mock rig) as separate
processes on a private domain, listens to ``joint_setpoints`` from this process, and for each rate:

- period error of the gait_player timer: |stamp[i+1] - stamp[i] - 1/rate| (us), p50 / p99 / max;
- lost setpoints: published (gait_player prints its count at exit) minus received here, over the whole
  run (the stream starts only after discovery); timer ticks missed: stamps expected at the rate minus
  stamps received during the measurement (scheduling stalls of the timer, not DDS losses); gaps: intervals
  longer than 1.5 periods;
- latency from a setpoint's stamp to the hardware node's write to the backend (ms), p50 / p99, as
  measured inside hardware_node and reported on /diagnostics (windows of the last 2000 setpoints;
  the worst window's p99 is reported);
- CPU use of each process (% of one core).

Run: python benchmarks/bench_pipeline.py [--rates 200 500 1000] [--duration-s 60]
Targets (issue 4): at 500 Hz p99 period error <= 150 us, p99 latency <= 1.5 ms, no lost setpoints over 60 s.
"""

from __future__ import annotations

import argparse
import os
import re
import signal
import time
from pathlib import Path

import numpy as np
from srs_testing import NodeProcess, RosClient, allocate_domain, fastdds_shm_clean, release_domain, ros_args


def _cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _diagnostic_values(msg) -> dict[str, str]:
    from srs_ros.ros.interfaces import diagnostic_values

    for status in msg.status:
        if status.name.startswith("hardware_node"):
            return diagnostic_values(status)
    return {}


def run_rate(rate_hz: float, duration_s: float, env: dict[str, str], client: RosClient) -> dict[str, float]:
    from diagnostic_msgs.msg import DiagnosticArray
    from sensor_msgs.msg import JointState

    from srs_ros.ros.interfaces import setpoint_qos, stamp_to_nanoseconds

    received_total = [0]
    total_sub = client.node.create_subscription(
        JointState, "joint_setpoints", lambda _m: received_total.__setitem__(0, received_total[0] + 1),
        setpoint_qos(depth=100))
    processes = [
        NodeProcess("trajectory_server", ros_args({"gait": "inward_rolling"}), env=env),
        NodeProcess("hardware_node", ros_args({"autostart": True}), env=env),
        NodeProcess("gait_player", ros_args({"rate_hz": rate_hz}), env=env),
    ]
    player = processes[-1]
    try:
        stamps_ns: list[int] = []
        recording = [False]

        def on_setpoint(msg):
            if recording[0]:
                stamps_ns.append(stamp_to_nanoseconds(msg.header.stamp))

        diag: list[dict[str, str]] = []
        sub = client.node.create_subscription(JointState, "joint_setpoints", on_setpoint, setpoint_qos(depth=100))
        dsub = client.node.create_subscription(
            DiagnosticArray, "/diagnostics", lambda m: diag.append(_diagnostic_values(m)) if recording[0] else None, 10)
        # Start only once both ends know each other, so every published setpoint can be counted here.
        client.spin_until(lambda: client.node.count_publishers("joint_setpoints") >= 1, 30.0, "gait_player")
        client.spin_until(lambda: client.node.count_subscribers("gait_trajectory") >= 1
                          and client.node.count_publishers("gait_trajectory") >= 1, 30.0, "trajectory wiring")
        client.spin_for(1.0)
        started = client.trigger("gait_player/start", timeout_s=30.0)
        while not started.success:  # the first fit may still be running
            client.spin_for(0.5)
            started = client.trigger("gait_player/start", timeout_s=30.0)
        client.spin_until(lambda: received_total[0] > 2 * rate_hz, 60.0, "the setpoint stream (ramp-in)")
        cpu0 = {p.script: _cpu_seconds(p.process.pid) for p in processes}
        t0 = time.monotonic()
        recording[0] = True
        client.spin_for(duration_s)
        recording[0] = False
        elapsed = time.monotonic() - t0
        cpu = {name: 100.0 * (_cpu_seconds(p.process.pid) - cpu0[name]) / elapsed
               for name, p in ((p.script, p) for p in processes)}
        player.process.send_signal(signal.SIGINT)  # its last words: how many setpoints it published
        client.spin_until(lambda: player.process.poll() is not None, 15.0, "gait_player exit")
        client.spin_for(0.5)
        published = int(re.search(r"published (\d+) setpoints", player.output()).group(1))
        for subscription in (sub, dsub, total_sub):
            client.node.destroy_subscription(subscription)
    finally:
        for proc in processes:
            proc.stop()
    return {"rate_hz": rate_hz, "published_total": published, "received_total": received_total[0],
            **_stream_figures(np.array(stamps_ns, dtype=np.int64), rate_hz, diag),
            **{f"cpu_{k}_pct": v for k, v in cpu.items()}}


def _stream_figures(stamps: np.ndarray, rate_hz: float, diag: list[dict[str, str]]) -> dict[str, float]:
    """Setpoints received against expected, gaps, period error (us) and the node's command latency (ms)."""
    period_ns = 1e9 / rate_hz
    dt = np.diff(stamps)
    error_us = np.abs(dt - period_ns) / 1e3
    expected = int(round((stamps[-1] - stamps[0]) / period_ns)) + 1
    p50 = [float(d["command_latency_p50_ms"]) for d in diag if d.get("command_latency_p50_ms", "n/a") != "n/a"]
    p99 = [float(d["command_latency_p99_ms"]) for d in diag if d.get("command_latency_p99_ms", "n/a") != "n/a"]
    return {
        "received": len(stamps), "expected": expected, "gaps": int(np.sum(dt > 1.5 * period_ns)),
        "period_p50_us": float(np.percentile(error_us, 50)), "period_p99_us": float(np.percentile(error_us, 99)),
        "period_max_us": float(error_us.max()),
        "latency_p50_ms": float(np.median(p50)) if p50 else float("nan"),
        "latency_p99_ms": float(np.max(p99)) if p99 else float("nan"),
    }

def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rates", type=float, nargs="+", default=[200.0, 500.0, 1000.0])
    parser.add_argument("--duration-s", type=float, default=60.0)
    args = parser.parse_args()
    results = []
    for rate in args.rates:
        domain = allocate_domain()
        env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
                   ROS_LOG_DIR=os.environ.get("ROS_LOG_DIR", "/tmp/srs_bench_logs"))
        os.environ.update({k: env[k] for k in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_LOG_DIR")})
        try:
            with RosClient(domain, "srs_bench") as client:
                results.append(run_rate(rate, args.duration_s, env, client))
        finally:
            release_domain(domain)
            fastdds_shm_clean()
        r = results[-1]
        print(f"{r['rate_hz']:6.0f} Hz over {args.duration_s:g} s: "
              f"lost {r['published_total'] - r['received_total']} of {r['published_total']} published, "
              f"{r['expected'] - r['received']} timer ticks missed, gaps {r['gaps']} | "
              f"period error p50 {r['period_p50_us']:.0f} us, p99 {r['period_p99_us']:.0f} us, "
              f"max {r['period_max_us']:.0f} us | latency p50 {r['latency_p50_ms']:.3f} ms, "
              f"p99 {r['latency_p99_ms']:.3f} ms | CPU player {r['cpu_gait_player_pct']:.0f} %, "
              f"hardware {r['cpu_hardware_node_pct']:.0f} %, server {r['cpu_trajectory_server_pct']:.0f} %",
              flush=True)
    print("targets at 500 Hz: p99 period error <= 150 us, p99 latency <= 1.5 ms, no lost setpoints")


if __name__ == "__main__":
    main()
