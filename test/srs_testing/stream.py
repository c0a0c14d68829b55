"""One measured run of the setpoint stream, shared by the soak, CPU-load and multi-host benchmarks and tests.

:func:`run_stream` starts trajectory_server, gait_player and hardware_node as processes (each on a
host of its own when a :class:`Placement` says so: a network namespace and its environment), with the
mock backend recording every command it is given (``record_file``), lets :mod:`.stream_probe` start
the gait, play it for ``duration_s`` and stop it, and returns the figures:

- setpoints published (the player's count at exit), delivered to the probe (a deep best-effort
  queue, beside the hardware node: what DDS delivered), taken by the hardware node (its
  ``setpoints_received``: its queue has depth 1, so a setpoint superseded before it was taken is
  not counted there), accepted, and the backend writes (``backend_writes``, the record);
- vents while playing, seen at the backend: runs of 0 bar commands in the record between the probe's
  PLAYING and STOPPING, with their durations, and the node's own ``stale_vents``;
- latency from a setpoint's stamp to its backend write (p50 / p99 / max of the per-second windows),
  the oldest setpoint at arrival, ``stale_on_arrival``;
- RSS (MiB, at PLAYING, at the end, largest) and CPU (% of one core) of every process.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from srs_ros.backends.mock import read_record
from srs_ros.core.vision.camera_calibration import save_calibration
from srs_ros.sim.scene import (
    RobotAppearance,
    SyntheticCamera,
    SyntheticScene,
    constant_velocity_poses,
    write_video,
)
from srs_testing.backend import recorded_rig
from srs_testing.netns import NetnsLab
from srs_testing.ros import NodeProcess, allocate_domain, fastdds_shm_clean, release_domain, ros_args

PROBE = Path(__file__).resolve().with_name("stream_probe.py")


@contextlib.contextmanager
def bench_env(**overrides: str):
    """A private DDS domain and environment for a benchmark run (localhost discovery); released afterwards."""
    domain = allocate_domain()
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
               ROS_LOG_DIR=os.environ.get("ROS_LOG_DIR", tempfile.mkdtemp(prefix="srs_bench_logs_")),
               PYTHONUNBUFFERED="1", **overrides)
    env.pop("ROS_STATIC_PEERS", None)
    os.environ.update({key: env[key] for key in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_LOG_DIR")})
    try:
        yield env
    finally:
        release_domain(domain)
        fastdds_shm_clean()


@dataclass
class Placement:
    """Where each role runs: a command prefix (``ip netns exec NS``) and its environment; default: here."""

    env: dict[str, str]
    prefixes: dict[str, list[str]] = field(default_factory=dict)
    envs: dict[str, dict[str, str]] = field(default_factory=dict)

    def start(self, role: str, script: str, args: list[str], log_dir: Path) -> NodeProcess:
        return NodeProcess(script, args, env=self.envs.get(role, self.env), log_dir=log_dir,
                           prefix=self.prefixes.get(role, []))


class Sampler:
    """RSS and CPU time of some processes, sampled every ``period_s`` in a thread."""

    def __init__(self, pids: dict[str, int], period_s: float = 2.0):
        self.pids = pids
        self.samples: dict[str, list[tuple[float, float, float]]] = {name: [] for name in pids}  # (t, rss MiB, cpu s)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, args=(period_s,), daemon=True)
        self._thread.start()

    def _run(self, period_s: float) -> None:
        while not self._stop.is_set():
            self.sample()
            self._stop.wait(period_s)

    def sample(self) -> None:
        for name, pid in self.pids.items():
            try:
                status = Path(f"/proc/{pid}/status").read_text()
                stat = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            rss = re.search(r"VmRSS:\s+(\d+)", status)
            if rss is None:  # exited, not yet reaped
                continue
            rss_mib = int(rss.group(1)) / 1024.0
            cpu_s = (int(stat[11]) + int(stat[12])) / os.sysconf("SC_CLK_TCK")
            self.samples[name].append((time.monotonic(), rss_mib, cpu_s))

    def close(self) -> None:
        self._stop.set()
        self._thread.join(5.0)

    def summary(self, start_s: float, end_s: float) -> dict[str, dict[str, float]]:
        """Per process: RSS at start and end of the window, the largest, and CPU % of one core in it."""
        result = {}
        for name, samples in self.samples.items():
            window = [s for s in samples if start_s - 3.0 <= s[0] <= end_s + 3.0]
            if len(window) < 2:
                continue
            (t0, rss0, cpu0), (t1, rss1, cpu1) = window[0], window[-1]
            result[name] = {"rss_start_mib": rss0, "rss_end_mib": rss1, "rss_max_mib": max(s[1] for s in window),
                            "cpu_pct": 100.0 * (cpu1 - cpu0) / (t1 - t0)}
        return result


HOSTS = {"trajectory_server": "operator", "gait_player": "operator", "hardware_node": "robot", "probe": "robot",
         "camera_tracker": "camera"}


def lab_placement(lab: NetnsLab, base_env: dict[str, str]) -> Placement:
    """Every role on its host, with that host's DDS settings."""
    return Placement(base_env, prefixes={role: lab.prefix(host) for role, host in HOSTS.items()},
                     envs={role: lab.env(host, base_env) for role, host in HOSTS.items()})


