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

import dataclasses
import time

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.experimental import EventsExecutor
from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn
from rclpy.publisher import Publisher
from rclpy.subscription import Subscription
from rclpy.timer import Timer
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger

from srs_ros.backends import BACKENDS, ActuatorBackend, create_backend
from srs_ros.core.actuation import operator
from srs_ros.core.actuation.compensation import SetpointShaper, setpoint_shaper
from srs_ros.core.actuation.intake import IntakeDecision, Setpoint, Verdict, take_setpoint
from srs_ros.core.actuation.muscle_calibration import CALIBRATED_MAP, PAPER_MAP
from srs_ros.core.actuation.pressure import pressures_to_command_v
from srs_ros.core.actuation.safety import VENT_FAILED, CommandGate, OutputReason
from srs_ros.core.actuation.status import HardwareStatus, NodeSetup, output_message
from srs_ros.core.actuation.timing import CommandTiming, command_timing
from srs_ros.core.errors import ConfigurationError
from srs_ros.core.ramp import DEFAULT_RAMP_TIME_S
from srs_ros.core.rig import RigConfig, load_rig
from srs_ros.core.robot import ABSOLUTE_MAX_PRESSURE_BAR, load_robot
from srs_ros.ros.interfaces import (
    ACTUATOR_STATE_TOPIC,
    COMMAND_VOLTAGE_TOPIC,
    COMMANDED_PRESSURE_TOPIC,
    DIAGNOSTICS_TOPIC,
    SETPOINT_TOPIC,
    diagnostic_array,
    diagnostic_status,
    labelled_array,
    setpoint_qos,
    stamp_to_nanoseconds,
)
from srs_ros.ros.parameters import REALTIME_PRIORITY, ParameterSpec, check_parameters, declare_parameters
from srs_ros.ros.process import forward_python_logs, request_realtime_priority, run_node, steady_timer

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


