"""Observer process for the stream benchmarks: starts the gait, watches it over DDS, stops it and reports.

Run it on any host (or network namespace) of the system; it needs only DDS (ROS_DOMAIN_ID and the
discovery settings of the environment):

1. waits until ``gait_player`` publishes ``joint_setpoints``, ``hardware_node`` subscribes to it and
   ``/gait_player/start`` answers; calls it until the player has its trajectory;
2. waits for the hardware node to command (ramp-in done), prints ``PLAYING <time.monotonic()>``;
3. for ``--duration-s`` collects the hardware node's /diagnostics (counters, arrival ages, latency),
   with ``--setpoints`` the setpoint stamps (gaps in the player's stream, age at this observer), with
   ``--poses`` the camera tracker's ``robot_pose`` count (``--setpoints`` also counts every setpoint
   from before ``~/start`` to the end of the stream: what DDS delivered here);
4. prints ``MEASURED <time.monotonic()>``, lets the gait play ``--then-play-s`` longer (e.g. while a
   test cuts a link), prints ``STOPPING <time.monotonic()>``, calls ``/gait_player/stop``, waits for
   the stream to end and two more diagnostics messages, and prints ``RESULT <json>``.

Monotonic times are comparable with the mock backend's ``record_file`` (one kernel clock, also across
network namespaces). Usage: ``python test/srs_testing/stream_probe.py --duration-s 60 --rate-hz 500``
(:mod:`srs_testing.stream` runs it).
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger

from srs_ros.ros.interfaces import DIAGNOSTICS_TOPIC, POSE_TOPIC, SETPOINT_TOPIC, setpoint_qos

#: diagnostics values kept per message (numbers), for the per-second series.
SERIES_KEYS = ("setpoint_arrival_age_max_ms", "command_latency_p50_ms", "command_latency_p99_ms",
               "command_latency_max_ms", "setpoint_rate_hz", "command_rate_hz")


class Probe:
    """One rclpy node that watches the stream; every wait is a timed spin_once loop."""

    def __init__(self, want_setpoints: bool, want_poses: bool):
        rclpy.init()
        self.node = rclpy.create_node("srs_stream_probe")
        self.executor = rclpy.executors.SingleThreadedExecutor()
        self.executor.add_node(self.node)
        self.recording = False
        self.diagnostics: list[tuple[float, dict[str, str]]] = []
        self.latest: dict[str, str] = {}
        self.stamps_ns: list[int] = []
        self.setpoints_total = 0  # every setpoint seen, from before ~/start to after the stream ended
        self.ages_ms: list[float] = []
        self.poses = 0
        self.node.create_subscription(DiagnosticArray, DIAGNOSTICS_TOPIC, self._on_diagnostics, 50)
        if want_setpoints:
            self.node.create_subscription(JointState, SETPOINT_TOPIC, self._on_setpoint, setpoint_qos(depth=1000))
        if want_poses:
            self.node.create_subscription(PoseStamped, POSE_TOPIC, self._on_pose, 100)
        self.start = self.node.create_client(Trigger, "/gait_player/start")
        self.stop = self.node.create_client(Trigger, "/gait_player/stop")

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            if status.name.startswith("hardware_node"):
                self.latest = {kv.key: kv.value for kv in status.values}
                self.diagnostics.append((time.monotonic(), self.latest))

    def _on_setpoint(self, msg: JointState) -> None:
        self.setpoints_total += 1
        if self.recording:
            stamp_ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
            self.stamps_ns.append(stamp_ns)
            self.ages_ms.append((self.node.get_clock().now().nanoseconds - stamp_ns) * 1e-6)

    def _on_pose(self, _msg: PoseStamped) -> None:
        if self.recording:
            self.poses += 1

    def spin_until(self, predicate, timeout_s: float, what: str) -> None:
        end = time.monotonic() + timeout_s
        while not predicate():
            if time.monotonic() > end:
                raise SystemExit(f"stream_probe: timed out after {timeout_s} s waiting for {what}")
            self.executor.spin_once(timeout_sec=0.02)

    def spin_for(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.02)

    def call(self, client, timeout_s: float = 20.0) -> Trigger.Response:
        self.spin_until(client.service_is_ready, timeout_s, f"service {client.srv_name}")
        future = client.call_async(Trigger.Request())
        self.spin_until(future.done, timeout_s, f"answer of {client.srv_name}")
        return future.result()

    def wired(self) -> bool:
        publishers = {i.node_name for i in self.node.get_publishers_info_by_topic("/" + SETPOINT_TOPIC)}
        subscribers = {i.node_name for i in self.node.get_subscriptions_info_by_topic("/" + SETPOINT_TOPIC)}
        return "gait_player" in publishers and "hardware_node" in subscribers and bool(self.latest)


def counters(values: dict[str, str]) -> dict[str, int]:
    keys = ("setpoints_received", "setpoints_accepted", "rejected_setpoints", "stale_on_arrival", "backend_writes",
            "stale_vents", "future_stamped", "command_stalls")
    return {key: int(values.get(key, 0)) for key in keys}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--duration-s", type=float, default=60.0)
    parser.add_argument("--rate-hz", type=float, default=500.0, help="the player's rate (gap threshold)")
    parser.add_argument("--ramp-s", type=float, default=1.0, help="the player's ramp_time_s")
    parser.add_argument("--setpoints", action="store_true", help="also subscribe to joint_setpoints")
    parser.add_argument("--poses", action="store_true", help="also count robot_pose messages")
    parser.add_argument("--then-play-s", type=float, default=0.0, help="play on this long after the measurement")
    parser.add_argument("--discovery-timeout-s", type=float, default=60.0)
    args = parser.parse_args()

    probe = Probe(args.setpoints, args.poses)
    probe.spin_until(probe.wired, args.discovery_timeout_s, "gait_player -> hardware_node wiring and diagnostics")
    probe.spin_for(1.0)  # the graph is seen here first; the player's writer matches the node's reader a moment later
    while not (response := probe.call(probe.start)).success:  # the latched trajectory may still be on its way
        probe.spin_for(0.5)
    probe.spin_until(lambda: probe.latest.get("output") == "commanding", 30.0, "the hardware node commanding")
    probe.spin_for(args.ramp_s)  # the player's ramp-in
    before = counters(probe.latest)
    probe.recording = True
    playing_s = time.monotonic()
    print(f"PLAYING {playing_s:.6f}", flush=True)
    probe.spin_for(args.duration_s)
    probe.recording = False
    measured_s = time.monotonic()
    during = counters(probe.latest)
    print(f"MEASURED {measured_s:.6f}", flush=True)
    probe.spin_for(args.then_play_s)
    print(f"STOPPING {time.monotonic():.6f}", flush=True)
    probe.call(probe.stop)
    seen = len(probe.diagnostics)
    stamps, ages, poses = probe.stamps_ns, probe.ages_ms, probe.poses
    end_s = time.monotonic() + args.ramp_s + 3.0
    probe.spin_until(lambda: float(probe.latest.get("setpoint_rate_hz", 1.0)) == 0.0 and time.monotonic() > end_s,
                     args.ramp_s + 30.0, "the stream to end after ~/stop")
    probe.spin_until(lambda: len(probe.diagnostics) >= seen + 2, 10.0, "two more diagnostics messages")
    final = counters(probe.latest)
    window = [v for t, v in probe.diagnostics if playing_s < t <= measured_s]
    series = {key: [float(v[key]) for v in window if v.get(key, "n/a") != "n/a"] for key in SERIES_KEYS}
    period_ns = 1e9 / args.rate_hz
    gaps_ms = np.diff(np.array(stamps, dtype=np.int64)) * 1e-6 if len(stamps) > 1 else np.zeros(0)
    result = {
        "response": response.message, "playing_s": playing_s, "measured_s": measured_s,
        "before": before, "during": during, "final": final, "series": series, "poses": poses,
        "setpoints_seen": len(stamps), "setpoints_total": probe.setpoints_total,
        "stamp_gap_max_ms": float(gaps_ms.max()) if gaps_ms.size else float("nan"),
        "stamp_gaps_over_3_periods": int(np.sum(gaps_ms > 3 * period_ns * 1e-6)),
        "stamp_gaps_over_50ms": int(np.sum(gaps_ms > 50.0)),
        "probe_age_p50_ms": float(np.percentile(ages, 50)) if ages else float("nan"),
        "probe_age_p99_ms": float(np.percentile(ages, 99)) if ages else float("nan"),
        "probe_age_max_ms": float(np.max(ages)) if ages else float("nan"),
    }
    print("RESULT " + json.dumps(result), flush=True)
    probe.node.destroy_node()
    rclpy.try_shutdown()


if __name__ == "__main__":
    sys.exit(main())