def camera_video(folder) -> tuple[str, str]:
    """A looping video of the robot moving and its floor calibration (the camera PC's input)."""
    scene = SyntheticScene(camera=SyntheticCamera(width_px=320, height_px=240, height_m=0.6),
                           robot=RobotAppearance(marker_spacing_m=0.25))
    _, truth = constant_velocity_poses(1.0, 10.0, (-0.05, 0.0, -0.4), np.array([0.05, 0.02]))
    return (str(write_video(folder / "camera.avi", scene, truth, 10.0)),
            str(save_calibration(scene.camera.calibration(), folder / "camera_calibration.yaml")))


def vents_in(record_file: Path, start_s: float, end_s: float) -> dict:
    """0 bar runs in the backend record between ``start_s`` and ``end_s`` (monotonic s): count and durations."""
    times, pressures, _ = read_record(record_file)
    inside = (times >= start_s) & (times <= end_s)
    times, zero = times[inside], ~pressures[inside].any(axis=1)
    edges = np.diff(np.r_[False, zero, False].astype(int))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)  # ends: the first write after
    durations = [float(times[min(end, times.size - 1)] - times[start]) for start, end in zip(starts, ends)]
    written = times.size
    return {"vents": len(durations), "vent_durations_s": [round(d, 3) for d in durations],
            "writes_in_window": written, "max_bar": float(pressures[inside].max()) if written else float("nan"),
            "finite": bool(np.isfinite(pressures).all())}


