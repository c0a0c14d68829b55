"""ROS wiring shared by every srs_ros node: topic names, QoS profiles, parameter declaration, main loop.

Topic graph (relative names, remappable with ``--ros-args -r``)::

    trajectory_server --gait_trajectory (JointTrajectory, reliable+transient_local)--> gait_player
    gait_player       --joint_setpoints (JointState, best effort)--> hardware_node
    hardware_node     --commanded_pressure_bar / command_voltage_v (Float64MultiArray, labelled)
                      --actuator_state (JointState), /diagnostics (DiagnosticArray)
    camera_tracker    --robot_pose (PoseStamped), robot_twist (TwistStamped), robot_path (Path)
"""

from __future__ import annotations

import gc
import math
import os
import signal
import sys
import time
import traceback
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

import rclpy
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import InvalidParameterValueException, ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from std_msgs.msg import Float64MultiArray, MultiArrayDimension

from srs_ros.core.errors import ConfigurationError, SrsError

TRAJECTORY_TOPIC = "gait_trajectory"
SETPOINT_TOPIC = "joint_setpoints"
COMMANDED_PRESSURE_TOPIC = "commanded_pressure_bar"
COMMAND_VOLTAGE_TOPIC = "command_voltage_v"
ACTUATOR_STATE_TOPIC = "actuator_state"
DIAGNOSTICS_TOPIC = "/diagnostics"
POSE_TOPIC = "robot_pose"
TWIST_TOPIC = "robot_twist"
PATH_TOPIC = "robot_path"


def latched_qos(depth: int = 1) -> QoSProfile:
    """Reliable + transient_local: late subscribers get the last message.

    ``ros2 topic echo`` needs ``--qos-durability transient_local`` to see it.
    """
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL)


def setpoint_qos(depth: int = 1) -> QoSProfile:
    """Best effort, volatile, depth 1: a stream where only the newest sample matters (no backlog after a stall)."""
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth, reliability=ReliabilityPolicy.BEST_EFFORT,
                      durability=DurabilityPolicy.VOLATILE)


@dataclass(frozen=True)
class ParameterSpec:
    """One declared parameter: default value, allowed range (inclusive) and description with unit."""

    name: str
    default: Any
    description: str
    minimum: float | int | None = None
    maximum: float | int | None = None
    read_only: bool = False
    additional_constraints: str = ""

    @property
    def is_double(self) -> bool:
        """True for a double parameter (a float default); it also accepts integers (:func:`declare_parameters`)."""
        return isinstance(self.default, float)

    def descriptor(self) -> ParameterDescriptor:
        """A ParameterDescriptor that rclpy enforces on every set (range, read-only)."""
        desc = ParameterDescriptor(name=self.name, description=self.description, read_only=self.read_only,
                                   additional_constraints=self.additional_constraints)
        if self.minimum is not None and self.maximum is not None and not isinstance(self.default, bool):
            if isinstance(self.default, int):
                desc.integer_range = [IntegerRange(from_value=int(self.minimum), to_value=int(self.maximum), step=1)]
            elif isinstance(self.default, float):
                desc.floating_point_range = [FloatingPointRange(from_value=float(self.minimum),
                                                                to_value=float(self.maximum), step=0.0)]
        return desc

    def check(self, value: Any) -> str:
        """Empty string if ``value`` is acceptable, else the reason (what was wrong, what is allowed)."""
        expected = type(self.default)
        if expected is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if not isinstance(value, expected) or (expected is not bool and isinstance(value, bool)):
            kind = "number (a double, e.g. 500.0)" if expected is float else expected.__name__
            return f"{self.name}: expected a {kind}, got {value!r}."
        if self.minimum is not None and self.maximum is not None and not isinstance(value, (bool, str)):
            if not (self.minimum <= value <= self.maximum):
                return f"{self.name}: {value} is outside [{self.minimum}, {self.maximum}] ({self.description})."
        return ""


