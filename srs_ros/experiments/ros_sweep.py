"""The sweep as a ROS client of running nodes, on any rig (the simulated robot or the real one), recorded as rosbag2.

For each run :class:`RosSweep` does what an experimenter does by hand: set the trajectory
(``trajectory_server`` parameters ``gait``, ``amplitude_bar``, ``frequency_hz`` + ``~/regenerate``) and the
player's ``frequency_hz``; on the simulated rig put the robot back at its start (``sim_world/reset``); on a
rig with real regulators ask the operator's go (the ``go`` callback: a prompt or ``--yes``) and only then
call ``hardware_node/arm`` (on every rig: the vent before a run disarms a simulated one too); take the start
pose from ``robot_pose`` (the camera tracker), call ``gait_player/start``, wait the run time, call
``gait_player/stop``, wait until the commanded pressures are vented and a settle time, take the end pose,
disarm. The traveling velocity is the paper's: the displacement
between the robot at rest before and after the run divided by the run time (the player's ramp-in and
ramp-out together make up one run time of full amplitude).

Every run is recorded as a rosbag2 directory (``metadata.yaml`` + MCAP, :class:`~srs_ros.experiments.recording.
BagRecorder`) from raw subscriptions: :data:`RECORDED_TOPICS` (the latched gait trajectory is written at the
start of each bag; ``sim/ground_truth_pose`` appears where a simulated robot publishes it).

A run aborts, vents (player stop, disarm) and is returned as a failed record with the reason when the
hardware node reports an ERROR (a backend fault) or a latched e-stop on ``/diagnostics``, or the pose is
missing; :class:`SweepStopped` ends the whole sweep where going on would be unsafe (the valves did not
vent). Ctrl-C (:meth:`RosSweep.install_interrupt_handler`) vents the same way, uninterrupted, and closes the
bag: what was recorded is kept. Waits use timed ``spin_once`` loops (this rclpy's ``spin()`` hangs).
"""

from __future__ import annotations

import math
import signal
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from rcl_interfaces.srv import SetParameters
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.serialization import deserialize_message
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory

from srs_ros.core.actuation.operator import REAL_ARM_PREFIX
from srs_ros.core.errors import SrsError
from srs_ros.core.gait.library import list_gaits
from srs_ros.experiments.recording import BagRecorder, bag_qos
from srs_ros.experiments.table import ROS_SETTLE_S, Cell, RunRecord
from srs_ros.nodes import gait_player
from srs_ros.ros.interfaces import (
    ACTUATOR_STATE_TOPIC,
    BUSY_RETRY_S,
    COMMANDED_PRESSURE_TOPIC,
    DIAGNOSTICS_TOPIC,
    GROUND_TRUTH_TOPIC,
    POSE_TOPIC,
    SETPOINT_TOPIC,
    STATUS_NODE_KEY,
    TRAJECTORY_TOPIC,
    diagnostic_values,
    fit_busy,
    latched_qos,
    setpoint_qos,
)

#: (topic, message class, QoS) recorded into every run's bag.
RECORDED_TOPICS = (
    (TRAJECTORY_TOPIC, JointTrajectory, latched_qos()),
    (SETPOINT_TOPIC, JointState, setpoint_qos(depth=100)),
    (COMMANDED_PRESSURE_TOPIC, Float64MultiArray, 100),
    (ACTUATOR_STATE_TOPIC, JointState, 100),
    (POSE_TOPIC, PoseStamped, 100),
    (DIAGNOSTICS_TOPIC, DiagnosticArray, 100),
    (GROUND_TRUTH_TOPIC, PoseStamped, 100),
)
#: The hardware node a sweep drives (in its namespace); its /diagnostics status says so (STATUS_NODE_KEY).
HARDWARE_NODE = "hardware_node"
#: Commanded pressures at or below this (bar) count as vented.
VENTED_BAR = 0.01
#: Poses averaged (median) at each end of a run, s.
POSE_WINDOW_S = 0.5
#: Spin period of the waits, s.
SPIN_S = 0.02
#: gait_player's plain playback, set for every run: these parameters at their defaults (its rate and ramps stay).
PLAIN_PLAYBACK = {spec.name: spec.default for spec in gait_player.PARAMETERS
                  if spec.name in ("amplitude_scale", "reverse", "cycles", "stop_at_phase")}