def run_stream(placement: Placement, rate_hz: float, duration_s: float, *, log_dir: Path | None = None,
               camera_source: str = "", camera_args: dict | None = None, then_play_s: float = 0.0, after_measure=None,
               sample_period_s: float = 2.0, params: dict[str, dict] | None = None) -> dict:
    """One run: start the nodes, play ``duration_s`` at ``rate_hz`` and return the figures (see module doc).

    After the measurement the gait plays ``then_play_s`` longer, and ``after_measure(measured_s,
    record_path)`` is called meanwhile (e.g. to cut a link); its return value is ``result["after"]``.
    ``camera_source`` (a video file) adds a camera_tracker reading it (more parameters in
    ``camera_args``, e.g. its calibration file); the probe counts its poses. ``params`` adds parameters
    per node (e.g. ``{"gait_player": {"realtime_priority": 50}}``).
    """
    params = params or {}
    log_dir = Path(log_dir or tempfile.mkdtemp(prefix="srs_stream_"))
    log_dir.mkdir(parents=True, exist_ok=True)
    rig, record = recorded_rig(log_dir)
    procs = {
        "trajectory_server": placement.start("trajectory_server", "trajectory_server", ros_args(
            {"gait": "inward_rolling", **params.get("trajectory_server", {})}), log_dir),
        "hardware_node": placement.start("hardware_node", "hardware_node", ros_args(
            {"autostart": True, "rig_file": str(rig), **params.get("hardware_node", {})}), log_dir),
        "gait_player": placement.start("gait_player", "gait_player", ros_args(
            {"rate_hz": rate_hz, **params.get("gait_player", {})}), log_dir),
    }
    if camera_source:
        procs["camera_tracker"] = placement.start("camera_tracker", "camera_tracker", ros_args(
            {"source": camera_source, "loop": True, **(camera_args or {}), **params.get("camera_tracker", {})}),
            log_dir)
    probe_args = [str(PROBE), "--duration-s", str(duration_s), "--rate-hz", str(rate_hz), "--setpoints",
                  "--then-play-s", str(then_play_s)]
    probe = placement.start("probe", "python", probe_args + (["--poses"] if camera_source else []), log_dir)
    sampler = Sampler({name: p.process.pid for name, p in procs.items()}, sample_period_s)
    try:
        _wait_line(probe, "PLAYING", 180.0)
        measured_s = _wait_line(probe, "MEASURED", duration_s + 60.0)
        after = after_measure(measured_s, record) if after_measure is not None else None
        result = json.loads(_wait_line(probe, "RESULT", then_play_s + 120.0, raw=True))
        result["after"] = after
        player = procs["gait_player"]
        player.process.send_signal(signal.SIGINT)
        player.process.wait(20.0)
        published = int(re.search(r"published (\d+) setpoints", player.output()).group(1))
    finally:
        sampler.close()
        for proc in (probe, *procs.values()):
            proc.stop()
    result["published"] = published
    result["record"] = vents_in(record, result["playing_s"], result["measured_s"])
    result["processes"] = sampler.summary(result["playing_s"], result["measured_s"])
    result["log_dir"] = str(log_dir)
    return result


def _wait_line(proc: NodeProcess, tag: str, timeout_s: float, raw: bool = False):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        for line in proc.output().splitlines():
            if line.startswith(tag + " "):
                value = line[len(tag) + 1:]
                return value if raw else float(value)
        if not proc.alive():
            raise RuntimeError(f"the stream probe ended without {tag}:\n{proc.output()[-3000:]}")
        time.sleep(0.2)
    raise RuntimeError(f"no {tag} from the stream probe within {timeout_s} s:\n{proc.output()[-3000:]}")


def summary_lines(name: str, r: dict) -> list[str]:
    """The figures of one run as printed lines."""
    series = r["series"]

    def worst(key):
        return max(series[key]) if series.get(key) else float("nan")

    def median(key):
        return float(np.median(series[key])) if series.get(key) else float("nan")

    final, before = r["final"], r["before"]
    lines = [
        f"{name}: setpoints published {r['published']}, delivered to the probe {r['setpoints_total']} "
        f"(lost {r['published'] - r['setpoints_total']}), taken by the hardware node {final['setpoints_received']} "
        f"(depth 1: the newest wins), accepted {final['setpoints_accepted']}, stale on arrival "
        f"{final['stale_on_arrival']}; backend writes {final['backend_writes']}",
        f"{name}: while playing: vents at the backend {r['record']['vents']} {r['record']['vent_durations_s']}, "
        f"stale_vents {r['during']['stale_vents'] - before['stale_vents']}, largest command "
        f"{r['record']['max_bar']:.3f} bar, all finite {r['record']['finite']}, "
        f"{r['record']['writes_in_window']} writes",
        f"{name}: latency stamp->write p50 {median('command_latency_p50_ms'):.2f} ms, p99 (worst second) "
        f"{worst('command_latency_p99_ms'):.2f} ms, max {worst('command_latency_max_ms'):.1f} ms; oldest at "
        f"arrival {worst('setpoint_arrival_age_max_ms'):.1f} ms; player stamp gaps > 50 ms "
        f"{r['stamp_gaps_over_50ms']}, largest {r['stamp_gap_max_ms']:.1f} ms; hardware_node command stalls "
        f"{r['during']['command_stalls'] - r['before']['command_stalls']}",
    ]
    for proc, figures in r["processes"].items():
        lines.append(f"{name}: {proc}: RSS {figures['rss_start_mib']:.1f} -> {figures['rss_end_mib']:.1f} MiB "
                     f"(max {figures['rss_max_mib']:.1f}), CPU {figures['cpu_pct']:.0f} %")
    return lines