def declare_parameters(node: Node, specs: Iterable[ParameterSpec]) -> dict[str, ParameterSpec]:
    """Declare every spec on ``node`` with its descriptor; return them by name. Once per node: all of them.

    A double parameter also takes an integer, converted to a double: at start-up
    (``-p rate_hz:=500``, a launch argument ``amplitude_bar:=3``) and at run time
    (``ros2 param set /gait_player rate_hz 500``). rclpy types parameters strictly and would refuse
    both; the value stored, published and checked against the range is always the double.

    The run-time conversion is a pre-set callback, and rclpy (7.1, Jazzy) concatenates the lists
    several such callbacks return: a second call would hand every parameter over twice, once still an
    integer, and the set would be refused. So a second call on the same node raises RuntimeError.
    """
    if getattr(node, "_srs_declared_parameters", None) is not None:
        raise RuntimeError(f"declare_parameters called twice on node {node.get_name()!r} (it declared "
                           f"{sorted(node._srs_declared_parameters)} already); expected one call with every "
                           "parameter of the node, since rclpy concatenates the outputs of several pre-set "
                           "callbacks and integers for doubles would then be refused.")
    by_name = {spec.name: spec for spec in specs}
    node._srs_declared_parameters = by_name
    doubles = frozenset(name for name, spec in by_name.items() if spec.is_double)
    # Start-up overrides are read by declare_parameter before any callback runs, so convert them here
    # (rclpy keeps them in Node._parameter_overrides and offers no public setter).
    overrides = getattr(node, "_parameter_overrides", {})
    for name in doubles & set(overrides):
        overrides[name] = integers_as_doubles(doubles, [overrides[name]])[0]
    for spec in by_name.values():
        node.declare_parameter(spec.name, spec.default, spec.descriptor())
    if doubles:
        node.add_pre_set_parameters_callback(partial(integers_as_doubles, doubles))
    return by_name


def startup_value(node: Node, spec: ParameterSpec) -> Any:
    """The value ``spec`` will be declared with: its start-up override (``-p``, a params file) or its default.

    For a node whose other parameters depend on one of them (e.g. a range from the robot file), read
    before the one :func:`declare_parameters` call. Raises ConfigurationError for a value of the wrong type.
    """
    override = getattr(node, "_parameter_overrides", {}).get(spec.name)
    value = spec.default if override is None else override.value
    reason = spec.check(value)
    if reason:
        raise ConfigurationError(f"invalid start-up parameter: {reason}")
    return float(value) if spec.is_double else value


def integers_as_doubles(names: frozenset[str], params: list[Parameter]) -> list[Parameter]:
    """``params`` with every integer value of a parameter in ``names`` turned into the equal double."""
    return [Parameter(p.name, Parameter.Type.DOUBLE, float(p.value))
            if p.name in names and p.type_ == Parameter.Type.INTEGER else p for p in params]


def check_parameters(specs: dict[str, ParameterSpec], params: Sequence,
                     extra_check: Callable[[str, Any], str] | None = None) -> SetParametersResult:
    """A set-parameters callback body: reject the whole set with a reason if any value is bad."""
    for param in params:
        spec = specs.get(param.name)
        reason = spec.check(param.value) if spec else ""
        if not reason and extra_check is not None:
            reason = extra_check(param.name, param.value)
        if reason:
            return SetParametersResult(successful=False, reason=reason)
    return SetParametersResult(successful=True)


def guard_parameter_services(node: Node) -> None:
    """Make malformed ``set_parameters`` requests refusals instead of the end of the node or a new parameter.

    rclpy's own parameter services raise on a value of an unknown type (e.g. type 99 sent by a broken
    or hostile client), and the exception stops the node's executor: for the hardware node, a vent and
    an exit. They also create a parameter named '' although the nodes declare every parameter they
    take. The guarded services answer such a parameter with ``successful=False`` and the reason, and
    handle every other parameter of the request as before.
    """
    from rcl_interfaces.srv import SetParameters

    def refusal(parameter) -> SetParametersResult | None:
        if not node.has_parameter(parameter.name):
            return SetParametersResult(successful=False, reason=f"{node.get_name()} has no parameter "
                                       f"{parameter.name!r}; `ros2 param list` shows them.")
        try:
            Parameter.from_parameter_msg(parameter)
        except (ValueError, TypeError) as exc:
            return SetParametersResult(successful=False, reason=f"{parameter.name}: malformed value refused "
                                       f"({type(exc).__name__}: {exc}); expected a value of a ROS parameter type.")
        return None

    def one_at_a_time(callback):
        def guarded(request, response):
            response.results = []
            for parameter in request.parameters:
                refused = refusal(parameter)
                response.results.append(refused or callback(SetParameters.Request(parameters=[parameter]),
                                                            SetParameters.Response()).results[0])
            return response
        return guarded

    def all_or_nothing(callback):
        def guarded(request, response):
            refused = next(filter(None, map(refusal, request.parameters)), None)
            if refused is not None:
                response.result = refused
                return response
            return callback(request, response)
        return guarded

    for service in node.services:
        if service.srv_name.endswith("/set_parameters"):
            service.callback = one_at_a_time(service.callback)
        elif service.srv_name.endswith("/set_parameters_atomically"):
            service.callback = all_or_nothing(service.callback)