class HardwareNode(LifecycleNode):
    """Lifecycle wiring around a backend and the ROS-free pieces of :mod:`srs_ros.core.actuation`.

    :class:`~srs_ros.core.actuation.timing.CommandTiming` checks the clocks at configure,
    :func:`~srs_ros.core.actuation.intake.take_setpoint` takes each setpoint into the
    :class:`~srs_ros.core.actuation.safety.CommandGate`, which decides every command, and
    :class:`~srs_ros.core.actuation.status.HardwareStatus` counts and reports; the node logs and publishes.
    """

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
        self.timing: CommandTiming | None = None  # command rate, setpoint timeout, state rate, from configure
        self.gate = CommandGate(joint_count=0, setpoint_timeout_s=0.0)
        self.status = HardwareStatus()
        # created at configure, destroyed when the node lets go of the hardware (cleanup, shutdown, error)
        self._pressure_publisher: Publisher | None = None
        self._voltage_publisher: Publisher | None = None
        self._state_publisher: Publisher | None = None
        self._setpoint_subscription: Subscription | None = None
        self._command_timer: Timer | None = None
        self._recovery_timer: Timer | None = None  # while a rig that recovers by itself is faulted
        forward_python_logs("srs_ros.backends", self.get_logger())  # e.g. a missing NI watchdog
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

    @property
    def configured(self) -> bool:
        """True while the runtime interfaces exist (configured: inactive or active)."""
        return self._command_timer is not None

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
                               f"{self.timing.command_rate_hz:g} Hz, setpoint timeout "
                               f"{self.timing.setpoint_timeout_s:g} s, limit {self.rig.robot.max_pressure_bar:g} bar, "
                               f"{self.shaper.map.describe()}, lag compensation "
                               f"{'on' if self.shaper.compensation else 'off'}")
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
        if self.status.recovers_by_itself:
            self._recovery_timer = self._recovery_timer or steady_timer(self, RECOVERY_PERIOD_S, self._try_recovery)
            self.get_logger().error(f"error processing done: backend closed, node unconfigured (fault: {fault}); "
                                    f"the simulated rig recovers by itself: configure"
                                    f"{' + activate' if self.status.reactivate else ''} in {RECOVERY_PERIOD_S:g} s")
        else:
            self.get_logger().error(f"error processing done: backend closed, node unconfigured; configure and "
                                    f"activate to recover (fault: {fault})")
        return TransitionCallbackReturn.SUCCESS

    def _try_recovery(self) -> None:
        """Configure (and activate, if it was active) a rig that recovers by itself; stop once done or overtaken."""
        if self.lifecycle_label() == "unconfigured" and self.trigger_configure() != TransitionCallbackReturn.SUCCESS:
            return  # configure said why; try again next period
        if self.status.reactivate and self.lifecycle_label() == "inactive":
            self.trigger_activate()
        self.destroy_timer(self._recovery_timer)
        self._recovery_timer = None
        self.status.recovers_by_itself = self.status.reactivate = False
        self.status.recoveries += 1
        self.get_logger().warning(f"recovered by itself after a fault: {self.lifecycle_label()}, holding 0 bar until "
                                  "the simulated robot answers, then ramping up")

    # -- configure helpers --------------------------------------------------------------------
    def _open_backend(self) -> tuple[RigConfig, ActuatorBackend]:
        """Load robot and rig, check the timing, open the backend and set the gate up for it."""
        param = self.get_parameter
        robot = load_robot(param("robot_description_file").value or None)
        limit_bar = min(robot.max_pressure_bar, param("max_pressure_bar").value)
        rig = load_rig(param("rig_file").value or None, dataclasses.replace(robot, max_pressure_bar=limit_bar))
        timing = command_timing(rig, param("command_rate_hz").value, param("setpoint_timeout_s").value,
                                param("state_publish_rate_hz").value)
        self.shaper = setpoint_shaper(rig.robot, param("pressure_map").value, param("calibration_file").value,
                                      param("compensation_delay_s").value, param("compensation_time_constant_s").value,
                                      param("lag_compensation").value)
        backend = create_backend(param("backend").value or rig.backend, rig.robot, rig.backend_options)
        backend.open()
        try:
            warning = timing.check_hardware(backend.name, backend.host_loss_timeout_s, backend.drives_real_hardware)
        except ConfigurationError:
            backend.close()
            raise
        if warning:
            self.get_logger().warning(warning)
        self.timing = timing
        self.gate.configure(rig.robot.joint_count, timing.setpoint_timeout_s, param("ramp_time_s").value,
                            requires_arm=backend.drives_real_hardware,
                            max_gap_s=timing.stall_gap_s(backend.host_loss_timeout_s))
        return rig, backend

    def _create_runtime(self) -> None:
        """The command publishers, the setpoint subscription and the command timer (steady clock)."""
        self.status.start_rate_window(time.monotonic())
        self._pressure_publisher = self.create_publisher(Float64MultiArray, COMMANDED_PRESSURE_TOPIC, 10)
        self._voltage_publisher = self.create_publisher(Float64MultiArray, COMMAND_VOLTAGE_TOPIC, 10)
        self._state_publisher = self.create_publisher(JointState, ACTUATOR_STATE_TOPIC, 10)
        self._setpoint_subscription = self.create_subscription(JointState, SETPOINT_TOPIC, self._on_setpoint,
                                                               setpoint_qos())
        self._command_timer = steady_timer(self, self.timing.period_s, self._on_command_tick)

    def _destroy_runtime(self) -> None:
        """Destroy what :meth:`_create_runtime` made; safe to repeat."""
        if self._command_timer is not None:
            self.destroy_timer(self._command_timer)
        if self._setpoint_subscription is not None:
            self.destroy_subscription(self._setpoint_subscription)
        for publisher in (self._pressure_publisher, self._voltage_publisher, self._state_publisher):
            if publisher is not None:
                self.destroy_publisher(publisher)
        self._command_timer = self._setpoint_subscription = None
        self._pressure_publisher = self._voltage_publisher = self._state_publisher = None

    def _release(self) -> None:
        """Vent and close the backend (best effort) and destroy the runtime interfaces; safe to repeat."""
        self.gate.set_active(False)
        self.status.released()
        self.release_hardware()
        self.shaper = None  # the next configure reads the map and the compensation again
        self._destroy_runtime()

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

    # -- runtime -----------------------------------------------------------------------------
    def _on_setpoint(self, msg: JointState) -> None:
        self.status.setpoints_received += 1
        if self.shaper is None or not self.configured:  # queued before a release (a fault, cleanup): nothing to drive
            self.status.setpoints_while_unconfigured += 1
            return
        setpoint = Setpoint(msg.name, msg.position, msg.velocity, stamp_to_nanoseconds(msg.header.stamp))
        try:
            decision = take_setpoint(setpoint, self.shaper, self.gate, self.get_clock().now().nanoseconds,
                                     time.monotonic())
        except Exception as exc:  # a callback must never kill the node; the setpoint is not used
            self.status.rejected_setpoints += 1
            self.get_logger().error(f"rejected setpoint, not sent (unexpected error, please report): "
                                    f"{_describe(exc)}", throttle_duration_sec=LOG_THROTTLE_S)
            return
        self.status.count_setpoint(decision)
        self._log_setpoint(decision)

    def _log_setpoint(self, decision: IntakeDecision) -> None:
        """Say what the intake noted; one call site per kind of note, so that each is throttled on its own."""
        log = self.get_logger()
        if decision.verdict is Verdict.INVALID:
            log.error(decision.rejection, throttle_duration_sec=LOG_THROTTLE_S)
        elif decision.verdict is Verdict.STALE:
            log.error(decision.rejection, throttle_duration_sec=LOG_THROTTLE_S)
        if decision.velocity_note:
            log.warning(decision.velocity_note, throttle_duration_sec=LOG_THROTTLE_S)
        if decision.clock_note:
            log.warning(decision.clock_note, throttle_duration_sec=LOG_THROTTLE_S)
        if decision.limit_note:
            log.warning(decision.limit_note, throttle_duration_sec=5.0)
        if decision.compensation_note:
            log.warning(decision.compensation_note, throttle_duration_sec=5.0)

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
            state = self.backend.read_state() if self.status.ticks % self.timing.state_every_ticks == 0 else None
        except Exception as exc:  # any backend failure takes the generic fault path
            self._on_backend_fault(exc)
            return
        self.status.note_write(reason, holding, self.get_clock().now().nanoseconds)
        self._note_reason(reason)
        names = self.rig.robot.joint_names
        self._pressure_publisher.publish(labelled_array(names, sent_bar))
        self._voltage_publisher.publish(labelled_array(names, pressures_to_command_v(sent_bar, self.rig.robot)))
        if state is not None:
            self._state_publisher.publish(self._actuator_state_msg(state))

    def _on_backend_fault(self, exc: Exception) -> None:
        """Vent (best effort), then fail the next transition so the node goes through ErrorProcessing."""
        self.status.fault = _describe(exc)
        self.status.recovers_by_itself, self.status.reactivate = self.backend.recovers_by_itself, self.gate.active
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
        if not self.status.note_reason(reason):
            return
        text = output_message(reason, self.gate.setpoint_timeout_s, self.status.holding)
        if reason in (OutputReason.STALE, OutputReason.HOLDING):  # rclpy fixes a call site's severity
            self.get_logger().warning(text)
        else:
            self.get_logger().info(text)

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
        answer = operator.Answer(failure is None, operator.estop_message(
            self.gate, had_backend, self.status.fault if failure is not None else ""))
        return self._answer(answer, response)

    def _on_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        return self._answer(operator.reset(self.gate), response)

    def _on_arm(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        return self._answer(operator.arm(self.gate, self.backend.name if self.backend else "none"), response)

    def _on_disarm(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        return self._answer(operator.disarm(self.gate), response)

    def _answer(self, answer: operator.Answer, response: Trigger.Response) -> Trigger.Response:
        if answer.warning:
            self.get_logger().warning(answer.warning)
        response.success, response.message = answer.success, answer.message
        return response

    # -- diagnostics -------------------------------------------------------------------------
    def _publish_diagnostics(self) -> None:
        """The status report on /diagnostics (1 Hz, in every state)."""
        setup = NodeSetup(rig=self.rig.name if self.rig else "none",
                          backend=self.backend.name if self.backend else "none",
                          backend_open=bool(self.backend and self.backend.is_open),
                          lifecycle_state=self.lifecycle_label(), configured=self.configured)
        report = self.status.report(time.monotonic(), setup, self.gate, self.shaper)
        status = diagnostic_status(f"{NODE_NAME}: actuators", setup.rig, report.level, report.message, report.values)
        self.diagnostics_publisher.publish(diagnostic_array([status], self.get_clock().now().to_msg()))

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
