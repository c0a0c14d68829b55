"""The hardware node (managed/lifecycle): setpoints in, the one clamp, regulator commands out at a fixed rate.

Lifecycle: configure loads the robot and rig and opens the backend (a failure logs the reason and
leaves the node unconfigured, nothing sent) and starts the command timer, which sends 0 bar until
activated; activate enables output; deactivate, cleanup and shutdown vent every valve to 0 bar.
A backend failure while commanding (any exception, e.g. ``HardwareError``) vents (best effort) and
takes the node through ErrorProcessing to unconfigured; configure + activate recover it.

Safety (see docs/safety.md):

- every timer runs on the steady clock, so the watchdog and the keep-alive keep running whatever
  ROS time does (``use_sim_time`` without ``/clock``, a system clock step);
- a rig whose backend drives real regulators (``can``, ``daq``) commands nothing above 0 bar until an
  operator calls ``~/arm`` (``srs_bringup --arm`` does it for you); deactivate, an e-stop or a fault
  disarm; the simulated backends need no arm, but ``~/disarm`` holds 0 bar on every rig until ``~/arm``;
- whenever output (re)starts (activation, arm, e-stop reset, after a vent for stale setpoints) it
  ramps up from 0 bar over ``ramp_time_s``;
- the backend is written at the command rate only (the newest setpoint wins); a setpoint counts from
  its stamp (unstamped: from its arrival), so the valves vent at most ``setpoint_timeout_s`` plus one
  command period after the last fresh setpoint was made.

Interfaces (relative names, remappable):

- subscribes ``joint_setpoints`` (sensor_msgs/JointState, best effort, depth 1): ``name`` = every actuator
  (``m1_pma1`` ... ``m3_pma3``) once, in any order; ``position`` = actuator length change (m).
  Rejected, never sent, throttled error log and counted: wrong count, names/positions mismatch,
  unknown or duplicate names, NaN/inf, a stamp older than the timeout (stale on arrival). A stamp
  from the future (a sender whose clock runs ahead) is aged from its arrival and reported on
  /diagnostics as a clock offset. Finite lengths outside ``[0, max_extension_m]`` or above what the
  pressure limit allows under the selected map (0.04 m at 4 bar with ``P = 100 l``, about 0.065 m with
  a calibrated map) are limited by the one clamp, with a throttled warning and a counter. ``velocity``
  (m/s, optional; gait_player sends it) feeds the lag compensation. A setpoint already queued when the
  node is released (a fault, cleanup) is dropped quietly and counted (``setpoints_while_unconfigured``).
- lengths become pressures through ``pressure_map``: ``paper`` (``P = 100 l``) or ``calibrated`` (each
  muscle's inverted static characteristic from ``calibration_file``, written by ``srs_identify``); with
  ``lag_compensation`` (live) commands lead the supply line's delay and invert its lag
  (:mod:`srs_ros.core.actuation.compensation`), always through the one clamp.
- publishes ``commanded_pressure_bar`` and ``command_voltage_v`` (std_msgs/Float64MultiArray, dim 0
  labelled with the comma-joined joint names): what the backend was sent, on each command while
  configured (zeros when inactive, disarmed, stale or e-stopped); ``actuator_state`` (sensor_msgs/JointState)
  at ``state_publish_rate_hz``: ``position`` = measured length (m), ``effort`` = measured pressure (bar),
  empty where the backend cannot measure; ``/diagnostics`` (diagnostic_msgs/DiagnosticArray, 1 Hz, in
  every state), with counters of setpoints received, rejected, limited and written, the pressure map and
  ``compensation_clamped`` (setpoints whose lead the clamp cut).
- services ``~/emergency_stop`` (std_srvs/Trigger: vents at once and latches, in any state; the latch
  survives deactivate/cleanup/configure), ``~/reset`` (releases the latch; output resumes with the
  next fresh setpoint, after a new ``~/arm`` on a real rig), ``~/arm`` and ``~/disarm``; the lifecycle
  services.
- parameters: :data:`PARAMETERS`; ``lag_compensation`` takes effect at once; ``max_pressure_bar`` and
  ``realtime_priority`` are read-only (start-up only), ``max_pressure_bar`` can only lower the robot's limit;
  the others take effect at the next configure.
"""

from __future__ import annotations

import collections
import dataclasses
import logging
import math
import time

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.experimental import EventsExecutor
from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger

from srs_ros.backends import BACKENDS, ActuatorBackend, create_backend
from srs_ros.core.actuation.compensation import SetpointShaper, setpoint_shaper
from srs_ros.core.actuation.muscle_calibration import CALIBRATED_MAP, PAPER_MAP
from srs_ros.core.actuation.pressure import pressures_to_command_v
from srs_ros.core.actuation.safety import (
    VENT_FAILED,
    CommandGate,
    OutputReason,
    StampCheck,
    min_setpoint_rate_hz,
    setpoint_age_s,
    setpoint_lengths_m,
    setpoint_velocities_m_per_s,
)
from srs_ros.core.errors import ConfigurationError, InvalidInputError
from srs_ros.core.ramp import DEFAULT_RAMP_TIME_S
from srs_ros.core.rig import RigConfig, load_rig
from srs_ros.core.robot import ABSOLUTE_MAX_PRESSURE_BAR, load_robot
from srs_ros.ros.interfaces import (
    ACTUATOR_STATE_TOPIC,
    COMMAND_VOLTAGE_TOPIC,
    COMMANDED_PRESSURE_TOPIC,
    DIAGNOSTICS_TOPIC,
    SETPOINT_TOPIC,
    labelled_array,
    setpoint_qos,
)
from srs_ros.ros.parameters import REALTIME_PRIORITY, ParameterSpec, check_parameters, declare_parameters
from srs_ros.ros.process import request_realtime_priority, run_node, steady_timer

