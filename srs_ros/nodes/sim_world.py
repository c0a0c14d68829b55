"""sim_world: the simulated robot (MuJoCo, :mod:`srs_ros.sim`) stepped in real time and driven like the real one.

The ``sim`` backend of ``hardware_node`` sends the regulators' commands here the way the ``can`` backend
sends frames to a DAC board; this node answers with the regulators' read-back and shows the world as a
lab would see it: ground truth, an overhead camera and markers for RViz or Foxglove.

Interface (relative names, remappable)::

    subscribes  sim/regulator_command   sensor_msgs/JointState  reliable, depth 1: effort = pressure (bar)
    publishes   sim/regulator_monitor   sensor_msgs/JointState  every control period: effort = pressure (bar),
                                                                position = muscle length (m)
                sim/ground_truth_pose   geometry_msgs/PoseStamped  frame ``floor``: the tracked reference point
                                                                (midpoint of head and tail bands) and heading
                sim/body_markers        visualization_msgs/MarkerArray  the simulated backbone as a tube (id 0)
                                                                and the commanded shape (id 1), frame ``floor``
                image_raw               sensor_msgs/Image  the overhead camera, ``camera_rate_hz``, ``camera_encoding``
                /diagnostics            diagnostic_msgs/DiagnosticArray  real-time factor, divergence
    services    ~/reset                 std_srvs/Trigger  the robot back to its start pose (also after a divergence)

The world follows the steady clock: each control tick advances the physics to the wall time since the
start. A diverged simulation (non-finite state, exploding speed) stops the world: no pose, no image, no
read-back (so the hardware node faults and vents, as on a dead board), an ERROR on /diagnostics, until
``~/reset``. Parameters: :data:`PARAMETERS`.
"""

from __future__ import annotations

import threading
import time
from collections import deque

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.duration import Duration
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Image, JointState
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from srs_ros.core.actuation.pressure import clamp_pressures_bar, pressures_to_lengths_m
from srs_ros.core.errors import ConfigurationError, InvalidInputError, SrsError
from srs_ros.core.kinematics import backbone_points
from srs_ros.core.robot import load_robot
from srs_ros.core.vision.tracking import yaw_to_quaternion
from srs_ros.ros.interfaces import (
    BODY_MARKERS_TOPIC,
    CLOCK_TOPIC,
    DIAGNOSTICS_TOPIC,
    FLOOR_FRAME,
    GROUND_TRUTH_TOPIC,
    IMAGE_ENCODINGS_OUT,
    IMAGE_TOPIC,
    SIM_BOARD_TIMEOUT_S,
    SIM_COMMAND_TOPIC,
    SIM_MONITOR_TOPIC,
    STATUS_NODE_KEY,
    array_to_image_msg,
    bus_qos,
    diagnostic_array,
    diagnostic_status,
    line_strip_marker,
    seconds_to_stamp,
)
from srs_ros.ros.parameters import REALTIME_PRIORITY, ParameterSpec, declare_parameters
from srs_ros.ros.process import request_realtime_priority, run_node, steady_timer
from srs_ros.sim.camera import OverheadCamera
from srs_ros.sim.config import load_sim_config
from srs_ros.sim.realtime import RECEIVER_BEHIND_S, RealTimePacer, ReceiverWatch, SimulatedBoard
from srs_ros.sim.world import SimWorld

NODE_NAME = "sim_world"
LOG_THROTTLE_S = 1.0