def labelled_array(labels: Sequence[str], values) -> Float64MultiArray:
    """A Float64MultiArray whose one dimension is labelled with the comma-joined joint names."""
    msg = Float64MultiArray()
    msg.layout.dim = [MultiArrayDimension(label=",".join(labels), size=len(labels), stride=len(labels))]
    msg.data = [float(v) for v in values]
    return msg


def steady_timer(node: Node, period_s: float, callback: Callable[[], None], callback_group=None):
    """A timer on the steady (monotonic) clock: it keeps running whatever ROS time does.

    Safety timers (the setpoint watchdog, the keep-alive, the setpoint stream, diagnostics) use it: a
    timer on the node's ROS clock stops with ``use_sim_time`` and no ``/clock``, or jumps with the
    system clock, and would leave the last pressure on the valves.
    """
    return node.create_timer(period_s, callback, callback_group, clock=Clock(clock_type=ClockType.STEADY_TIME))


#: The parameter that puts a real-time node (gait_player, hardware_node) on the SCHED_FIFO scheduler.
REALTIME_PRIORITY = ParameterSpec(
    "realtime_priority", 0, "SCHED_FIFO priority 1-98 for every thread of this process, so CPU load cannot delay "
    "setpoints; 0 = the normal scheduler; needs an rtprio limit or CAP_SYS_NICE (README)", 0, 98, read_only=True)


def request_realtime_priority(priority: int, logger) -> bool:
    """Put every thread of this process (and those it starts later) on SCHED_FIFO at ``priority`` (1-98).

    Under CPU load the normal scheduler lets other processes delay the setpoint stream by tens of ms
    (benchmarks/bench_cpu_load.py); a real-time priority removes that. It needs the right to (an
    ``rtprio`` limit in /etc/security/limits.conf, or CAP_SYS_NICE): without it the node says so and
    runs on. The kernel's real-time throttling (95 % of each second) keeps a runaway thread from
    locking the machine. ``priority`` 0 does nothing. Returns True when the priority is in place.
    """
    if priority <= 0:
        return False
    try:
        for task in sorted(os.listdir("/proc/self/task")):
            try:
                os.sched_setscheduler(int(task), os.SCHED_FIFO, os.sched_param(priority))
            except ProcessLookupError:  # a thread that ended meanwhile
                continue
    except OSError as exc:
        logger.warning(f"realtime_priority {priority}: SCHED_FIFO refused ({exc.strerror}); running on the normal "
                       "scheduler, where CPU load can delay setpoints. Allow it with an rtprio limit (e.g. "
                       "'@realtime - rtprio 98' in /etc/security/limits.conf, user in group realtime) or "
                       "CAP_SYS_NICE, or set realtime_priority to 0.")
        return False
    logger.info(f"real-time scheduling: every thread on SCHED_FIFO priority {priority}")
    return True


class ShutdownSignals:
    """SIGINT and SIGTERM for a node process: the first asks for a clean shutdown; the rest are ignored.

    A terminal's Ctrl-C reaches every process of the group and ``ros2 launch`` sends its own SIGINT a
    few ms later, so each node gets two. rclpy's own handlers (which raise ``KeyboardInterrupt``
    anywhere, also inside the vent) are not installed (:func:`init_ros`); this handler only sets a
    flag that the spin loop polls and then ignores both signals for the rest of the process (also
    during interpreter exit, where Python would otherwise restore the default action and die by the
    signal). SIGKILL still ends a process that hangs.
    """

    def __init__(self) -> None:
        self.requested = ""  # the name of the first signal, once one came

    def install(self) -> None:
        """Handle SIGINT and SIGTERM from now on (main thread only)."""
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, self._handle)

    def _handle(self, signum: int, _frame) -> None:
        self.requested = self.requested or signal.Signals(signum).name
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, signal.SIG_IGN)