NODE_NAME = "hardware_node"
DIAGNOSTICS_PERIOD_S = 1.0
LOG_THROTTLE_S = 1.0
#: How often a faulted rig that recovers by itself (sim) is configured again (s).
RECOVERY_PERIOD_S = 1.0

PARAMETERS = (
    ParameterSpec("rig_file", "", "rig YAML (config/rigs/*.yaml); '' = the mock rig"),
    ParameterSpec("backend", "", "backend overriding the rig's ('mock', 'can', 'daq'); '' = the rig's"),
    ParameterSpec("robot_description_file", "", "robot YAML; '' = the package's config/robot.yaml"),
    ParameterSpec("setpoint_timeout_s", 0.0, "setpoints older than this vent to 0 bar (s); 0 = the rig's value",
                  0.0, 5.0),
    ParameterSpec("command_rate_hz", 0.0, "commands sent to the backend per second; 0 = the rig's value",
                  0.0, 1000.0),
    ParameterSpec("state_publish_rate_hz", 50.0, "actuator_state messages per second (at most the command rate)",
                  1.0, 1000.0),
    ParameterSpec("ramp_time_s", DEFAULT_RAMP_TIME_S,
                  "output ramps up from 0 bar over this time whenever it (re)starts (s)", 0.0, 60.0),
    ParameterSpec("max_pressure_bar", ABSOLUTE_MAX_PRESSURE_BAR,
                  "pressure limit (bar); only lowers the robot's; read-only: set it at start-up",
                  0.1, ABSOLUTE_MAX_PRESSURE_BAR, read_only=True),
    ParameterSpec("autostart", False, "configure and activate at start-up (a real rig still waits for ~/arm)"),
    ParameterSpec("pressure_map", PAPER_MAP, f"how lengths become pressures: '{PAPER_MAP}' (P = 100 l) or "
                  f"'{CALIBRATED_MAP}' (each muscle's characteristic from calibration_file)",
                  additional_constraints=f"'{PAPER_MAP}' or '{CALIBRATED_MAP}'"),
    ParameterSpec("calibration_file", "", "the rig's muscle calibration (srs_identify); '' = none"),
    ParameterSpec("lag_compensation", False, "lead the supply line's delay and invert its lag (live; needs the "
                  "calibration's dynamics or the two compensation_* parameters)"),
    ParameterSpec("compensation_delay_s", 0.0, "supply-line delay led by the compensation (s); 0 = the "
                  "calibration file's", 0.0, 2.0),
    ParameterSpec("compensation_time_constant_s", 0.0, "pressure time constant the compensation inverts (s); 0 = "
                  "the calibration file's", 0.0, 10.0),
    REALTIME_PRIORITY,
)


@dataclasses.dataclass
class HardwareStatus:
    """Counters and messages for /diagnostics."""

    ticks: int = 0
    setpoints_received: int = 0
    setpoints_accepted: int = 0
    rejected_setpoints: int = 0
    ignored_velocities: int = 0  # setpoints whose velocities were unusable (NaN, wrong size): lengths used alone
    setpoints_while_unconfigured: int = 0  # queued before a release (fault, cleanup), dropped after it
    stale_on_arrival: int = 0
    future_stamped: int = 0
    limited_setpoints: int = 0  # accepted, but some length needed more than the pressure limit
    stale_vents: int = 0  # times the output went from commanding to 0 bar because setpoints went stale
    arrival_age_max_s: float = 0.0  # oldest stamp age at arrival since the last diagnostics message
    clock_offset_s: float = 0.0  # the latest stamp-vs-clock difference that was out of bounds
    last_error: str = ""
    fault: str = ""  # set by a backend failure, cleared by the next successful configure
    holding: str = ""  # why the backend holds output at 0 bar right now (a paused simulator), '' if it does not
    holds: int = 0  # times output went to 0 bar because the backend held (a paused simulator)
    recoveries: int = 0  # times a rig that recovers by itself (sim) was configured and activated again after a fault
    reason: OutputReason = OutputReason.INACTIVE
    # (time s, ticks, setpoints received, stamp problems) at the previous diagnostics
    rate_window: tuple[float, int, int, int] = (math.nan, 0, 0, 0)
    last_publish_s: float = -math.inf  # monotonic time of the last commanded_pressure_bar message
    pending_stamp_ns: int = 0  # stamp of an accepted setpoint not yet written (for the latency figure)
    latency_ms: collections.deque = dataclasses.field(default_factory=lambda: collections.deque(maxlen=2000))


