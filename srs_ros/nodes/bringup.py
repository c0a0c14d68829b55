"""``srs_bringup``: the whole SRS in one process, all nodes on one executor (the main job).

Starts ``trajectory_server`` (fits the gait at start-up), ``gait_player`` (autostart) and the
lifecycle ``hardware_node`` (autostart: configured and active) on the chosen rig, plus a small status
monitor (:mod:`srs_ros.nodes.bringup_nodes`) that prints gait, cycles, setpoint and command rates and the
largest commanded pressure until Ctrl-C (or ``--duration-s``); then the valves are vented.

The default rig is the simulated robot (``config/rigs/sim.yaml``): the bringup then also runs
``sim_world`` (MuJoCo, real time) and ``camera_tracker`` on its overhead camera (colour bands), and the
status line shows the tracked traveling speed beside the ground truth (cm/s); while the tracker reports the
robot out of the camera's view (or the camera silent) on ``/diagnostics`` the line says so with where the
robot was last seen, and the tracked speed shows ``--``. ``--video FILE`` saves the camera's view.
``--rig config/rigs/mock.yaml`` runs the muscle-only mock instead.

``--navigate`` closes the loop: the ``navigator`` (:mod:`srs_ros.nodes.navigator`) drives the gait to the goals
sent on ``goal_pose`` / ``goal_path`` by the camera's pose, the gait player waits for it, and the status line
adds the navigator's state, goal, distance to go and heading error. ``--patrol`` also sends it waypoints to
patrol in a loop (``--waypoint X Y`` ..., by default on the sim rig a rectangle inside the simulated camera's
view): the main job, ``scripts/run.sh``, does this unless it is given ``--gait`` (open loop).

On a rig with real regulators (``can``, ``daq``) nothing above 0 bar is commanded until the operator
arms it: ``--arm`` on the command line, or ``ros2 service call /hardware_node/arm std_srvs/srv/Trigger``
while it runs. A hardware node that cannot start (a bad rig, a missing bus) stops the bringup with
exit status 2 and the reason. Ctrl-C (once or several times) vents, then exits 0.

Executors: the real-time path (gait_player, hardware_node, status) shares one EventsExecutor, driven
by a timed spin_once loop in the main thread (its spin() hangs in this rclpy); the trajectory_server
keeps its own multi-threaded executor in a second thread so that a fit (~0.1 s) never holds up a
setpoint or a command; the simulated world, the camera tracker and the video recorder share a third
executor on a third thread, with the navigator (it only reads poses and calls services); a
MultiThreadedExecutor for everything was measured to drop the 200 Hz streams to 10-40 Hz in this rclpy. The
GIL switch interval is lowered to 0.5 ms so the real-time thread gets the interpreter back quickly while a
fit runs.

Example: ``srs_bringup --gait serpentine --amplitude-bar 3 --frequency-hz 0.5``. ROS arguments
after ``--ros-args`` are passed on (e.g. remappings) and win over the options above
(``--ros-args -p gait:=serpentine`` is the same as ``--gait serpentine``). ``launch/srs.launch.py``
starts the same nodes as separate processes on a stock ROS install.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import threading
import traceback
from typing import Any

import rclpy
import yaml
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor, SingleThreadedExecutor
from rclpy.experimental import EventsExecutor
from rclpy.logging import LoggingSeverity, set_logger_level
from rclpy.node import Node

from srs_ros.core import rig as rig_config
from srs_ros.core.actuation.safety import min_setpoint_rate_hz
from srs_ros.core.errors import ConfigurationError, SrsError
from srs_ros.core.gait import request
from srs_ros.core.gait.library import list_gaits
from srs_ros.core.rig import load_rig
from srs_ros.core.robot import amplitude_field, default_robot
from srs_ros.nodes import gait_player
from srs_ros.nodes.bringup_nodes import (  # noqa: F401 (SpeedMeter, navigation_text: this module's API too)
    Patrol,
    SpeedMeter,
    StatusMonitor,
    VideoRecorder,
    navigation_text,
)
from srs_ros.nodes.gait_player import GaitPlayer
from srs_ros.nodes.hardware_node import HardwareNode, release_and_report
from srs_ros.nodes.navigator import Navigator
from srs_ros.nodes.trajectory_server import TrajectoryServer
from srs_ros.ros.parameters import params_file_key
from srs_ros.ros.process import SHUTDOWN, CleanExit, guard_services, init_ros, spin_until_shutdown

#: The main job's patrol on the sim rig (m, floor frame): a rectangle well inside the simulated camera's view
#: (2.9 m x 2.3 m around the origin, where the robot starts), kept view_margin_m inside its edge.
SIM_PATROL_XY_M = ((0.4, 0.4), (-0.4, 0.4), (-0.4, -0.4), (0.4, -0.4))


def spec_defaults() -> dict[str, Any]:
    """The defaults of the options that set node parameters, read from the nodes' specs (as the launch file's)."""
    player = {spec.name: spec for spec in gait_player.PARAMETERS}
    return {"gait": request.gait_field(list_gaits()).default,
            "amplitude_bar": amplitude_field(default_robot()).default,
            "frequency_hz": request.FREQUENCY_FIELD.default, "samples": request.SAMPLES_FIELD.default,
            "rate_hz": player["rate_hz"].default, "rig": str(rig_config.rig_path(rig_config.SYSTEM_RIG)),
            "realtime_priority": player["realtime_priority"].default}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="srs_bringup", description=__doc__.split("\n")[0])
    default = spec_defaults()
    parser.add_argument("--gait", default=default["gait"], help=f"gait to stream (default {default['gait']}; "
                        "with --navigate the navigator chooses)")
    parser.add_argument("--amplitude-bar", type=float, default=default["amplitude_bar"],
                        help=f"largest pressure, bar (default: the robot's limit, {default['amplitude_bar']:g}); "
                        "with --navigate the navigator's cruise amplitude (0.5-4 bar)")
    parser.add_argument("--frequency-hz", type=float, default=default["frequency_hz"],
                        help=f"gait frequency, Hz (default {default['frequency_hz']:g}; with --navigate the "
                        "navigator chooses: its cruise_frequency_hz)")
    parser.add_argument("--samples", type=int, default=default["samples"],
                        help=f"samples per fitted cycle (default {default['samples']})")
    parser.add_argument("--rate-hz", type=float, default=default["rate_hz"],
                        help=f"setpoint rate, Hz (default {default['rate_hz']:g})")
    parser.add_argument("--rig", default=default["rig"],
                        help=f"rig YAML (default: config/rigs/{rig_config.SYSTEM_RIG}.yaml, the simulated robot; "
                             "config/rigs/mock.yaml is the muscle-only mock, can.yaml and daq.yaml drive real "
                             "regulators)")
    parser.add_argument("--backend", default="", help="override the rig's backend: sim, mock, can or daq")
    parser.add_argument("--sim-config", default="", help="simulation YAML for the sim rig (default config/sim.yaml)")
    parser.add_argument("--video", default="", help="sim rig: save the overhead camera's view to this file (.avi)")
    parser.add_argument("--arm", action="store_true",
                        help="the operator's go for a rig with real regulators: command pressures at once "
                             "(without it such a rig stays at 0 bar until ~/arm is called)")
    parser.add_argument("--realtime-priority", type=int, default=default["realtime_priority"],
                        choices=range(0, 99), metavar="0-98",
                        help="SCHED_FIFO priority of the process, so CPU load cannot delay setpoints (needs an "
                             "rtprio limit or CAP_SYS_NICE; default 0 = the normal scheduler)")
    parser.add_argument("--navigate", action="store_true",
                        help="closed loop: start the navigator, which drives the gait to the goals sent on goal_pose "
                             "(RViz's 2D Goal Pose, frame floor) or goal_path by the camera's pose (the gait player "
                             "waits for it); docs/navigation.md")
    parser.add_argument("--patrol", action="store_true",
                        help="navigate and patrol waypoints in a loop: --waypoint's, or on the sim rig "
                             f"{' '.join(f'({x:g}, {y:g})' for x, y in SIM_PATROL_XY_M)} m, inside the simulated "
                             "camera's view (scripts/run.sh does this unless given --gait)")
    parser.add_argument("--waypoint", nargs=2, type=float, action="append", metavar=("X_M", "Y_M"), default=None,
                        help="a patrol waypoint (floor frame, m); repeat for each, in order")
    parser.add_argument("--duration-s", type=float, default=0.0, help="stop after this long; 0 = until Ctrl-C")
    parser.add_argument("--status-period-s", type=float, default=1.0, help="status line period, s (default 1)")
    return parser


def _params_file(args: argparse.Namespace, ros_args: list[str]) -> str:
    """The bringup's parameters as a temporary params file, without those the ROS arguments set.

    A ``-p name:=value`` applies to every node (``/**``), and rcl lets a node's own entry in a params
    file beat a wildcard: so a name given with ``-p`` is left out here for the user's value to win.
    The file is passed before the user's ROS arguments, so their own ``--params-file`` wins too.
    """
    given = {value.split(":=", 1)[0] for flag, value in zip(ros_args, ros_args[1:]) if flag in ("-p", "--param")}
    params = {
        "trajectory_server": {"gait": args.gait, "amplitude_bar": args.amplitude_bar,
                              "frequency_hz": args.frequency_hz, "samples": args.samples},
        "gait_player": {"autostart": not _navigating(args), "rate_hz": args.rate_hz,
                        "realtime_priority": args.realtime_priority},
        "hardware_node": {"autostart": True, "rig_file": args.rig, "backend": args.backend,
                          "realtime_priority": args.realtime_priority},
        "sim_world": {"sim_config_file": args.sim_config},
        "camera_tracker": {"color_preset": rig_config.SIM_COLOR_PRESET, "sim_config_file": args.sim_config},
        "navigator": {"calibration_preset": rig_config.SIM_COLOR_PRESET if _simulated(args) else "",
                      "loop_path": bool(args.patrol), "amplitude_bar": args.amplitude_bar,
                      "sim_config_file": args.sim_config},
    }
    params = {node: {k: v for k, v in values.items() if k not in given} for node, values in params.items()}
    with tempfile.NamedTemporaryFile("w", prefix="srs_bringup_", suffix=".yaml", delete=False) as stream:
        # "/**/name": the node in whatever namespace the process is given (``-r __ns:=/snake1``).
        yaml.safe_dump({params_file_key(name): {"ros__parameters": values} for name, values in params.items()}, stream)
        return stream.name


def main(argv: list[str] | None = None) -> int:
    """Console script ``srs_bringup``: 0 when stopped, 1 after a failure while running, 2 if it cannot start."""
    args, ros_args = _parse_arguments(argv)
    outcome = CleanExit()
    _init_ros(args, ros_args, outcome)
    if outcome.exit_code:
        return outcome.exit_code
    sys.setswitchinterval(0.0005)  # the real-time thread gets the interpreter back quickly while a fit runs
    system = System()
    try:
        with outcome:
            system.create_nodes(args)
            _check_hardware(system.hardware, system.player, args)
            outcome.started = True
            system.start()
            spin_until_shutdown(system.realtime, args.duration_s)
            if system.failure:
                outcome.exit_code = 1
    finally:
        system.stop(outcome)
        SHUTDOWN.ignore_from_now()
    return outcome.exit_code


def _parse_arguments(argv: list[str] | None) -> tuple[argparse.Namespace, list[str]]:
    """The bringup's own options, and the ROS arguments from ``--ros-args`` on (passed on to rclpy)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    ros_args = argv[argv.index("--ros-args"):] if "--ros-args" in argv else []
    parser = build_parser()
    args = parser.parse_args(argv[:len(argv) - len(ros_args)])
    if not (math.isfinite(args.status_period_s) and args.status_period_s > 0.0):
        parser.error(f"--status-period-s {args.status_period_s:g}: expected seconds > 0")
    if not (math.isfinite(args.duration_s) and args.duration_s >= 0.0):
        parser.error(f"--duration-s {args.duration_s:g}: expected seconds >= 0 (0 = until Ctrl-C)")
    if args.video and not os.access(os.path.dirname(os.path.abspath(args.video)), os.W_OK):
        parser.error(f"--video {args.video}: its folder does not exist or is not writable; expected a .avi path in a "
                     "writable folder")
    if args.waypoint and not args.patrol:
        parser.error("--waypoint X_M Y_M is a patrol waypoint: add --patrol (or send goals on goal_path)")
    if args.patrol and not args.waypoint:
        try:
            simulated = _rig_backend(args) == "sim"
        except SrsError as exc:  # a misspelled --rig: said as such, not as a rig without waypoints
            parser.error(str(exc))
        if not simulated:
            parser.error("--patrol on a rig other than the simulated robot needs its waypoints (--waypoint X_M Y_M, "
                         "inside your camera's calibrated floor area)")
        args.waypoint = [list(p) for p in SIM_PATROL_XY_M]
    return args, ros_args


def _navigating(args: argparse.Namespace) -> bool:
    return bool(args.navigate or args.patrol)


def _simulated(args: argparse.Namespace) -> bool:
    """True for the sim rig; False also for a rig file that cannot be read (the hardware node says why)."""
    try:
        return _rig_backend(args) == "sim"
    except SrsError:
        return False


def _init_ros(args: argparse.Namespace, ros_args: list[str], outcome: CleanExit) -> None:
    """Initialise rclpy with the bringup's parameters, then the user's ROS arguments (which win)."""
    params_file = _params_file(args, ros_args)
    try:
        with outcome:
            init_ros(["srs_bringup", "--ros-args", "--params-file", params_file, *ros_args[1:]])
    finally:
        os.unlink(params_file)  # rcl has parsed it in init


class System:
    """The bringup's nodes and its three executors (see the module docstring), started and stopped in order."""

    def __init__(self) -> None:
        """The executors and their threads; no node yet."""
        self.realtime = EventsExecutor()  # gait_player, hardware_node, status: spun by the main thread
        self.fitting = MultiThreadedExecutor(num_threads=2)  # trajectory_server: a fit never holds up a command
        self.world = SingleThreadedExecutor()  # sim_world, camera_tracker, the video recorder
        self._world_stop = threading.Event()
        self._threads = (
            threading.Thread(target=self._spin, args=(self.fitting.spin,), name="trajectory_server", daemon=True),
            threading.Thread(target=self._spin, args=(self._spin_world,), name="sim_world", daemon=True))
        self.failure = ""  # a worker thread's error, which stops the bringup
        self.server: TrajectoryServer | None = None
        self.player: GaitPlayer | None = None
        self.hardware: HardwareNode | None = None
        self.status: StatusMonitor | None = None
        self.navigator: Navigator | None = None
        self.recorder: VideoRecorder | None = None
        self.tracker: Node | None = None  # the camera tracker (sim rig)
        self.world_nodes: list[Node] = []
        self.nodes: list[Node] = []

    def create_nodes(self, args: argparse.Namespace) -> None:
        """Every node of the rig's system; the simulated world first, as the hardware node talks to it.

        Each node is kept as soon as it exists, so that :meth:`stop` destroys it whatever fails after it
        (a simulated world left alive at exit steps and publishes while rclpy shuts down: a segfault).
        """
        simulated = _rig_backend(args) == "sim"
        if simulated:
            self._create_world(args)
        self.server = self._keep(TrajectoryServer())
        self.player = self._keep(GaitPlayer())
        self.hardware = self._keep(HardwareNode())
        if _navigating(args):  # on the world's executor: it only calls the gait nodes' services
            # the navigator changes the cycle every second or two: the player's takeover lines would bury the
            # status line, which shows the navigator's state instead (its warnings and errors still show)
            set_logger_level(self.player.get_logger().name, LoggingSeverity.WARN)
            self.navigator = self._keep(Navigator())
            self.world_nodes.append(self.navigator)
            if args.patrol:
                self.world_nodes.append(self._keep(Patrol(args.waypoint)))
        tracker = self.tracker
        self.status = self._keep(StatusMonitor(self.player, self.server, self.hardware, args.status_period_s,
                                               simulated, None if tracker is None
                                               else (tracker.status_name, tracker.hardware_id),
                                               navigating=_navigating(args)))
        for node in self.nodes:
            guard_services(node)

    def _create_world(self, args: argparse.Namespace) -> None:
        """The simulated robot, the camera tracker on its images and (``--video``) the recorder.

        Their modules (MuJoCo, OpenCV) are imported here: a rig without the simulated robot never loads them.
        """
        from srs_ros.nodes.camera_tracker import CameraTrackerNode
        from srs_ros.nodes.sim_world import SimWorldNode

        world = self._keep(SimWorldNode())
        self.tracker = self._keep(CameraTrackerNode())
        self.world_nodes = [world, self.tracker]
        if args.video:
            self.recorder = self._keep(VideoRecorder(args.video, world.get_parameter("camera_rate_hz").value))
            self.world_nodes.append(self.recorder)

    def _keep(self, node):
        self.nodes.append(node)
        return node

    def start(self) -> None:
        """Hand the nodes to their executors and start the two spinning threads."""
        self.fitting.add_node(self.server)
        self._threads[0].start()
        for node in (self.player, self.hardware, self.status):
            self.realtime.add_node(node)
        for node in self.world_nodes:
            self.world.add_node(node)
        if self.world_nodes:
            self._threads[1].start()

    def _spin(self, spin) -> None:
        """A worker thread: ``spin()`` until shutdown; an error in it stops the whole bringup (vent, exit status 1).

        Before, an unwritable --video ended the world thread while the status line went on printing, and exited 0.
        """
        try:
            spin()
        except (KeyboardInterrupt, ExternalShutdownException):
            pass
        except Exception as exc:
            if not isinstance(exc, SrsError):  # an unexpected error: its traceback too
                traceback.print_exc()
            reason = str(exc).rstrip(".")
            self.failure = f"the {threading.current_thread().name} thread stopped: {type(exc).__name__}: {reason}"
            print(f"srs_bringup: {self.failure}; venting and exiting with status 1", file=sys.stderr, flush=True)
            SHUTDOWN.request(self.failure)

    def _spin_world(self) -> None:
        """A timed spin_once loop until the bringup stops (or rclpy's shutdown)."""
        while not self._world_stop.is_set() and rclpy.ok():
            self.world.spin_once(timeout_sec=0.05)

    def stop(self, outcome: CleanExit) -> None:
        """Vent first; then let a fit finish, stop the threads, finish the video, destroy the nodes, shut down."""
        self.realtime.shutdown()
        if self.hardware is not None:
            release_and_report(self.hardware, "srs_bringup")
        elif outcome.exit_code == 0:
            outcome.exit_code = 1
        if self.server is not None:
            self.server.wait_for_fit()
        self.fitting.shutdown()
        self._world_stop.set()
        for thread in self._threads:
            if thread.is_alive():
                thread.join(timeout=10.0)
        self.world.shutdown()
        if self.recorder is not None:
            self.recorder.close()
        for node in self.nodes:
            node.destroy_node()
        rclpy.try_shutdown()


def _rig_backend(args: argparse.Namespace) -> str:
    return args.backend or load_rig(args.rig or None).backend


def _check_hardware(hardware: HardwareNode, player: GaitPlayer, args: argparse.Namespace) -> None:
    """Refuse to run without a working hardware node or with too slow a stream; arm on ``--arm``."""
    state = hardware.lifecycle_label()
    if state != "active":
        raise ConfigurationError(f"hardware_node could not start (it is {state}): "
                                 f"{hardware.status.last_error or 'see the log above'}")
    slowest_hz = min_setpoint_rate_hz(hardware.gate.setpoint_timeout_s)
    rate_hz = player.get_parameter("rate_hz").value  # --rate-hz, or a -p rate_hz:= or params file that beat it
    if rate_hz < slowest_hz:
        raise ConfigurationError(f"gait_player's rate_hz {rate_hz:g} (--rate-hz) is too slow for the rig's setpoint "
                                 f"timeout of {hardware.gate.setpoint_timeout_s:g} s (the valves would pulse); "
                                 f"expected at least {slowest_hz:g} Hz.")
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


if __name__ == "__main__":
    sys.exit(main())
