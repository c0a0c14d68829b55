"""The hardware node (managed/lifecycle): setpoints in, the one clamp, regulator commands out at a fixed rate.

Lifecycle: configure loads the robot and rig, opens the backend (a failure logs why, nothing sent) and starts the
command timer (0 bar until activated); activate enables output; deactivate, cleanup and shutdown vent. A backend
failure while commanding (any exception, e.g. ``HardwareError``) vents (best effort) and takes the node through
ErrorProcessing to unconfigured; configure + activate recover it.

Safety (see docs/safety.md):

- every timer runs on the steady clock, so the watchdog and the keep-alive keep running whatever ROS time does
  (``use_sim_time`` without ``/clock``, a system clock step);
- a rig whose backend drives real regulators (``can``, ``daq``) commands nothing above 0 bar until an operator calls
  ``~/arm`` (``srs_bringup --arm`` does it for you); deactivate, an e-stop or a fault disarm; the simulated backends
  need no arm, but ``~/disarm`` holds 0 bar on every rig until ``~/arm``;
- whenever output (re)starts (activation, arm, e-stop reset, after a vent for stale setpoints) it ramps up from 0 bar
  over ``ramp_time_s``;
- the backend is written at the command rate only (the newest setpoint wins); a setpoint counts from its stamp
  (unstamped: from its arrival), so the valves vent at most ``setpoint_timeout_s`` plus one command period after the
  last fresh setpoint was made.

Interfaces (relative names, remappable):

- subscribes ``joint_setpoints`` (sensor_msgs/JointState, best effort, depth 1): ``name`` = every actuator
  (``m1_pma1`` ... ``m3_pma3``) once, in any order; ``position`` = actuator length change (m). Rejected, never sent,
  throttled error log and counted: wrong count, names/positions mismatch, unknown or duplicate names, NaN/inf, a stamp
  older than the timeout (stale on arrival). A stamp from the future is aged from its arrival and reported on
  /diagnostics as a clock offset. Finite lengths outside ``[0, max_extension_m]`` or above what the pressure limit
  allows under the selected map are limited by the one clamp, with a throttled warning and a counter. ``velocity``
  (m/s, optional; gait_player sends it) feeds the lag compensation. A setpoint already queued when the node is
  released (a fault, cleanup) is dropped quietly and counted (``setpoints_while_unconfigured``).
- lengths become pressures through ``pressure_map`` (``paper``: ``P = 100 l``; ``calibrated``: ``calibration_file``
  from ``srs_identify``), led by ``lag_compensation`` if on (live), always through the one clamp.
- publishes ``commanded_pressure_bar`` and ``command_voltage_v`` (std_msgs/Float64MultiArray, dim 0 labelled with the
  joint names): what the backend was sent, on each command while configured (zeros when inactive, disarmed, stale or
  e-stopped); ``actuator_state`` (sensor_msgs/JointState) at ``state_publish_rate_hz``: ``position`` = measured length
  (m), ``effort`` = measured pressure (bar), empty where the backend cannot measure; ``/diagnostics``
  (diagnostic_msgs/DiagnosticArray, 1 Hz, in every state, and at once on a backend fault), with counters of setpoints
  received, rejected, limited and written, the pressure map and ``compensation_clamped``.
- services ``~/emergency_stop`` (std_srvs/Trigger: vents at once and latches, in any state; the latch survives
  deactivate/cleanup/configure), ``~/reset`` (releases the latch; output resumes with the next fresh setpoint, after a
  new ``~/arm`` on a real rig), ``~/arm`` and ``~/disarm``; the lifecycle services.
- parameters: :data:`PARAMETERS`; ``lag_compensation`` live; ``max_pressure_bar`` (only lowers the robot's limit) and
  ``realtime_priority`` read-only; the others at the next configure.
"""

from __future__ import annotations

import dataclasses
import functools
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