class _NodeLogHandler(logging.Handler):
    """Forwards the backends' Python log records (e.g. a missing NI watchdog) to the node's logger and /rosout."""

    def __init__(self, node_logger):
        super().__init__()
        self._node_logger = node_logger

    def emit(self, record: logging.LogRecord) -> None:
        text = self.format(record)
        if record.levelno >= logging.ERROR:  # rclpy fixes a call site's severity, hence one call per level
            self._node_logger.error(text)
        elif record.levelno >= logging.WARNING:
            self._node_logger.warning(text)
        else:
            self._node_logger.info(text)


class HardwareNode(LifecycleNode):
    """Lifecycle wiring around a backend and a :class:`~srs_ros.core.actuation.safety.CommandGate`."""

    def __init__(self, **kwargs):
        """Declare parameters, diagnostics and the e-stop/arm services; configure+activate if ``autostart``."""
        super().__init__(NODE_NAME, **kwargs)
        self.specs = declare_parameters(self, PARAMETERS)
        request_realtime_priority(self.get_parameter("realtime_priority").value, self.get_logger())
        self.add_on_set_parameters_callback(lambda params: check_parameters(self.specs, params, self._check_value))
        self.add_post_set_parameters_callback(self._apply_parameters)
        self.rig: RigConfig | None = None
        self.backend: ActuatorBackend | None = None
        self.shaper: SetpointShaper | None = None  # lengths -> pressures (map, compensation), from configure
        self.gate = CommandGate(joint_count=0, setpoint_timeout_s=0.0)
        self.status = HardwareStatus()
        self._runtime: dict = {}
        self._recover = (False, False)  # (the faulted backend recovers by itself, it was active) at the last fault
        self._recovery_timer = None
        self._state_every_ticks = 1
        self._limited_names: list[str] = []
        backend_log = logging.getLogger("srs_ros.backends")
        backend_log.addHandler(_NodeLogHandler(self.get_logger()))
        backend_log.setLevel(logging.INFO)
        backend_log.propagate = False
        self.diagnostics_publisher = self.create_publisher(DiagnosticArray, DIAGNOSTICS_TOPIC, 10)
        self.create_service(Trigger, "~/emergency_stop", self._on_emergency_stop)
        self.create_service(Trigger, "~/reset", self._on_reset)
        self.create_service(Trigger, "~/arm", self._on_arm)
        self.create_service(Trigger, "~/disarm", self._on_disarm)
        steady_timer(self, DIAGNOSTICS_PERIOD_S, self._publish_diagnostics)
        if not self.get_parameter("autostart").value:
            self.get_logger().info(f"unconfigured, nothing sent: waiting for `ros2 lifecycle set "
                                   f"{self.get_fully_qualified_name()} configure` (then activate), or start with "
                                   "autostart:=true")
        elif self.trigger_configure() == TransitionCallbackReturn.SUCCESS:
            self.trigger_activate()

    # -- the state machine -------------------------------------------------------------------
    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Load robot and rig, open the backend (vented) and start commanding 0 bar."""
        try:
            self.rig, self.backend = self._open_backend()
        except Exception as exc:  # any failure must leave the node unconfigured
            self._report_error(f"configure failed, node stays unconfigured, nothing sent: {_describe(exc)}")
            return TransitionCallbackReturn.FAILURE
        self.status.fault = ""
        self._create_runtime()
        arm = ("real regulators: nothing above 0 bar until an operator calls ~/arm" if self.gate.requires_arm
               else "simulated: no arm needed" if self.gate.has_go else "simulated, disarmed: 0 bar until ~/arm")
        self.get_logger().info(f"configured: rig {self.rig.name!r}, backend {self.backend.name!r} ({arm}), "
                               f"{self._command_rate_hz():g} Hz, setpoint timeout {self.gate.setpoint_timeout_s:g} s, "
                               f"limit {self.rig.robot.max_pressure_bar:g} bar, {self.shaper.map.describe()}, "
                               f"lag compensation {'on' if self.shaper.compensation else 'off'}")
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Enable output: fresh setpoints from now on reach the backend (after ~/arm on a real rig)."""
        self.gate.set_active(True)
        self.get_logger().info("active: " + ("waiting for ~/arm before commanding" if not self.gate.has_go
                                             else "commanding fresh setpoints"))
        return TransitionCallbackReturn.SUCCESS

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Disable output, disarm and vent every valve to 0 bar (ERROR after a backend fault)."""
        self.gate.set_active(False)
        if self.status.fault:
            return TransitionCallbackReturn.ERROR
        failure = self._vent()
        if failure is not None:
            self.status.fault = _describe(failure)
            return TransitionCallbackReturn.ERROR
        self.get_logger().info("inactive: vented, sending 0 bar")
        return TransitionCallbackReturn.SUCCESS

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Vent, close the backend and drop the runtime interfaces (ERROR after a backend fault)."""
        if self.status.fault:
            return TransitionCallbackReturn.ERROR
        self._release()
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Vent and close whatever is open."""
        self._release()
        return TransitionCallbackReturn.SUCCESS

    def on_error(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Vent (best effort), close and fall back to unconfigured; configure + activate recover.

        A rig that recovers by itself (the simulated robot) is configured, and activated if it was active,
        again by :meth:`_try_recovery` every :data:`RECOVERY_PERIOD_S`; a real rig waits for the operator.
        """
        self._release()
        fault = self.status.fault or self.status.last_error
        if self._recover[0]:
            self._recovery_timer = self._recovery_timer or steady_timer(self, RECOVERY_PERIOD_S, self._try_recovery)
            self.get_logger().error(f"error processing done: backend closed, node unconfigured (fault: {fault}); "
                                    f"the simulated rig recovers by itself: configure"
                                    f"{' + activate' if self._recover[1] else ''} in {RECOVERY_PERIOD_S:g} s")
        else:
            self.get_logger().error(f"error processing done: backend closed, node unconfigured; configure and "
                                    f"activate to recover (fault: {fault})")
        return TransitionCallbackReturn.SUCCESS

    def _try_recovery(self) -> None:
        """Configure (and activate, if it was active) a rig that recovers by itself; stop once done or overtaken."""
        if self.lifecycle_label() == "unconfigured" and self.trigger_configure() != TransitionCallbackReturn.SUCCESS:
            return  # configure said why; try again next period
        if self._recover[1] and self.lifecycle_label() == "inactive":
            self.trigger_activate()
        self.destroy_timer(self._recovery_timer)
        self._recovery_timer = None
        self._recover = (False, False)
        self.status.recoveries += 1
        self.get_logger().warning(f"recovered by itself after a fault: {self.lifecycle_label()}, holding 0 bar until "
                                  "the simulated robot answers, then ramping up")

    # -- configure helpers --------------------------------------------------------------------
    def _open_backend(self) -> tuple[RigConfig, ActuatorBackend]:
        robot = load_robot(self.get_parameter("robot_description_file").value or None)
        limit_bar = min(robot.max_pressure_bar, self.get_parameter("max_pressure_bar").value)
        rig = load_rig(self.get_parameter("rig_file").value or None,
                       dataclasses.replace(robot, max_pressure_bar=limit_bar))
        timeout_s = self.get_parameter("setpoint_timeout_s").value or rig.setpoint_timeout_s
        rate_hz = self.get_parameter("command_rate_hz").value or rig.command_rate_hz
        if rate_hz < min_setpoint_rate_hz(timeout_s):
            # Staleness is acted on at command ticks: a slow tick would hold a stale pressure too long.
            raise ConfigurationError(f"command_rate_hz is {rate_hz:g} Hz with setpoint_timeout_s {timeout_s:g} s; "
                                     f"expected at least {min_setpoint_rate_hz(timeout_s):g} Hz (two commands per "
                                     "timeout).")
        param = self.get_parameter
        self.shaper = setpoint_shaper(rig.robot, param("pressure_map").value, param("calibration_file").value,
                                      param("compensation_delay_s").value, param("compensation_time_constant_s").value,
                                      param("lag_compensation").value)
        backend = create_backend(self.get_parameter("backend").value or rig.backend, rig.robot, rig.backend_options)
        backend.open()
        self._check_host_loss(backend, rate_hz)
        self.gate.joint_count = rig.robot.joint_count
        self.gate.setpoint_timeout_s = timeout_s
        self.gate.ramp_time_s = self.get_parameter("ramp_time_s").value
        self.gate.requires_arm = backend.drives_real_hardware
        # after a stall longer than this, the hardware may have vented: output restarts with a ramp
        self.gate.max_gap_s = min(timeout_s, backend.host_loss_timeout_s or math.inf)
        self.gate.restart_stall_watch()
        return rig, backend

    def _check_host_loss(self, backend: ActuatorBackend, rate_hz: float) -> None:
        """The hardware's own vent-on-silence must outlast a few command periods, and a missing one is said."""
        timeout_s = backend.host_loss_timeout_s
        if timeout_s is not None and timeout_s < 3.0 / rate_hz:
            backend.close()
            raise ConfigurationError(f"the {backend.name} hardware vents after {timeout_s:g} s without a command, less "
                                     f"than three command periods at command_rate_hz {rate_hz:g} Hz: it would vent "
                                     f"between commands; raise command_rate_hz to at least {3.0 / timeout_s:g} Hz.")
        if timeout_s is None and backend.drives_real_hardware:
            self.get_logger().warning(f"the {backend.name} hardware keeps its last command if this host dies (no "
                                      "watchdog): fit a dump valve or relay on the supply (docs/safety.md)")

    def _command_rate_hz(self) -> float:
        return self.get_parameter("command_rate_hz").value or self.rig.command_rate_hz

    def _create_runtime(self) -> None:
        rate_hz = self._command_rate_hz()
        state_rate_hz = min(self.get_parameter("state_publish_rate_hz").value, rate_hz)
        self._state_every_ticks = max(1, round(rate_hz / state_rate_hz))
        status = self.status
        status.rate_window = (time.monotonic(), status.ticks, status.setpoints_received,
                              status.stale_on_arrival + status.future_stamped)
        self._runtime = {
            "pressure": self.create_publisher(Float64MultiArray, COMMANDED_PRESSURE_TOPIC, 10),
            "voltage": self.create_publisher(Float64MultiArray, COMMAND_VOLTAGE_TOPIC, 10),
            "state": self.create_publisher(JointState, ACTUATOR_STATE_TOPIC, 10),
            "setpoints": self.create_subscription(JointState, SETPOINT_TOPIC, self._on_setpoint, setpoint_qos()),
            "timer": steady_timer(self, 1.0 / rate_hz, self._on_command_tick),
        }

    def _release(self) -> None:
        """Vent and close the backend (best effort) and destroy the runtime interfaces; safe to repeat."""
        self.gate.set_active(False)
        self.status.reason = OutputReason.INACTIVE
        self.status.holding = ""
        self.release_hardware()
        self.shaper = None  # the next configure reads the map and the compensation again
        for entity in self._runtime.values():
            self._destroy(entity)
        self._runtime = {}

    def release_hardware(self) -> bool:
        """Vent and close the backend, logging instead of raising (also used at process exit).

        Returns False if the vent failed (then the regulators may still hold pressure).
        """
        backend, self.backend = self.backend, None
        if backend is None:
            return True
        try:
            backend.close()  # vents first
        except Exception as exc:  # closing must go on; the failure is reported
            self._report_error(f"{VENT_FAILED} (closing the {backend.name} backend: {_describe(exc)})")
            return False
        return True

    def _destroy(self, entity) -> None:
        destroy = {"Publisher": self.destroy_publisher, "Subscription": self.destroy_subscription,
                   "Timer": self.destroy_timer}[type(entity).__name__]
        destroy(entity)

    # -- runtime -----------------------------------------------------------------------------
    def _on_setpoint(self, msg: JointState) -> None:
        self.status.setpoints_received += 1
        if self.shaper is None or not self._runtime:  # queued before a release (a fault, cleanup): nothing to drive
            self.status.setpoints_while_unconfigured += 1
            return
        try:
            self._take_setpoint(msg)
        except Exception as exc:  # a callback must never kill the node; the setpoint is not used
            self.status.rejected_setpoints += 1
            self.get_logger().error(f"rejected setpoint, not sent (unexpected error, please report): "
                                    f"{_describe(exc)}", throttle_duration_sec=LOG_THROTTLE_S)

    def _take_setpoint(self, msg: JointState) -> None:
        robot = self.rig.robot
        try:
            lengths_m = setpoint_lengths_m(msg.name, msg.position, robot)
        except InvalidInputError as exc:
            self.status.rejected_setpoints += 1
            self.get_logger().error(f"rejected setpoint, not sent (the previous command continues until stale): "
                                    f"{exc}", throttle_duration_sec=LOG_THROTTLE_S)
            return
        try:
            velocities_m_per_s = setpoint_velocities_m_per_s(msg.name, msg.velocity, robot)
        except InvalidInputError as exc:
            # Velocities are a hint for the lag compensation only: the lengths are the command. Unusable ones
            # are dropped (the compensation then differences successive setpoints), said and counted.
            velocities_m_per_s = None
            self.status.ignored_velocities += 1
            self.get_logger().warning(f"setpoint velocities ignored (the lengths are used): {exc}",
                                      throttle_duration_sec=LOG_THROTTLE_S)
        stamp_ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        age_s, check = setpoint_age_s(stamp_ns, self.get_clock().now().nanoseconds, self.gate.setpoint_timeout_s)
        self.status.arrival_age_max_s = max(self.status.arrival_age_max_s, age_s)
        if check is StampCheck.STALE:
            self.status.rejected_setpoints += 1
            self.status.stale_on_arrival += 1
            self.status.clock_offset_s = age_s
            self.get_logger().error(f"rejected setpoint, not sent: its stamp is {age_s:.3f} s old, more than "
                                    f"setpoint_timeout_s {self.gate.setpoint_timeout_s:g} s (a stall, or the "
                                    "sender's clock lags this host's: sync the clocks)",
                                    throttle_duration_sec=LOG_THROTTLE_S)
            return
        if check is StampCheck.FUTURE:
            self.status.future_stamped += 1
            self.status.clock_offset_s = (self.get_clock().now().nanoseconds - stamp_ns) * 1e-9
            self.get_logger().warning(f"setpoint stamped {-self.status.clock_offset_s:.3f} s in the future: the "
                                      "sender's clock runs ahead of this host's (sync the clocks); aged from arrival",
                                      throttle_duration_sec=LOG_THROTTLE_S)
        self._note_limited(lengths_m)
        now_s, cut_before = time.monotonic(), self.shaper.compensation_clamped
        self.gate.accept(self.shaper.pressures_bar(lengths_m, velocities_m_per_s, now_s), now_s, age_s)
        if self.shaper.compensation_clamped > cut_before:
            self.get_logger().warning(
                f"lag compensation: the lead asked for more than [0, {robot.max_pressure_bar:g}] bar (or a muscle's "
                "saturation); cut at the clamp, never exceeded (compensation_clamped on /diagnostics)",
                throttle_duration_sec=5.0)
        self.status.setpoints_accepted += 1
        self.status.pending_stamp_ns = stamp_ns

    def _note_limited(self, lengths_m: np.ndarray) -> None:
        """Say out loud when the clamp changes a setpoint: outside [0, max extension] or above the pressure limit."""
        robot = self.rig.robot
        names = self.shaper.limited_joints(lengths_m)
        if not names:
            return
        self.status.limited_setpoints += 1
        indices = [robot.joint_index[name] for name in names]
        asked = [round(float(lengths_m[i]), 4) for i in indices]
        limits = [round(float(self.shaper.map.limited_length_m[i]), 4) for i in indices]
        self.get_logger().warning(
            f"setpoint limited by the clamp: {names} ask {asked} m; they are commanded within [0, {limits}] m, "
            f"i.e. [0, {robot.max_pressure_bar:g}] bar with {self.shaper.map.describe()} (the muscles' largest "
            f"extension is {robot.max_extension_m:g} m); lower the gait amplitude to avoid it",
            throttle_duration_sec=5.0)

    def _on_command_tick(self) -> None:
        """At the command rate, on the steady clock: write the gate's decision (newest setpoint or 0 bar)."""
        if self.backend is None:  # released (cleanup, shutdown) while a callback was already queued
            return
        now_s = time.monotonic()
        try:
            holding = self.backend.holding_reason()  # a paused simulator holds; a lost one raises
        except Exception as exc:  # any backend failure takes the generic fault path
            self._on_backend_fault(exc)
            return
        stalls = self.gate.stalls
        pressure_bar, reason = self.gate.decide(now_s, holding)
        if self.gate.stalls > stalls:
            self.get_logger().warning(f"command ticks stalled longer than {self.gate.max_gap_s:g} s (this process was "
                                      "frozen or starved of CPU; see realtime_priority): output restarts with a "
                                      "ramp from 0 bar", throttle_duration_sec=LOG_THROTTLE_S)
        try:
            sent_bar = self.backend.write_pressures(pressure_bar)
            state = self.backend.read_state() if self.status.ticks % self._state_every_ticks == 0 else None
        except Exception as exc:  # any backend failure takes the generic fault path
            self._on_backend_fault(exc)
            return
        if self.status.pending_stamp_ns and reason in (OutputReason.COMMANDING, OutputReason.RAMPING):
            self.status.latency_ms.append((self.get_clock().now().nanoseconds - self.status.pending_stamp_ns) * 1e-6)
        self.status.pending_stamp_ns = 0
        self.status.ticks += 1
        self.status.holding = holding
        self._note_reason(reason)
        names = self.rig.robot.joint_names
        self._runtime["pressure"].publish(labelled_array(names, sent_bar))
        self._runtime["voltage"].publish(labelled_array(names, pressures_to_command_v(sent_bar, self.rig.robot)))
        if state is not None:
            self._runtime["state"].publish(self._actuator_state_msg(state))

    def _on_backend_fault(self, exc: Exception) -> None:
        """Vent (best effort), then fail the next transition so the node goes through ErrorProcessing."""
        self.status.fault = _describe(exc)
        self._recover = (self.backend.recovers_by_itself, self.gate.active)
        self._report_error(f"backend fault while commanding (venting, going to the error state): {self.status.fault}")
        self._vent()
        if self.gate.active:
            self.trigger_deactivate()
        else:
            self.trigger_cleanup()

    def _vent(self) -> Exception | None:
        """Command 0 bar now; on failure report it loudly and return the exception."""
        if self.backend is None or not self.backend.is_open:
            return None
        try:
            self.backend.vent()
        except Exception as exc:  # venting is best effort; the failure is reported
            self._report_error(f"{VENT_FAILED} ({_describe(exc)})")
            return exc
        return None

    def _note_reason(self, reason: OutputReason) -> None:
        if reason is self.status.reason:
            return
        if reason is OutputReason.STALE and self.status.reason in (OutputReason.COMMANDING, OutputReason.RAMPING):
            self.status.stale_vents += 1
        self.status.holds += reason is OutputReason.HOLDING
        self.status.reason = reason
        if reason is OutputReason.STALE:  # rclpy fixes a call site's severity, hence three calls
            self.get_logger().warning(f"output: {reason.value} (older than {self.gate.setpoint_timeout_s:g} s) "
                                      "-> 0 bar")
        elif reason is OutputReason.HOLDING:
            self.get_logger().warning(f"output: {reason.value}: {self.status.holding}; ramps back in when it answers")
        else:
            self.get_logger().info(f"output: {reason.value}" + (
                "" if reason in (OutputReason.COMMANDING, OutputReason.RAMPING) else " -> 0 bar"))

    def _actuator_state_msg(self, state) -> JointState:
        msg = JointState(name=list(self.rig.robot.joint_names))
        msg.header.stamp = self.get_clock().now().to_msg()
        if state.measured_length_m is not None:
            msg.position = [float(v) for v in state.measured_length_m]
        if state.measured_pressure_bar is not None:
            msg.effort = [float(v) for v in state.measured_pressure_bar]
        return msg

    # -- parameters --------------------------------------------------------------------------
    def _check_value(self, name: str, value) -> str:
        """Why a new parameter value is refused ('' if it is not): the static checks, and a live compensation."""
        if name == "lag_compensation" and value and self.shaper is not None:
            refusal = self.shaper.compensation_refusal()
            if refusal:
                return f"lag_compensation: {refusal} (then configure again)"
        return _check_choice(name, value)

    def _apply_parameters(self, params) -> None:
        """Switch the lag compensation live; every other parameter waits for the next configure."""
        for param in params:
            if param.name == "lag_compensation" and self.shaper is not None:
                self.shaper.compensation = param.value
                self.get_logger().info(f"lag compensation {'on' if param.value else 'off'} "
                                       f"({self.shaper.map.describe()})")

    # -- services ----------------------------------------------------------------------------
    def _on_emergency_stop(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        self.gate.latch_estop()
        self._note_reason(OutputReason.ESTOP)
        self.get_logger().warning("EMERGENCY STOP latched: venting every valve until ~/reset")
        had_backend = self.backend is not None
        failure = self._vent()
        if failure is not None:
            self._on_backend_fault(failure)
        response.success = failure is None
        response.message = ("e-stop latched: every valve vented to 0 bar" if had_backend and failure is None
                            else "e-stop latched (no backend open, nothing to vent)" if failure is None
                            else f"e-stop latched; {VENT_FAILED}; node went to the error state: {self.status.fault}")
        response.message += "; call ~/reset to release" + (", then ~/arm." if not self.gate.has_go else ".")
        return response

    def _on_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        was_latched = self.gate.reset_estop()
        then = "call ~/arm, then output ramps up with" if not self.gate.has_go else "output ramps up with"
        if was_latched:
            self.get_logger().warning(f"e-stop released: {then} the next fresh setpoint")
        response.success = True
        response.message = (f"e-stop released; {then} the next fresh setpoint." if was_latched
                            else "e-stop was not latched; nothing to reset.")
        return response

    def _on_arm(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        had_go = self.gate.has_go
        refusal = self.gate.arm()
        response.success = not refusal
        if refusal:
            response.message = f"not armed: {refusal}."
        elif not self.gate.requires_arm:
            response.message = (f"armed (the {self.backend.name} rig is simulated and needs no arm)." if had_go else
                                f"armed again after ~/disarm: the simulated {self.backend.name} rig commands fresh "
                                f"setpoints, ramping up from 0 bar over {self.gate.ramp_time_s:g} s.")
        else:
            response.message = (f"ARMED by the operator: the {self.backend.name} rig now commands fresh setpoints, "
                                f"ramping up from 0 bar over {self.gate.ramp_time_s:g} s; ~/emergency_stop or "
                                "~/disarm vents.")
            self.get_logger().warning(response.message)
        return response

    def _on_disarm(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        was_armed = self.gate.disarm()
        response.success = True
        response.message = ("disarmed: venting to 0 bar until ~/arm." if was_armed
                             else "was not armed: output stays at 0 bar until ~/arm.")
        if was_armed:
            self.get_logger().warning(response.message)
        return response

    # -- diagnostics -------------------------------------------------------------------------
    def _publish_diagnostics(self) -> None:
        now_s = time.monotonic()
        status = self.status
        then_s, then_ticks, then_received, then_problems = status.rate_window
        span_s = now_s - then_s if now_s > then_s and self._runtime else math.inf
        rate_hz = (status.ticks - then_ticks) / span_s
        setpoint_rate_hz = (status.setpoints_received - then_received) / span_s
        problems = status.stale_on_arrival + status.future_stamped
        status.rate_window = (now_s, status.ticks, status.setpoints_received, problems)
        arrival_age_max_s, status.arrival_age_max_s = status.arrival_age_max_s, 0.0
        level, message = self._diagnostic_summary(setpoint_rate_hz, problems - then_problems)
        values = {
            "backend": self.backend.name if self.backend else "none",
            "backend_open": str(bool(self.backend and self.backend.is_open)),
            "rig": self.rig.name if self.rig else "none",
            "lifecycle_state": self.lifecycle_label(),
            "output": status.reason.value if self._runtime else "not configured",
            "requires_arm": str(self.gate.requires_arm),
            "armed": str(self.gate.armed),
            "command_rate_hz": f"{rate_hz:.1f}",
            "setpoint_rate_hz": f"{setpoint_rate_hz:.1f}",
            "setpoint_age_s": f"{self.gate.setpoint_age_s(now_s):.3f}",
            "setpoint_timeout_s": f"{self.gate.setpoint_timeout_s:g}",
            "estop_latched": str(self.gate.estop_latched),
            "setpoints_received": str(status.setpoints_received),
            "setpoints_accepted": str(status.setpoints_accepted),
            "rejected_setpoints": str(status.rejected_setpoints),
            "ignored_velocities": str(status.ignored_velocities),
            "setpoints_while_unconfigured": str(status.setpoints_while_unconfigured),
            "stale_on_arrival": str(status.stale_on_arrival),
            "future_stamped": str(status.future_stamped),
            "clock_offset_s": f"{status.clock_offset_s:.3f}",
            "limited_setpoints": str(status.limited_setpoints),
            "pressure_map": self.shaper.map.name if self.shaper else "none",
            "lag_compensation": str(bool(self.shaper and self.shaper.compensation)),
            "compensation_clamped": str(self.shaper.compensation_clamped if self.shaper else 0),
            "stale_vents": str(status.stale_vents),
            "command_stalls": str(self.gate.stalls),
            "holding": status.holding or "none",
            "holds": str(status.holds),
            "recoveries": str(status.recoveries),
            "setpoint_arrival_age_max_ms": f"{arrival_age_max_s * 1e3:.3f}",
            "backend_writes": str(status.ticks),
            **self._latency_summary(),
            "last_error": status.last_error or "none",
        }
        status_msg = DiagnosticStatus(level=level, name=f"{NODE_NAME}: actuators", message=message,
                                      hardware_id=self.rig.name if self.rig else "none",
                                      values=[KeyValue(key=k, value=v) for k, v in values.items()])
        msg = DiagnosticArray(status=[status_msg])
        msg.header.stamp = self.get_clock().now().to_msg()
        self.diagnostics_publisher.publish(msg)

    def _latency_summary(self) -> dict[str, str]:
        """Setpoint stamp -> backend write latency over the last 2000 written setpoints (ms)."""
        if not self.status.latency_ms:
            return {"command_latency_p50_ms": "n/a", "command_latency_p99_ms": "n/a", "command_latency_max_ms": "n/a",
                    "command_latency_count": "0"}
        p50, p99, worst = np.percentile(np.fromiter(self.status.latency_ms, float), [50, 99, 100])
        return {"command_latency_p50_ms": f"{p50:.3f}", "command_latency_p99_ms": f"{p99:.3f}",
                "command_latency_max_ms": f"{worst:.3f}",
                "command_latency_count": str(len(self.status.latency_ms))}

    def _diagnostic_summary(self, setpoint_rate_hz: float, stamp_problems: int) -> tuple[bytes, str]:
        if self.status.fault:
            then = ("the simulated rig recovers by itself" if self._recover[0]
                    else "configure and activate to recover")
            return DiagnosticStatus.ERROR, f"backend fault: {self.status.fault}; {then}"
        if self.gate.estop_latched:
            return DiagnosticStatus.WARN, "e-stop latched: venting until ~/reset"
        if not self._runtime:
            return DiagnosticStatus.OK, "unconfigured: backend closed, nothing sent"
        timeout_s = self.gate.setpoint_timeout_s
        if 0.0 < setpoint_rate_hz < min_setpoint_rate_hz(timeout_s):
            return DiagnosticStatus.WARN, (f"setpoints arrive at {setpoint_rate_hz:.1f} Hz, fewer than two per "
                                           f"setpoint_timeout_s ({timeout_s:g} s): the valves pulse; raise the "
                                           f"player's rate_hz to at least {min_setpoint_rate_hz(timeout_s):g} Hz")
        if stamp_problems:
            return DiagnosticStatus.WARN, (f"{self.status.reason.value}; {stamp_problems} setpoint stamps in the last "
                                           f"period were stale on arrival or from the future (latest offset "
                                           f"{self.status.clock_offset_s:+.3f} s): a stall or a clock offset between "
                                           "hosts (sync the clocks)")
        if self.status.reason is OutputReason.STALE:
            return DiagnosticStatus.WARN, "setpoints stale: venting to 0 bar"
        if self.status.reason is OutputReason.HOLDING:
            return DiagnosticStatus.WARN, (f"holding at 0 bar: {self.status.holding}; output ramps back in when it "
                                           "answers")
        return DiagnosticStatus.OK, self.status.reason.value

    def lifecycle_label(self) -> str:
        """The lifecycle state label (unconfigured, inactive, active, ...)."""
        # rclpy's LifecycleNode keeps the state only in its state machine; no public getter in Jazzy.
        return self._state_machine.current_state[1]

    def _report_error(self, text: str) -> None:
        self.status.last_error = text
        self.get_logger().error(text)


def _check_choice(name: str, value) -> str:
    if name == "backend" and value and value not in BACKENDS:
        return f"backend: unknown backend {value!r}; expected '' (the rig's) or one of {sorted(BACKENDS)}."
    if name == "pressure_map" and value not in (PAPER_MAP, CALIBRATED_MAP):
        return f"pressure_map: {value!r}; expected '{PAPER_MAP}' (P = 100 l) or '{CALIBRATED_MAP}' (calibration_file)."
    return ""


def _describe(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


def release_and_report(node: HardwareNode, program: str) -> bool:
    """Vent and close at process exit and print the outcome (the vent, nothing to vent, or VENT FAILED)."""
    was_open = node.backend is not None
    vented = node.release_hardware()
    outcome = VENT_FAILED if not vented else ("every valve vented to 0 bar" if was_open
                                              else "no backend was open, nothing to vent")
    print(f"\n{program}: stopped; {outcome}", flush=True)
    return vented


def main(args: list[str] | None = None) -> int:
    """``hardware_node``: spin until Ctrl-C, then vent and close the backend."""
    return run_node(HardwareNode, args, executor_factory=EventsExecutor,
                    on_shutdown=lambda node: release_and_report(node, NODE_NAME))


if __name__ == "__main__":
    raise SystemExit(main())