#: The slowest camera or markers rate (per second) other than 0 (off).
MIN_OUTPUT_RATE_HZ = 0.1
#: /diagnostics says WARN when the world followed the wall clock at less than SLOW_WORLD_RATE over the last
#: SLOW_WINDOW_S: sustained, not one of a busy machine's 0.2-0.4 s stalls (0.92 over 5 s).
SLOW_WORLD_RATE = 0.8
SLOW_WINDOW_S = 5.0
PARAMETERS = (
    ParameterSpec("sim_config_file", "", "simulation YAML; '' = the package's config/sim.yaml", read_only=True),
    ParameterSpec("robot_description_file", "", "robot YAML; '' = the package's config/robot.yaml", read_only=True),
    ParameterSpec("camera_rate_hz", 30.0, "overhead camera frames per second on image_raw (0 = no camera)",
                  0.0, 120.0, read_only=True),
    ParameterSpec("camera_encoding", "bayer_rggb8", "image_raw's encoding: a colour sensor's raw Bayer mosaic (a "
                  "third of bgr8's bytes: a 640x480 frame fits Fast DDS's default shared memory, every frame arrives "
                  "on a busy machine) or bgr8 (0.9 MB, over UDP fragments that a busy reader loses)",
                  read_only=True, choices=IMAGE_ENCODINGS_OUT),
    ParameterSpec("pose_rate_hz", 50.0, "sim/ground_truth_pose messages per second", 1.0, 500.0, read_only=True),
    ParameterSpec("markers_rate_hz", 10.0, "sim/body_markers messages per second (0 = none)", 0.0, 100.0,
                  read_only=True),
    ParameterSpec("command_timeout_s", SIM_BOARD_TIMEOUT_S, "the simulated board vents every muscle by itself when "
                  "no command came for this long (s of world time), as a real DAC board must", 0.02, 10.0,
                  read_only=True),
    REALTIME_PRIORITY,
)


