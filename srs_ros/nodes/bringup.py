"""``srs_bringup``: the whole SRS in one process, all nodes on one executor (the main job).

Starts ``trajectory_server`` (fits the gait at start-up), ``gait_player`` (autostart) and the
lifecycle ``hardware_node`` (autostart: configured and active) on the chosen rig (the mock robot by
default), plus a small status monitor that prints gait, phase, setpoint and command rates and the
largest commanded pressure until Ctrl-C (or ``--duration-s``); then the valves are vented.

On a rig with real regulators (``can``, ``daq``) nothing above 0 bar is commanded until the operator
arms it: ``--arm`` on the command line, or ``ros2 service call /hardware_node/arm std_srvs/srv/Trigger``
while it runs. A hardware node that cannot start (a bad rig, a missing bus) stops the bringup with
exit status 2 and the reason. Ctrl-C (once or several times) vents, then exits 0.

Executors: the real-time path (gait_player, hardware_node, status) shares one EventsExecutor, driven
by a timed spin_once loop in the main thread (its spin() hangs in this rclpy); the trajectory_server
keeps its own multi-threaded executor in a second thread so that a fit (~0.1 s) never holds up a
setpoint or a command (a MultiThreadedExecutor for everything was measured to drop the 200 Hz streams
to 10-40 Hz in this rclpy). The GIL switch interval is lowered to 0.5 ms so the real-time thread gets
the interpreter back quickly while a fit runs.

Example: ``srs_bringup --gait serpentine --amplitude-bar 3 --frequency-hz 0.5``. ROS arguments
after ``--ros-args`` are passed on (e.g. remappings). ``launch/srs.launch.py`` starts the same nodes
as separate processes on a stock ROS install.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import threading
import time

import rclpy
import yaml
from rclpy.executors import MultiThreadedExecutor
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from srs_ros.core.errors import ConfigurationError
from srs_ros.core.robot import default_robot
from srs_ros.core.safety import min_setpoint_rate_hz
from srs_ros.nodes.common import (
    COMMANDED_PRESSURE_TOPIC,
    SETPOINT_TOPIC,
    CleanExit,
    guard_parameter_services,
    init_ros,
    setpoint_qos,
    spin_until_shutdown,
    steady_timer,
)
from srs_ros.nodes.gait_player import GaitPlayer
from srs_ros.nodes.hardware_node import HardwareNode, release_and_report
from srs_ros.nodes.trajectory_server import TrajectoryServer


class StatusMonitor(Node):
    """Counts setpoints and commands and prints one status line per period."""

    def __init__(self, player: GaitPlayer, server: TrajectoryServer, hardware: HardwareNode, period_s: float):
        super().__init__("srs_status")
        self._player, self._server, self._hardware = player, server, hardware
        self._setpoints = 0
        self._commands = 0
        self._largest_bar = 0.0
        self._since_s = time.monotonic()
        self._start_s = self._since_s
        self._tty = sys.stdout.isatty()
        self.create_subscription(JointState, SETPOINT_TOPIC, self._on_setpoint, setpoint_qos())
        self.create_subscription(Float64MultiArray, COMMANDED_PRESSURE_TOPIC, self._on_command, 10)
        steady_timer(self, period_s, self._print)

    def _on_setpoint(self, _msg: JointState) -> None:
        self._setpoints += 1

    def _on_command(self, msg: Float64MultiArray) -> None:
        self._commands += 1
        self._largest_bar = max(self._largest_bar, max(msg.data, default=0.0))

    def status_line(self) -> str:
        """One line: gait request, phase, rates (Hz) and the largest pressure commanded in the period."""
        now_s = time.monotonic()
        span_s = max(now_s - self._since_s, 1e-9)
        get = self._server.get_parameter
        playback = self._player.playback
        line = (f"[{now_s - self._start_s:6.1f} s] {get('gait').value} {get('amplitude_bar').value:g} bar "
                f"{get('frequency_hz').value:g} Hz | {playback.state.value} phase {playback.phase:4.2f} | "
                f"setpoints {self._setpoints / span_s:5.0f} Hz | commands {self._commands / span_s:5.0f} Hz | "
                f"largest {self._largest_bar:4.2f} bar | hardware {self._hardware.status.reason.value}")
        self._setpoints = self._commands = 0
        self._largest_bar = 0.0
        self._since_s = now_s
        return line

    def _print(self) -> None:
        line = self.status_line()
        if self._tty:
            print("\r" + line.ljust(140), end="", flush=True)
        else:
            print(line, flush=True)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="srs_bringup", description=__doc__.split("\n")[0])
    parser.add_argument("--gait", default="inward_rolling", help="gait to stream (default inward_rolling)")
    parser.add_argument("--amplitude-bar", type=float, default=None,
                        help="largest pressure, bar (default: the robot's max_pressure_bar, 4)")
    parser.add_argument("--frequency-hz", type=float, default=1.0, help="gait frequency, Hz (default 1)")
    parser.add_argument("--samples", type=int, default=64, help="samples per fitted cycle (default 64)")
    parser.add_argument("--rate-hz", type=float, default=200.0, help="setpoint rate, Hz (default 200)")
    parser.add_argument("--rig", default="", help="rig YAML (default: config/rigs/mock.yaml, the mock robot)")
    parser.add_argument("--backend", default="", help="override the rig's backend: mock, can or daq")
    parser.add_argument("--arm", action="store_true",
                        help="the operator's go for a rig with real regulators: command pressures at once "
                             "(without it such a rig stays at 0 bar until ~/arm is called)")
    parser.add_argument("--realtime-priority", type=int, default=0, choices=range(0, 99), metavar="0-98",
                        help="SCHED_FIFO priority of the process, so CPU load cannot delay setpoints (needs an "
                             "rtprio limit or CAP_SYS_NICE; default 0 = the normal scheduler)")
    parser.add_argument("--duration-s", type=float, default=0.0, help="stop after this long; 0 = until Ctrl-C")
    parser.add_argument("--status-period-s", type=float, default=1.0, help="status line period, s (default 1)")
    return parser


def _params_file(args: argparse.Namespace) -> str:
    if args.amplitude_bar is None:
        args.amplitude_bar = default_robot().max_pressure_bar
    params = {
        "trajectory_server": {"gait": args.gait, "amplitude_bar": args.amplitude_bar,
                              "frequency_hz": args.frequency_hz, "samples": args.samples},
        "gait_player": {"autostart": True, "rate_hz": args.rate_hz, "realtime_priority": args.realtime_priority},
        "hardware_node": {"autostart": True, "rig_file": args.rig, "backend": args.backend,
                          "realtime_priority": args.realtime_priority},
    }
    with tempfile.NamedTemporaryFile("w", prefix="srs_bringup_", suffix=".yaml", delete=False) as stream:
        yaml.safe_dump({name: {"ros__parameters": values} for name, values in params.items()}, stream)
        return stream.name


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    ros_args = argv[argv.index("--ros-args"):] if "--ros-args" in argv else []
    args = build_parser().parse_args(argv[:len(argv) - len(ros_args)])
    ros_args = ros_args or ["--ros-args"]
    outcome = CleanExit()
    with outcome:
        init_ros(["srs_bringup", *ros_args, "--params-file", _params_file(args)])
    if outcome.exit_code:
        return outcome.exit_code
    sys.setswitchinterval(0.0005)
    realtime = EventsExecutor()
    fitting = MultiThreadedExecutor(num_threads=2)
    fitting_thread = threading.Thread(target=_spin_quietly, args=(fitting,), name="trajectory_server", daemon=True)
    nodes: list[Node] = []
    hardware = server = None
    try:
        with outcome:
            server, player, hardware = TrajectoryServer(), GaitPlayer(), HardwareNode()
            nodes = [server, player, hardware, StatusMonitor(player, server, hardware, args.status_period_s)]
            for node in nodes:
                guard_parameter_services(node)
            _check_hardware(hardware, args)
            outcome.started = True
            fitting.add_node(server)
            fitting_thread.start()
            for node in nodes[1:]:
                realtime.add_node(node)
            spin_until_shutdown(realtime, args.duration_s)
    finally:
        realtime.shutdown()
        if hardware is not None:
            release_and_report(hardware, "srs_bringup")
        elif outcome.exit_code == 0:
            outcome.exit_code = 1
        if server is not None:
            server.wait_for_fit()
        fitting.shutdown()
        if fitting_thread.is_alive():
            fitting_thread.join(timeout=10.0)
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
    return outcome.exit_code


def _check_hardware(hardware: HardwareNode, args: argparse.Namespace) -> None:
    """Refuse to run without a working hardware node or with too slow a stream; arm on ``--arm``."""
    state = hardware.lifecycle_label()
    if state != "active":
        raise ConfigurationError(f"hardware_node could not start (it is {state}): "
                                 f"{hardware.status.last_error or 'see the log above'}")
    slowest_hz = min_setpoint_rate_hz(hardware.gate.setpoint_timeout_s)
    if args.rate_hz < slowest_hz:
        raise ConfigurationError(f"--rate-hz {args.rate_hz:g} is too slow for the rig's setpoint timeout of "
                                 f"{hardware.gate.setpoint_timeout_s:g} s (the valves would pulse); expected at "
                                 f"least {slowest_hz:g} Hz.")
    if not hardware.gate.requires_arm:
        return
    if args.arm:
        refusal = hardware.gate.arm()
        if refusal:
            raise ConfigurationError(f"--arm: {refusal}")
        hardware.get_logger().warning(f"ARMED by --arm: the {hardware.backend.name} rig commands pressures, "
                                      f"ramping up from 0 bar over {hardware.gate.ramp_time_s:g} s")
    else:
        print(f"srs_bringup: the {hardware.backend.name} rig drives real regulators: holding 0 bar until the "
              f"operator arms it: ros2 service call {hardware.get_fully_qualified_name()}/arm "
              "std_srvs/srv/Trigger (or start with --arm)", flush=True)


def _spin_quietly(executor) -> None:
    with CleanExit():
        executor.spin()


if __name__ == "__main__":
    sys.exit(main())