from srs_ros.backends import BACKENDS, ActuatorBackend, backend_class, create_backend
from srs_ros.core.actuation import operator
from srs_ros.core.actuation.compensation import SetpointShaper
from srs_ros.core.actuation.intake import IntakeDecision, NoteThrottle, Setpoint, take_setpoint
from srs_ros.core.actuation.pressure import pressures_to_command_v
from srs_ros.core.actuation.safety import VENT_FAILED, CommandGate, OutputReason
from srs_ros.core.actuation.settings import HARDWARE_SETTINGS, READ_ONLY, hardware_setup
from srs_ros.core.actuation.status import (
    HardwareStatus,
    NodeSetup,
    configured_message,
    exit_message,
    output_message,
    stall_message,
)
from srs_ros.core.actuation.timing import CommandTiming
from srs_ros.core.errors import ConfigurationError, SrsError
from srs_ros.core.rig import RigConfig
from srs_ros.ros.interfaces import (
    ACTUATOR_STATE_TOPIC,
    COMMAND_VOLTAGE_TOPIC,
    COMMANDED_PRESSURE_TOPIC,
    DIAGNOSTICS_TOPIC,
    SETPOINT_TOPIC,
    STATUS_NODE_KEY,
    diagnostic_array,
    diagnostic_status,
    joint_state,
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

#: The node's parameters: its settings (:mod:`srs_ros.core.actuation.settings`) and the real-time priority.
PARAMETERS = (*(ParameterSpec.from_field(f, read_only=f.name in READ_ONLY) for f in HARDWARE_SETTINGS),
              REALTIME_PRIORITY)


@dataclasses.dataclass(frozen=True)
class Runtime:
    """What exists while the node is configured: made at configure, destroyed when it lets go of the hardware."""

    pressure_publisher: Publisher  # commanded_pressure_bar
    voltage_publisher: Publisher  # command_voltage_v
    state_publisher: Publisher  # actuator_state
    setpoint_subscription: Subscription  # joint_setpoints
    command_timer: Timer  # the command rate, on the steady clock


class HardwareNode(LifecycleNode):
    """Lifecycle wiring around a backend and the ROS-free pieces of :mod:`srs_ros.core.actuation`.

    :func:`~srs_ros.core.actuation.settings.hardware_setup` turns the parameters into rig, timing and shaper
    at configure (:class:`~srs_ros.core.actuation.timing.CommandTiming` checks the clocks),
    :func:`~srs_ros.core.actuation.intake.take_setpoint` takes each setpoint into the
    :class:`~srs_ros.core.actuation.safety.CommandGate`, which decides every command,
    :mod:`~srs_ros.core.actuation.operator` answers the services and
    :class:`~srs_ros.core.actuation.status.HardwareStatus` counts, keeps the fault and reports; the node
    holds the typed :class:`Runtime` entities, logs and publishes.
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
        self.notes = NoteThrottle()  # what the intake says about setpoints, throttled
        self.runtime: Runtime | None = None  # created at configure, destroyed at cleanup, shutdown or an error
        self._recovery_timer: Timer | None = None  # while a rig that recovers by itself is faulted
        forward_python_logs("srs_ros.backends", self.get_logger())  # e.g. a missing NI watchdog
        self.diagnostics_publisher = self.create_publisher(DiagnosticArray, DIAGNOSTICS_TOPIC, 10)
        for name, decide in (("emergency_stop", self._emergency_stop), ("reset", lambda: operator.reset(self.gate)),
                             ("arm", lambda: operator.arm(self.gate, self.backend.name if self.backend else "none")),
                             ("disarm", lambda: operator.disarm(self.gate))):
            self.create_service(Trigger, f"~/{name}", functools.partial(self._answer, decide))
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
        return self.runtime is not None

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
        self.get_logger().info(configured_message(self.rig, self.backend.name, self.gate, self.timing, self.shaper))
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
        if self.status.recovers_by_itself:
            self._recovery_timer = self._recovery_timer or steady_timer(self, RECOVERY_PERIOD_S, self._try_recovery)
        self.get_logger().error(self.status.error_processed(RECOVERY_PERIOD_S))
        return TransitionCallbackReturn.SUCCESS

    def _try_recovery(self) -> None:
        """Configure (and activate, if it was active) a rig that recovers by itself; else leave it to the operator.

        A configure by hand meanwhile, or a real rig set since the fault (``rig_file``, ``backend``), is theirs.
        """
        if (state := self.lifecycle_label()) != "unconfigured":
            self._stop_recovery(f"automatic recovery stopped: configured by hand ({state}); activate it yourself")
        elif self._recovers_by_itself_now() is False:
            self._stop_recovery("automatic recovery stopped: the rig set since the fault is real hardware, which "
                                "waits for the operator; configure it yourself")
        elif self.trigger_configure() == TransitionCallbackReturn.SUCCESS:
            self._recovered()
        # else configure said why; tried again next period

    def _stop_recovery(self, message: str) -> None:
        """End the automatic recovery: a configure by hand, even of a real rig, is never activated by it (a review)."""
        self.destroy_timer(self._recovery_timer)
        self._recovery_timer = None
        self.get_logger().warning(message)

    def _recovered(self) -> None:
        if self.status.reactivate and self.lifecycle_label() == "inactive":
            self.trigger_activate()
        self._stop_recovery(self.status.recovered(self.lifecycle_label()))

    def _recovers_by_itself_now(self) -> bool | None:
        """Whether the rig the parameters now name recovers by itself (None if they cannot be read: configure says)."""
        try:
            setup = hardware_setup({f.name: self.get_parameter(f.name).value for f in HARDWARE_SETTINGS})
            return backend_class(setup.backend).recovers_by_itself
        except SrsError:
            return None

    # -- configure helpers --------------------------------------------------------------------
    def _open_backend(self) -> tuple[RigConfig, ActuatorBackend]:
        """Set up rig, timing and shaper from the parameters, open the backend and set the gate up for it."""
        setup = hardware_setup({f.name: self.get_parameter(f.name).value for f in HARDWARE_SETTINGS})
        self.shaper = setup.shaper
        own = setup.backend == setup.rig.backend  # the rig's options are its own backend's, not an override's
        backend = create_backend(setup.backend, setup.rig.robot, setup.rig.backend_options if own else {},
                                 setup.rig.source if own else "")
        backend.open()
        try:
            warning = setup.timing.check_hardware(backend.name, backend.host_loss_timeout_s,
                                                  backend.drives_real_hardware, backend.silence_vent_s)
        except ConfigurationError:
            backend.close()
            raise
        if warning:
            self.get_logger().warning(warning)
        self.timing = setup.timing
        self.gate.configure(setup.rig.robot.joint_count, setup.timing.setpoint_timeout_s, setup.ramp_time_s,
                            requires_arm=backend.drives_real_hardware,
                            max_gap_s=setup.timing.stall_gap_s(backend.silence_vent_s))
        return setup.rig, backend

    def _create_runtime(self) -> None:
        """The command publishers, the setpoint subscription and the command timer (steady clock)."""
        self.status.start_rate_window(time.monotonic())
        self.runtime = Runtime(
            self.create_publisher(Float64MultiArray, COMMANDED_PRESSURE_TOPIC, 10),
            self.create_publisher(Float64MultiArray, COMMAND_VOLTAGE_TOPIC, 10),
            self.create_publisher(JointState, ACTUATOR_STATE_TOPIC, 10),
            self.create_subscription(JointState, SETPOINT_TOPIC, self._on_setpoint, setpoint_qos()),
            steady_timer(self, self.timing.period_s, self._on_command_tick))

    def _destroy_runtime(self) -> None:
        """Destroy what :meth:`_create_runtime` made; safe to repeat."""
        runtime, self.runtime = self.runtime, None
        if runtime is None:
            return
        self.destroy_timer(runtime.command_timer)
        self.destroy_subscription(runtime.setpoint_subscription)
        for publisher in (runtime.pressure_publisher, runtime.voltage_publisher, runtime.state_publisher):
            self.destroy_publisher(publisher)

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
        """Say what the intake noted, each kind of note at most once per its throttle period."""
        for note in self.notes.due(decision.notes(), time.monotonic()):
            if note.severity == "error":  # rclpy fixes a call site's severity: one call site each
                self.get_logger().error(note.text)
            else:
                self.get_logger().warning(note.text)

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
        decision = self.gate.decide(now_s, holding)
        pressure_bar, reason = self.gate.withdraw_if_late(decision, now_s, time.monotonic())  # frozen in between?
        if self.gate.stalls > stalls:
            self.get_logger().warning(stall_message(self.gate.max_gap_s), throttle_duration_sec=LOG_THROTTLE_S)
        try:
            sent_bar = self.backend.write_pressures(pressure_bar)
            state = self.backend.read_state() if self.status.ticks % self.timing.state_every_ticks == 0 else None
        except Exception as exc:  # any backend failure takes the generic fault path
            self._on_backend_fault(exc)
            return
        self.status.note_write(reason, holding, self.get_clock().now().nanoseconds)
        self._note_reason(reason)
        names, runtime = self.rig.robot.joint_names, self.runtime
        runtime.pressure_publisher.publish(labelled_array(names, sent_bar))
        runtime.voltage_publisher.publish(labelled_array(names, pressures_to_command_v(sent_bar, self.rig.robot)))
        if state is not None:
            runtime.state_publisher.publish(joint_state(names, self.get_clock().now().to_msg(),
                                                        state.measured_length_m, state.measured_pressure_bar))

    def _on_backend_fault(self, exc: Exception) -> None:
        """Vent (best effort), fail the next transition so the node goes through ErrorProcessing, and say so.

        The fault goes on /diagnostics at once, not only at the next 1 Hz report: a simulated rig is configured
        again after :data:`RECOVERY_PERIOD_S`, and a report that came late (a stalled executor runs both timers
        together) would find it recovered and the fault never reported.
        """
        self.status.note_fault(_describe(exc), self.backend.recovers_by_itself, self.gate.active)
        self._report_error(f"backend fault while commanding (venting, going to the error state): {self.status.fault}")
        self._vent()
        if self.gate.active:
            self.trigger_deactivate()
        else:
            self.trigger_cleanup()
        self._publish_diagnostics()

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

    # -- parameters --------------------------------------------------------------------------
    def _check_value(self, name: str, value) -> str:
        """Why a new parameter value is refused ('' if it is not): the static checks, and a live compensation."""
        if name == "lag_compensation" and value and self.shaper is not None:
            refusal = self.shaper.compensation_refusal()
            if refusal:
                return f"lag_compensation: {refusal} (then configure again)"
        if name == "backend" and value and value not in BACKENDS:
            return f"backend: unknown backend {value!r}; expected '' (the rig's) or one of {sorted(BACKENDS)}."
        return ""

    def _apply_parameters(self, params) -> None:
        """Switch the lag compensation live; every other parameter waits for the next configure."""
        for param in params:
            if param.name == "lag_compensation" and self.shaper is not None:
                self.shaper.compensation = param.value
                self.get_logger().info(f"lag compensation {'on' if param.value else 'off'} "
                                       f"({self.shaper.map.describe()})")

    # -- services ----------------------------------------------------------------------------
    def _emergency_stop(self) -> operator.Answer:
        """Latch the e-stop and vent at once, in any state; a vent that fails is a backend fault."""
        self.gate.latch_estop()
        self._note_reason(OutputReason.ESTOP)
        self.get_logger().warning("EMERGENCY STOP latched: venting every valve until ~/reset")
        had_backend = self.backend is not None
        failure = self._vent()
        if failure is not None:
            self._on_backend_fault(failure)
        return operator.Answer(failure is None, operator.estop_message(
            self.gate, had_backend, self.status.fault if failure is not None else ""))

    def _answer(self, decide, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """A Trigger service: the operator's answer (:mod:`srs_ros.core.actuation.operator`) as the response."""
        answer = decide()
        if answer.warning:
            self.get_logger().warning(answer.warning)
        response.success, response.message = answer.success, answer.message
        return response

    # -- diagnostics -------------------------------------------------------------------------
    def _publish_diagnostics(self) -> None:
        """The status report on /diagnostics (1 Hz, in every state, and at once on a backend fault)."""
        setup = self._setup()
        report = self.status.report(time.monotonic(), setup, self.gate, self.shaper)
        # Named as the node runs (`__node` remap) and keyed by its full name, so that clients driving one robot of
        # several (e.g. `srs_sweep --namespace snake1`) read its own status from the shared /diagnostics.
        status = diagnostic_status(f"{self.get_name()}: actuators", setup.rig, report.level, report.message,
                                   {**report.values, STATUS_NODE_KEY: self.get_fully_qualified_name()})
        self.diagnostics_publisher.publish(diagnostic_array([status], self.get_clock().now().to_msg()))

    def _setup(self) -> NodeSetup:
        """What the node has open now, for the reports."""
        return NodeSetup(rig=self.rig.name if self.rig else "none",
                         backend=self.backend.name if self.backend else "none",
                         backend_open=bool(self.backend and self.backend.is_open),
                         lifecycle_state=self.lifecycle_label(), configured=self.configured)

    def lifecycle_label(self) -> str:
        """The lifecycle state label (unconfigured, inactive, active, ...)."""
        # rclpy's LifecycleNode keeps the state only in its state machine; no public getter in Jazzy.
        return self._state_machine.current_state[1]

    def _report_error(self, text: str) -> None:
        self.status.last_error = text
        self.get_logger().error(text)


def _describe(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


def release_and_report(node: HardwareNode, program: str) -> bool:
    """Vent and close at process exit and print the outcome (the vent, nothing to vent, or VENT FAILED)."""
    was_open = node.backend is not None
    vented = node.release_hardware()
    print(f"\n{exit_message(program, vented, was_open)}", flush=True)
    return vented


def main(args: list[str] | None = None) -> int:
    """``hardware_node``: spin until Ctrl-C, then vent and close the backend."""
    return run_node(HardwareNode, args, executor_factory=EventsExecutor,
                    on_shutdown=lambda node: release_and_report(node, NODE_NAME))


if __name__ == "__main__":
    raise SystemExit(main())