class SimWorldNode(Node):
    """ROS wiring of a :class:`~srs_ros.sim.world.SimWorld` and an :class:`~srs_ros.sim.camera.OverheadCamera`.

    The physics steps on a thread of its own (:meth:`_step_loop`), paced to the steady clock with bounded
    catch-up (:class:`~srs_ros.sim.realtime.RealTimePacer`); commands reach it through a simulated board
    (:class:`~srs_ros.sim.realtime.SimulatedBoard`) that vents on silence. The executor only receives
    commands and publishes snapshots (pose, camera, markers, diagnostics), so a slow render never holds
    up the physics or the read-back.
    """

    def __init__(self, **kwargs):
        """Build the world and the camera, then start stepping in real time on the steady clock."""
        super().__init__(NODE_NAME, **kwargs)
        self._specs = declare_parameters(self, PARAMETERS)
        p = {name: self.get_parameter(name).value for name in self._specs}
        for name in ("camera_rate_hz", "markers_rate_hz"):  # 0 = off; a tiny rate overflowed its timer's period
            if 0.0 < p[name] < MIN_OUTPUT_RATE_HZ:
                raise ConfigurationError(f"{name} {p[name]:g}: expected 0 (off) or at least {MIN_OUTPUT_RATE_HZ:g} "
                                         "per second")
        request_realtime_priority(p["realtime_priority"], self.get_logger())  # before the stepping thread starts
        self.robot = load_robot(p["robot_description_file"] or None)
        self.config = load_sim_config(p["sim_config_file"] or None, robot=self.robot)
        self.world = SimWorld(self.config, self.robot)
        self.camera = OverheadCamera(self.config) if p["camera_rate_hz"] > 0 else None
        self._camera_encoding = p["camera_encoding"]
        self.board = SimulatedBoard(self.robot.joint_count, p["command_timeout_s"])
        self.pacer = RealTimePacer()
        self.failure = ""  # why the world stopped (a divergence), until ~/reset
        self.commands = 0
        self._lock = threading.Lock()  # the world: stepped by the stepping thread, read by the executor's callbacks
        self._target_s = 0.0  # world time the pacer allows so far (s)
        self._clock_base_s = 0.0  # /clock = base + world time: it never goes back at a ~/reset
        self._step_wall_s = 0.0  # wall time spent stepping, for the real-time figure
        self._window = (time.monotonic(), 0.0, 0.0)  # (wall s, world s, stepping s) at the last diagnostics
        self._rate_marks: deque[tuple[float, float]] = deque()  # (wall s, world s) at recent diagnostics
        self._state = None  # the world's state at its current time, computed once for every output
        self._last_step = (time.monotonic(), 0.0)  # (wall s, world s) at the last wake-up: dates the commands
        self.receiver = ReceiverWatch()  # the executor: while it is behind, a command may wait unread
        # A command waits for the next control tick, dated when it arrived: exact while the supply line's delay
        # is longer than a control period (the muscles feel it only after the delay); else it wakes the loop.
        self._wake_on_command = self.config.muscles.transport_delay_s < self.config.physics.control_period_s
        self._create_interfaces(p)
        self._stop = threading.Event()
        self._wake = threading.Event()
        self._thread = threading.Thread(target=self._step_loop, name="sim_world_physics", daemon=True)
        self._thread.start()
        self.get_logger().info(
            f"simulated robot: {self.config.body.segments_per_module} segments per module, "
            f"{self.config.contact.describe()}, time step {self.world.time_step_s * 1e3:g} ms; "
            f"commands on {self.resolve_topic_name(SIM_COMMAND_TOPIC)} (vent after {p['command_timeout_s']:g} s "
            "without one), camera "
            + (f"{p['camera_rate_hz']:g} fps on {self.resolve_topic_name(IMAGE_TOPIC)}" if self.camera else "off")
            + ("; publishing /clock (use_sim_time)" if self._clock_pub else ""))

    def _create_interfaces(self, p: dict) -> None:
        self._monitor = JointState(name=list(self.robot.joint_names))
        self._monitor_pub = self.create_publisher(JointState, SIM_MONITOR_TOPIC, bus_qos())
        self._pose_pub = self.create_publisher(PoseStamped, GROUND_TRUTH_TOPIC, 10)
        self._markers_pub = self.create_publisher(MarkerArray, BODY_MARKERS_TOPIC, 1)
        self._image_pub = self.create_publisher(Image, IMAGE_TOPIC, 1)
        self._diag_pub = self.create_publisher(DiagnosticArray, DIAGNOSTICS_TOPIC, 10)
        # With use_sim_time the world is the clock, as Gazebo is: every node follows its time on /clock.
        use_sim_time = self.get_parameter("use_sim_time").value
        self._clock_pub = self.create_publisher(Clock, CLOCK_TOPIC, 10) if use_sim_time else None
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.create_subscription(JointState, SIM_COMMAND_TOPIC, self._on_command, bus_qos())
        self.create_service(Trigger, "~/reset", self._on_reset)
        steady_timer(self, 1.0 / p["pose_rate_hz"], self._publish_pose)
        if p["markers_rate_hz"] > 0:
            steady_timer(self, 1.0 / p["markers_rate_hz"], self._publish_markers)
        if self.camera is not None:
            steady_timer(self, 1.0 / p["camera_rate_hz"], self._publish_image)
        steady_timer(self, 1.0, self._publish_diagnostics)
        steady_timer(self, RECEIVER_BEHIND_S / 5.0, self._executor_runs)

    def _on_set_parameters(self, params) -> SetParametersResult:
        """Refuse a change of use_sim_time: it is read at start-up.

        Switched on live, sim_world's own clock waited for a /clock that nobody published and every stamp was 0 (a
        helper's review). Its other parameters are read-only.
        """
        for param in params:
            if param.name == "use_sim_time" and param.value != self.get_parameter("use_sim_time").value:
                return SetParametersResult(successful=False, reason=(
                    "use_sim_time is read at start-up (sim_world publishes /clock only if it started with it); "
                    "restart sim_world with -p use_sim_time:=true, and its nodes with it"))
        return SetParametersResult(successful=True)

    # -- the physics thread ------------------------------------------------------------------
    def _step_loop(self) -> None:
        """Step at every control period (and at each command if the line's delay is shorter), until destroyed."""
        period_s = self.config.physics.control_period_s
        next_tick_s = time.monotonic()
        while not self._stop.is_set():
            self._wake.wait(timeout=max(0.0, next_tick_s - time.monotonic()))
            self._wake.clear()
            now_s = time.monotonic()
            tick = now_s >= next_tick_s
            if tick:
                next_tick_s = max(next_tick_s + period_s, now_s - period_s)  # late: no burst of ticks
            try:
                self._step(now_s, tick)
            except Exception as exc:  # the context went down under us (process exit): stop stepping
                if self._stop.is_set() or not self.context.ok():
                    return
                # Else the world stops (no pose, no read-back: the hardware node faults and vents) and the thread
                # waits for ~/reset: it ended here, and a reset answered "back" to a world nobody stepped any more
                # (a helper's review).
                with self._lock:
                    self._stop_world(f"the physics step failed: {type(exc).__name__}: {exc}")

    def _step(self, now_s: float, tick: bool) -> None:
        """Advance the world as the pacer allows, apply the board's command; at a tick publish read-back and clock."""
        with self._lock:
            if self.failure:
                return
            started = time.monotonic()
            try:
                self._target_s += self.pacer.step_s(now_s)
                self.world.advance_to(self._target_s)
                self._last_step = (now_s, self.world.time_s)  # commands arriving from now on are dated from here
                self._check_receiver(now_s)
                commands = self.board.take(self.world.time_s)
                for when_s, command in commands:
                    self.world.command_pressures(command, when_s)
                if commands and self.board.vented_by_silence:
                    self.get_logger().warning(
                        f"no regulator command for {self.board.command_timeout_s:g} s: the simulated board "
                        "vented every muscle by itself (the hardware node stopped or died)")
            except SrsError as exc:
                self._stop_world(str(exc))
                return
            finally:
                self._step_wall_s += time.monotonic() - started
            if not tick:
                return
            pressure_bar, length_m = self.world.muscles.state(self.world.time_s)  # the read-back only: cheap
            clock_s = self._clock_base_s + self.world.time_s
        if self._clock_pub is not None:
            self._clock_pub.publish(Clock(clock=seconds_to_stamp(clock_s)))
        msg = self._monitor  # on use_sim_time stamped with the world time it shows, not the /clock last taken in
        msg.header.stamp = seconds_to_stamp(clock_s) if self._clock_pub is not None else self.get_clock().now().to_msg()
        msg.effort = pressure_bar.tolist()
        msg.position = length_m.tolist()
        self._monitor_pub.publish(msg)

    def _check_receiver(self, now_s: float) -> None:
        """While the executor is behind (starved, not stuck), commands may wait unread: the board counts no silence."""
        if self.receiver.behind(now_s):
            self.board.receiver_behind(self.world.time_s)

    def _executor_runs(self) -> None:
        self.receiver.ran(time.monotonic())

    def _stop_world(self, reason: str) -> None:
        self.failure = reason
        self.get_logger().error(f"the simulation stopped (no pose, no images, no read-back: the hardware node will "
                                f"fault and vent): {reason}; call ~/reset to retry, or restart sim_world for a changed "
                                "sim config (sim_config_file is read at start-up)")

    def destroy_node(self) -> None:
        """Stop the physics thread, then destroy the node."""
        self._stop.set()
        self._wake.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(timeout=5.0)
        super().destroy_node()

    # -- inputs ------------------------------------------------------------------------------
    # The outputs read the world under the lock and get None once it has stopped: the physics thread sets
    # ``failure`` under the same lock, so a world that diverged between an output's own check and its read is
    # seen here, not met as an exception that ended the process (a helper's review: 1-3 runs in 5).
    def _stepped(self, read):
        """``read()`` of the world and the stamp of the instant the world was so (None: the world stopped).

        A camera stamps its exposure, so the pose and the image are stamped at the physics step that made the state
        they show, not when the executor gets round to them: after a stall of the executor thread (0.2-0.4 s on a busy
        machine) ``now`` dated a state up to that much late, and the tracked pose against the ground truth, each
        stamped by a different timer, moved apart by the robot's speed times the difference (a median of 6.3 mm
        against under 5 in a full suite run). On use_sim_time the stamp is the world's own time of the state: ``now``
        there is the last /clock the executor took in, up to a few control periods behind, and 0 before the first
        (a helper's review).
        """
        with self._lock:
            if self.failure:
                return None
            value, stepped_s, world_clock_s = read(), self._last_step[0], self._clock_base_s + self.world.time_s
        if self._clock_pub is not None:
            return value, seconds_to_stamp(world_clock_s)
        now = self.get_clock().now() - Duration(nanoseconds=int(max(0.0, time.monotonic() - stepped_s) * 1e9))
        return value, now.to_msg()

    def state(self):
        """The world's state now (None: the world stopped), computed once per world time step for the outputs."""
        with self._lock:
            if self.failure:
                return None
            if self._state is None or self._state.time_s != self.world.time_s:
                self._state = self.world.state(with_contacts=False)
            return self._state

    def _on_command(self, msg: JointState) -> None:
        if self.failure:
            return
        try:
            if list(msg.name) != list(self.robot.joint_names):
                raise InvalidInputError(f"names {list(msg.name)}; expected {list(self.robot.joint_names)} in order.")
            wall_s, world_s = self._last_step  # dated in world time from the last wake-up: applied at the next
            self.board.receive(clamp_pressures_bar(msg.effort, self.robot), world_s + time.monotonic() - wall_s)
            self.commands += 1
            if self._wake_on_command:
                self._wake.set()
        except SrsError as exc:  # the regulators ignore a frame they cannot read; the last command stays
            self.get_logger().error(f"ignored a regulator command: {exc}", throttle_duration_sec=LOG_THROTTLE_S)

    def _on_reset(self, _request, response):
        with self._lock:
            self._clock_base_s += self.world.time_s
            self.world.reset()
            self.board.reset()
            self.pacer.restart()
            self._target_s = 0.0
            self._last_step = (time.monotonic(), 0.0)
            self._state = None
            self._window = (time.monotonic(), 0.0, self._step_wall_s)  # the rate from the reset on, never negative
            self._rate_marks.clear()
            was, self.failure = self.failure, ""
        response.success = True
        response.message = "the simulated robot is back at its start pose, vented" + (
            f" (it had stopped: {was})" if was else "")
        self.get_logger().info(response.message)
        return response

    # -- outputs -----------------------------------------------------------------------------
    def _publish_pose(self) -> None:
        stepped = self._stepped(self.world.tracked_pose)
        if stepped is None:
            return
        (reference_xy_m, heading_rad), stamp = stepped
        msg = PoseStamped()
        msg.header.stamp = stamp
        msg.header.frame_id = FLOOR_FRAME
        msg.pose.position.x, msg.pose.position.y = (float(v) for v in reference_xy_m)
        qx, qy, qz, qw = (float(v) for v in yaw_to_quaternion(heading_rad))
        msg.pose.orientation.x, msg.pose.orientation.y = qx, qy
        msg.pose.orientation.z, msg.pose.orientation.w = qz, qw
        self._pose_pub.publish(msg)

    def _publish_image(self) -> None:
        # Stamped at the instant of the state shown, as a camera stamps its exposure: not after the render, which
        # a busy machine can stall for 0.2-0.4 s (a rolling robot's pose would be dated centimetres late).
        stepped = self._stepped(self.world.node_positions_m)
        if stepped is None:
            return
        nodes_m, stamp = stepped
        image = self.camera.render(nodes_m)  # outside the lock: the physics goes on meanwhile
        self._image_pub.publish(array_to_image_msg(image, stamp, "camera", self._camera_encoding))

    def _publish_markers(self) -> None:
        state = self.state()
        if state is None:
            return
        stamp = self.get_clock().now().to_msg()
        commanded_m = pressures_to_lengths_m(state.commanded_pressure_bar, self.robot)
        commanded_shape = backbone_points(commanded_m, robot=self.robot, base=state.base_pose)
        diameter_m = 2.0 * self.config.body.skin_radius_m
        self._markers_pub.publish(MarkerArray(markers=[
            line_strip_marker(0, "simulated", state.backbone_m, diameter_m, (0.25, 0.25, 0.28, 1.0), stamp),
            line_strip_marker(1, "commanded", commanded_shape, 0.004, (0.1, 0.8, 0.2, 0.9), stamp),
        ]))

    def _publish_diagnostics(self) -> None:
        now_s, world_s, stepping_s = time.monotonic(), self.world.time_s, self._step_wall_s
        then_s, then_world_s, then_stepping_s = self._window
        self._window = (now_s, world_s, stepping_s)
        span_s = max(now_s - then_s, 1e-9)
        values = {"world_time_s": f"{world_s:.3f}", "slipped_s": f"{self.pacer.slipped_s:.3f}",
                  "slips": str(self.pacer.slips), "stepping_share": f"{(stepping_s - then_stepping_s) / span_s:.3f}",
                  "world_rate": f"{(world_s - then_world_s) / span_s:.3f}", "commands": str(self.commands),
                  "silence_vents": str(self.board.silence_vents), "receiver_stalls": str(self.receiver.stalls),
                  "failure": self.failure or "none"}
        clock_rivals = self.count_publishers(self._clock_pub.topic_name) - 1 if self._clock_pub is not None else 0
        if clock_rivals > 0:
            self.get_logger().error(f"{self._clock_pub.topic_name} has {clock_rivals} other publisher(s): one "
                                    "simulation with use_sim_time per ROS_DOMAIN_ID", throttle_duration_sec=10.0)
        level, message = self._summary(self._slow_rate(now_s, world_s), clock_rivals)
        # Named as the node runs and keyed by its full name: two robots in two namespaces are told apart.
        status = diagnostic_status(f"{self.get_name()}: simulated robot", "mujoco", level, message,
                                   {**values, STATUS_NODE_KEY: self.get_fully_qualified_name()})
        self._diag_pub.publish(diagnostic_array([status], self.get_clock().now().to_msg()))

    def _slow_rate(self, now_s: float, world_s: float) -> float | None:
        """The world's rate over the last SLOW_WINDOW_S (world s per wall s) if below SLOW_WORLD_RATE, else None."""
        marks = self._rate_marks
        marks.append((now_s, world_s))
        while len(marks) > 1 and now_s - marks[1][0] >= SLOW_WINDOW_S:
            marks.popleft()
        span_s = now_s - marks[0][0]
        rate = (world_s - marks[0][1]) / span_s if span_s >= SLOW_WINDOW_S else None
        return rate if rate is not None and rate < SLOW_WORLD_RATE else None

    def _summary(self, slow_rate: float | None = None, clock_rivals: int = 0) -> tuple[str, str]:
        if self.failure:
            return "ERROR", f"stopped: {self.failure}; call ~/reset"
        if clock_rivals > 0:  # /clock is one topic for the whole domain, namespaces or not
            topic = self._clock_pub.topic_name if self._clock_pub is not None else CLOCK_TOPIC
            return "ERROR", (f"{clock_rivals} other publisher(s) of {topic}: every node on use_sim_time sees "
                             "its time jump back and forth; run one simulation with use_sim_time per ROS_DOMAIN_ID "
                             "(the others without it, or in a domain of their own)")
        if self.board.vented_by_silence:
            return "WARN", (f"vented by the board's own watchdog: no regulator command for "
                            f"{self.board.command_timeout_s:g} s (is the hardware node running?)")
        if slow_rate is not None and self._clock_pub is not None:  # every node follows /clock: slower, not wrong
            return "OK", f"stepping at {slow_rate:.2f}x real time (use_sim_time: every node follows /clock)"
        if slow_rate is not None:
            return "WARN", (f"behind real time: {slow_rate:.2f}x over the last {SLOW_WINDOW_S:g} s (the machine is "
                            "too busy for this model: the robot moves slower than its gait asks and its clock "
                            "slips, see slipped_s; free a core, or start every node with use_sim_time to follow "
                            "the world's clock)")
        return "OK", "stepping in real time"


def main(args: list[str] | None = None) -> int:
    """Console script ``sim_world``."""
    # EventsExecutor: measured 29 % of a core for the whole node against 39 % with the SingleThreadedExecutor.
    return run_node(SimWorldNode, args, executor_factory=EventsExecutor)


if __name__ == "__main__":
    raise SystemExit(main())