def type_name(msg_class) -> str:
    """``package/msg/Name`` of a generated rclpy message class."""
    return f"{msg_class.__module__.split('.')[0]}/msg/{msg_class.__name__}"


class RunAborted(SrsError):
    """A run could not go on; the message is the reason put in the table."""


class SweepStopped(SrsError):
    """The sweep must not go on (e.g. the valves did not vent)."""


@dataclass(frozen=True)
class RosSweepOptions:
    """How runs are driven: timeouts (s), the settle time after the vent and the nodes' namespace."""

    settle_s: float = ROS_SETTLE_S
    vent_timeout_s: float = 15.0
    pose_timeout_s: float = 5.0  # at rest, before and after a run: a tracker on a busy machine pauses for 2 s
    discovery_timeout_s: float = 20.0
    service_timeout_s: float = 10.0
    fit_timeout_s: float = 120.0
    namespace: str = ""
    reset_sim: bool = True


@dataclass
class RigInfo:
    """What discovery found: whether the rig drives real regulators and whether a simulated world runs.

    ``state`` is hardware_node's lifecycle state when it was read. A node not active yet has no rig to answer
    for (its status says ``requires_arm: False`` until a rig is configured), so it counts as real regulators.
    """

    requires_arm: bool
    simulated: bool
    rig: str
    state: str = "active"