#: The process-wide shutdown request (signals reach only the main thread of one process).
SHUTDOWN = ShutdownSignals()


def init_ros(args: list[str] | None) -> None:
    """``rclpy.init`` for a node process, with :data:`SHUTDOWN` handling SIGINT/SIGTERM instead of rclpy.

    Raises :class:`ConfigurationError` when rcl cannot parse the ROS arguments (e.g. ``-p name:=[.nan, 1]``).
    """
    try:
        rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    except _rclpy.RCLError as exc:
        raise ConfigurationError(f"the ROS arguments cannot be parsed: {str(exc).strip()}") from None
    SHUTDOWN.install()


def run_node(node_factory: Callable[[], Node], args: list[str] | None = None, executor_factory=SingleThreadedExecutor,
             on_shutdown: Callable[[Node], None] | None = None) -> int:
    """``main()`` of every node: init, spin until Ctrl-C or shutdown, then clean up in order.

    ``on_shutdown(node)`` runs before the node is destroyed (e.g. to vent the hardware); no signal
    interrupts it.
    """
    outcome = CleanExit()
    with outcome:
        init_ros(args if args is not None else sys.argv)
    if outcome.exit_code:
        return outcome.exit_code
    node = None
    executor = executor_factory()
    try:
        with outcome:
            node = node_factory()
            guard_parameter_services(node)
            executor.add_node(node)
            outcome.started = True
            spin_until_shutdown(executor)
    finally:
        if node is not None and on_shutdown is not None:
            on_shutdown(node)
        executor.shutdown()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return outcome.exit_code


class CleanExit:
    """Context manager for the end of a node's main loop, holding its exit code.

    Ctrl-C or an external shutdown end it quietly (exit code 0). Before ``started`` is set, a start-up
    error (:data:`STARTUP_ERRORS`) prints the reason and what to do (exit code 2); after it, any
    exception is a failure while running: its traceback is printed with a line that says so (exit
    code 1) and the clean-up (vent) still runs.
    """

    def __init__(self) -> None:
        self.exit_code = 0
        self.started = False

    def __enter__(self) -> CleanExit:
        return self

    def __exit__(self, kind, exc, tb) -> bool:
        if kind is None:
            return False
        if issubclass(kind, (KeyboardInterrupt, ExternalShutdownException)):
            return True
        if not self.started and issubclass(kind, STARTUP_ERRORS):
            print(startup_error_text(exc), file=sys.stderr, flush=True)
            self.exit_code = 2
            return True
        if self.started and issubclass(kind, Exception):
            traceback.print_exception(kind, exc, tb, file=sys.stderr)
            print(f"stopped by an unexpected error while running: {type(exc).__name__}: {exc}; "
                  "cleaning up (venting) and exiting with status 1. Please report this.", file=sys.stderr, flush=True)
            self.exit_code = 1
            return True
        return False


def spin_until_shutdown(executor, duration_s: float = 0.0) -> None:
    """Spin until a shutdown signal, rclpy's shutdown or ``duration_s`` > 0 seconds, for any executor.

    A timed spin_once loop, not spin(): this rclpy's EventsExecutor.spin() never runs a callback.
    Objects made at start-up live for the whole run, so the cyclic GC is told to leave them alone
    (its pauses showed up as timer jitter in the setpoint stream).
    """
    end_s = time.monotonic() + duration_s if duration_s > 0 else math.inf
    gc.collect()
    gc.freeze()
    while rclpy.ok() and not SHUTDOWN.requested and time.monotonic() < end_s:
        executor.spin_once(timeout_sec=0.05)


#: Errors that mean "the node cannot start with this configuration" (exit code 2, no traceback).
STARTUP_ERRORS = (SrsError, InvalidParameterValueException, ParameterException)


def startup_error_text(exc: BaseException) -> str:
    """What to print when a node cannot start: the reason and what to do."""
    return (f"cannot start: {exc}\nFix the parameter (--ros-args -p name:=value or the params file) "
            "or the configuration file named above, then start again.")