class RosSweep:
    """The sweep's rclpy client (own context, one node, timed spin loops); close it when done."""

    def __init__(self, options: RosSweepOptions | None = None, log: Callable[[str], None] = print):
        self.options = options or RosSweepOptions()
        self.log = log
        self.context = Context()
        rclpy.init(context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        namespace = self.options.namespace.strip("/")
        self._prefix = f"/{namespace}" if namespace else ""
        self.node = rclpy.create_node("srs_sweep", namespace=self._prefix or "/", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.recorder: BagRecorder | None = None
        self.rig: RigInfo | None = None
        self._clients: dict[str, object] = {}
        self._poses: list[tuple[float, float, float, float]] = []  # (monotonic s, x m, y m, yaw rad)
        self._hardware: tuple[float, DiagnosticStatus] | None = None  # (monotonic s, status)
        self._commanded: tuple[float, float] | None = None  # (monotonic s, largest pressure bar)
        self._trajectory: bytes | None = None
        self._trajectories = 0
        self.interrupted = False  # Ctrl-C seen (see install_interrupt_handler)
        self._venting = False
        for topic, msg_class, qos in RECORDED_TOPICS:
            name = self.node.resolve_topic_name(topic)
            self.node.create_subscription(msg_class, topic, self._receiver(name, msg_class), qos, raw=True)

    # -- plumbing ---------------------------------------------------------------------------
    def close(self) -> None:
        """Close the bag being written (if any) and the rclpy context."""
        if self.recorder is not None:
            self.recorder.close()
            self.recorder = None
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)

    def _offered_qos(self, topic: str) -> list:
        """The QoS profiles the topic's publishers offer, as rosbag2 records them (``ros2 bag play`` reads them)."""
        return [bag_qos(info.qos_profile) for info in self.node.get_publishers_info_by_topic(topic)]

    def _receiver(self, topic: str, msg_class):
        kind = type_name(msg_class)

        def receive(data: bytes) -> None:
            now = time.monotonic()
            if self.recorder is not None:
                self.recorder.write(topic, kind, self.node.get_clock().now().nanoseconds, data,
                                    offered_qos=lambda: self._offered_qos(topic))
            if msg_class is JointTrajectory:
                self._trajectory, self._trajectories = data, self._trajectories + 1
            elif topic.endswith("/" + POSE_TOPIC):
                pose = deserialize_message(data, PoseStamped).pose
                q = pose.orientation
                yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
                self._poses.append((now, pose.position.x, pose.position.y, yaw))
            elif msg_class is DiagnosticArray:
                for status in deserialize_message(data, DiagnosticArray).status:
                    if self._is_our_hardware(status):
                        self._hardware = (now, status)
            elif msg_class is Float64MultiArray:
                values = deserialize_message(data, Float64MultiArray).data
                self._commanded = (now, max(values, default=0.0))

        return receive

    def _is_our_hardware(self, status: DiagnosticStatus) -> bool:
        """Whether ``status`` is the status of the hardware node this sweep drives.

        /diagnostics is shared by every robot on the domain: another namespace's hardware_node (its requires_arm,
        its state) must not be taken for ours.
        """
        return diagnostic_values(status).get(STATUS_NODE_KEY) == f"{self._prefix}/{HARDWARE_NODE}"

    def install_interrupt_handler(self) -> None:
        """SIGINT/SIGTERM set :attr:`interrupted`; the waits raise ``KeyboardInterrupt`` between two spins.

        So a Ctrl-C never lands inside a bag write or a vent; the vent itself is never interrupted and
        every later signal is one and the same request (as the nodes' ``ShutdownSignals``).
        """
        def on_signal(_signum, _frame) -> None:
            self.interrupted = True

        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, on_signal)

    def _check_interrupt(self) -> None:
        if self.interrupted and not self._venting:
            raise KeyboardInterrupt

    def spin_for(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=min(SPIN_S, max(end - time.monotonic(), 0.0)))
            self._check_interrupt()

    def spin_until(self, predicate: Callable[[], bool], timeout_s: float,
                   check: Callable[[], None] | None = None) -> bool:
        """Spin until ``predicate()``; False on timeout. ``check()`` runs every spin (it may raise RunAborted)."""
        end = time.monotonic() + timeout_s
        while not predicate():
            if time.monotonic() > end:
                return False
            self.executor.spin_once(timeout_sec=SPIN_S)
            self._check_interrupt()
            if check is not None:
                check()
        return True

    def _service(self, node: str, name: str, srv_type=Trigger):
        full = f"{self._prefix}/{node}/{name}"
        if full not in self._clients:
            self._clients[full] = self.node.create_client(srv_type, full)
        return full, self._clients[full]

    def has_service(self, node: str, name: str, timeout_s: float = 0.0, srv_type=Trigger) -> bool:
        _, client = self._service(node, name, srv_type)
        return self.spin_until(client.service_is_ready, timeout_s)

    def call(self, node: str, name: str, request=None, srv_type=Trigger, timeout_s: float | None = None):
        """Call a service; :class:`RunAborted` if it is missing or does not answer in time."""
        timeout_s = self.options.service_timeout_s if timeout_s is None else timeout_s
        full, client = self._service(node, name, srv_type)
        if not self.spin_until(client.service_is_ready, timeout_s):
            raise RunAborted(f"service {full} is not available (is {node} running?)")
        future = client.call_async(request if request is not None else srv_type.Request())
        if not self.spin_until(future.done, timeout_s):
            raise RunAborted(f"service {full} did not answer within {timeout_s:g} s")
        return future.result()

    def trigger(self, node: str, name: str, timeout_s: float | None = None) -> str:
        """Call a Trigger service; :class:`RunAborted` with its message if it says no."""
        response = self.call(node, name, timeout_s=timeout_s)
        if not response.success:
            raise RunAborted(f"{node}/{name}: {response.message}")
        return response.message

    def set_parameters(self, node: str, values: dict) -> None:
        request = SetParameters.Request(
            parameters=[Parameter(k, value=v).to_parameter_msg() for k, v in values.items()])
        results = self.call(node, "set_parameters", request, SetParameters).results
        refused = [f"{name}: {r.reason}" for name, r in zip(values, results) if not r.successful]
        if refused:
            raise RunAborted(f"{node} refused the parameters: {'; '.join(refused)}")

    # -- discovery and checks ---------------------------------------------------------------
    def discover(self) -> RigInfo:
        """Wait for the nodes a sweep drives and the hardware node's status; :class:`SweepStopped` if missing."""
        timeout = self.options.discovery_timeout_s
        for node, name in (("trajectory_server", "regenerate"), ("gait_player", "start"), ("gait_player", "stop"),
                           ("hardware_node", "arm"), ("hardware_node", "disarm")):
            if not self.has_service(node, name, timeout):
                raise SweepStopped(f"no service {self._prefix}/{node}/{name} after {timeout:g} s: start the rig's "
                                   "nodes first (e.g. srs_bringup, or ros2 launch srs_ros srs.launch.py)")
        if not self.spin_until(lambda: self._hardware is not None, timeout):
            raise SweepStopped(f"no status of {self._prefix}/{HARDWARE_NODE} on /diagnostics after {timeout:g} s: is "
                               "hardware_node running?")
        values = diagnostic_values(self._hardware[1])
        # The sim backend talks to a sim_world: wait for it as for the other nodes; elsewhere just look.
        simulated = self.has_service("sim_world", "reset", timeout if values.get("backend") == "sim" else 1.0)
        self.rig = self._rig_now(simulated)
        if not self.vent():  # a player already streaming (e.g. srs_bringup's autostart) stops: runs start at rest
            raise self._not_vented("gait_player ~/stop and hardware_node ~/disarm at the start")
        return self.rig

    def _rig_now(self, simulated: bool) -> RigInfo:
        """The rig as hardware_node's last status gives it.

        Anything but an explicit "False" from an active node counts as real air: the go is asked rather than
        assumed (an unconfigured node's "False" is no rig's answer, and the operator may configure it on a real rig
        after the sweep started).
        """
        values = diagnostic_values(self._hardware[1]) if self._hardware is not None else {}
        state = values.get("lifecycle_state", "active")
        return RigInfo(requires_arm=values.get("requires_arm") != "False" or state != "active", simulated=simulated,
                       rig=values.get("rig", "unknown"), state=state)

    def hardware_problem(self) -> str:
        """Why the hardware cannot run now ('' when it can): an ERROR (backend fault) or a latched e-stop."""
        if self._hardware is None:
            return "no hardware_node status on /diagnostics"
        status = self._hardware[1]
        values = diagnostic_values(status)
        if values.get("estop_latched") == "True":
            return f"e-stop latched ({status.message}); release it with hardware_node ~/reset"
        if status.level == DiagnosticStatus.ERROR:
            return f"hardware error: {status.message}"
        if values.get("lifecycle_state", "active") != "active":
            return f"hardware_node is {values.get('lifecycle_state')}, not active"
        return ""

    def _abort_on_hardware_problem(self) -> None:
        problem = self.hardware_problem()
        if problem:
            raise RunAborted(problem)

    def _median_pose(self, since_s: float) -> tuple[float, float, float] | None:
        """Median position (and the last heading) of the poses received since ``since_s``; None if there are none."""
        recent = [p for p in self._poses if p[0] >= since_s]
        if not recent:
            return None
        data = np.array(recent)
        return float(np.median(data[:, 1])), float(np.median(data[:, 2])), float(data[-1, 3])

    def _wait_pose(self, since_s: float, what: str) -> tuple[float, float, float]:
        """The robot's pose at rest: a fresh pose (after ``since_s``), then the median over POSE_WINDOW_S more.

        A tracker that publishes but has sent no pose yet (a rig launched with the sweep: camera and tracker
        still starting) is given the discovery timeout; otherwise the pose timeout applies.
        """
        timeout = self.options.pose_timeout_s

        def fresh() -> bool:
            return self._median_pose(max(since_s, time.monotonic() - POSE_WINDOW_S)) is not None

        found = self.spin_until(fresh, timeout, self._abort_on_hardware_problem)
        if not found and not self._poses and self.node.count_publishers(POSE_TOPIC) > 0:
            timeout = self.options.discovery_timeout_s
            found = self.spin_until(fresh, timeout - self.options.pose_timeout_s, self._abort_on_hardware_problem)
        if not found:
            raise RunAborted(f"no pose on {self.node.resolve_topic_name(POSE_TOPIC)} for {timeout:g} s {what} "
                             "(is camera_tracker running and does it see both markers?)")
        found_s = time.monotonic()
        self.spin_for(POSE_WINDOW_S)
        return self._median_pose(max(since_s, found_s - POSE_WINDOW_S))

    # -- one run ----------------------------------------------------------------------------
    def prepare(self, cell: Cell) -> None:
        """Fit and latch the cell's trajectory and set the player (nothing moves yet).

        As the offline sweep plays them: the gait's own parameters at their defaults and the player's plain
        playback, whatever was set before (a navigator's turn, reverse, cycles or stop phase, an operator's
        ``amplitude_scale`` 0.5: each played a cell other than the one recorded).
        """
        gait, amplitude_bar, frequency_hz = cell
        defaults = {f"{gait}.{p.name}": p.default for p in list_gaits()[gait].parameters}
        self.set_parameters("trajectory_server", {"gait": gait, "amplitude_bar": float(amplitude_bar),
                                                  "frequency_hz": float(frequency_hz), **defaults})
        before = self._trajectories
        self.regenerate()
        if not self.spin_until(lambda: self._trajectories > before, self.options.service_timeout_s):
            raise RunAborted(f"the new trajectory did not arrive on {self.node.resolve_topic_name(TRAJECTORY_TOPIC)}")
        self.set_parameters("gait_player", {"frequency_hz": float(frequency_hz), **PLAIN_PLAYBACK})

    def regenerate(self) -> None:
        """Have trajectory_server fit the parameters set; while it is busy with another fit, wait and ask again.

        :class:`RunAborted` if it refuses for another reason, or is still busy after ``fit_timeout_s``.
        """
        deadline_s = time.monotonic() + self.options.fit_timeout_s
        while True:
            response = self.call("trajectory_server", "regenerate", timeout_s=self.options.fit_timeout_s)
            if response.success:
                return
            if not fit_busy(response.message) or time.monotonic() >= deadline_s:
                raise RunAborted(f"trajectory_server/regenerate: {response.message}")
            self.spin_for(BUSY_RETRY_S)

    def vent(self) -> bool:
        """Stop the player and disarm (a real rig vents at once); True once the valves are known to be vented.

        Vented: the hardware node commands 0 bar, or it is no longer active (it vents on deactivate, cleanup
        and a backend fault).
        """
        started = time.monotonic()
        self._venting = True
        try:
            for node, name in (("gait_player", "stop"), ("hardware_node", "disarm")):
                try:
                    self.call(node, name, timeout_s=min(self.options.service_timeout_s, 5.0))
                except RunAborted as exc:
                    self.log(f"srs_sweep: while venting: {exc}")
            return self.spin_until(lambda: self._vented_since(started) or self._hardware_inactive_since(started),
                                   self.options.vent_timeout_s)
        finally:
            self._venting = False

    def _not_vented(self, after: str) -> SweepStopped:
        return SweepStopped(f"the commanded pressures did not vent within {self.options.vent_timeout_s:g} s of "
                            f"{after}: check the rig (shut off the air if in doubt)")

    def _vented_since(self, since_s: float) -> bool:
        return self._commanded is not None and self._commanded[0] > since_s and self._commanded[1] <= VENTED_BAR

    def _hardware_inactive_since(self, since_s: float) -> bool:
        if self._hardware is None or self._hardware[0] <= since_s:
            return False
        state = diagnostic_values(self._hardware[1]).get("lifecycle_state", "")
        return state in ("unconfigured", "inactive", "finalized")

    def run(self, cell: Cell, duration_s: float, bag_path: Path, go: Callable[[Cell], bool] | None = None
            ) -> RunRecord:
        """One run of ``cell``, recorded into ``bag_path``; a failed record (with the reason) if it aborts.

        ``go(cell)`` is asked on a rig with real regulators before anything is armed; False skips the run (a
        record with the status ``skipped: ...``, not a failure).
        Raises :class:`SweepStopped` when the valves do not vent, ``KeyboardInterrupt`` after venting on Ctrl-C.
        """
        if self.rig is None:
            self.discover()
        track: list[tuple[float, float, float, float]] = []
        armed = False
        try:
            self._abort_on_hardware_problem()
            self.prepare(cell)
            if self.rig.simulated and self.options.reset_sim:
                reset_s = time.monotonic()
                self.trigger("sim_world", "reset")
                self._wait_pose(reset_s, "after sim_world reset")
            # Read again for every run: the node may have been configured (or reconfigured) on another rig since.
            self.rig = self._rig_now(self.rig.simulated)
            if self.rig.requires_arm and (go is None or not go(cell)):
                return RunRecord.skipped(cell, "no go from the operator")
            answer = self.trigger("hardware_node", "arm")  # also a simulated rig: the vent at discovery disarmed it
            armed = True
            if not self.rig.requires_arm and answer.startswith(REAL_ARM_PREFIX):  # switched since its last status
                raise RunAborted("hardware_node turned out to drive real regulators and no go was asked: disarmed; "
                                 "run the sweep again to be asked")
            self.recorder = BagRecorder(bag_path)
            if self._trajectory is not None:
                topic = self.node.resolve_topic_name(TRAJECTORY_TOPIC)
                self.recorder.write(topic, type_name(JointTrajectory), self.node.get_clock().now().nanoseconds,
                                    self._trajectory, offered_qos=lambda: self._offered_qos(topic))
            start_pose = self._wait_pose(0.0, "before the start")
            first = len(self._poses)
            started = time.monotonic()
            self.trigger("gait_player", "start")
            self.spin_until(lambda: time.monotonic() >= started + duration_s, duration_s + 1.0,
                            self._abort_on_hardware_problem)
            stopped = time.monotonic()
            self.call("gait_player", "stop")
            if not self.spin_until(lambda: self._vented_since(stopped), self.options.vent_timeout_s,
                                   self._abort_on_hardware_problem):
                raise self._not_vented("gait_player ~/stop")
            self.spin_for(self.options.settle_s)
            end_pose = self._wait_pose(stopped, "after the settle")
            track = [(t - started, x, y, yaw) for t, x, y, yaw in self._poses[first:]]
            if armed:  # unanswered, a failed record like any abort (it escaped before: no table at all)
                self.call("hardware_node", "disarm")
        except RunAborted as exc:
            self._vent_after_abort(armed)
            return RunRecord.failed(cell, str(exc), _array(track))
        except BaseException as exc:  # Ctrl-C, SweepStopped, anything unexpected: vent, then let it go on
            self.log("srs_sweep: Ctrl-C: venting" if isinstance(exc, KeyboardInterrupt) else
                     f"srs_sweep: venting after: {exc}")
            if not self.vent():
                self.log(f"srs_sweep: {self._not_vented('the stop')}")
            raise
        finally:
            if self.recorder is not None:
                self.recorder.close()
                self.recorder = None
        dx, dy = end_pose[0] - start_pose[0], end_pose[1] - start_pose[1]
        return RunRecord(cell[0], cell[1], cell[2], 100.0 * dx / duration_s, 100.0 * dy / duration_s, dx, dy,
                         track=_array(track))

    def _vent_after_abort(self, armed: bool) -> None:
        if not self.vent():
            raise self._not_vented("the abort")
        if armed:
            self.log("srs_sweep: vented and disarmed")


def _array(track: list) -> np.ndarray:
    return np.array(track, dtype=np.float64).reshape(-1, 4)
