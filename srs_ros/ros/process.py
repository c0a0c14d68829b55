"""A node process from start to exit: init, the steady-clock timers, spinning, signals, real-time priority, errors.

Also the Python log records of the libraries a node drives (:func:`forward_python_logs`).
"""

from __future__ import annotations

import gc
import logging
import math
import os
import signal
import sys
import time
import traceback
from collections.abc import Callable

import rclpy
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import InvalidParameterValueException, NameValidationException, ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from srs_ros.core.errors import ConfigurationError, SrsError
from srs_ros.ros.parameters import guard_parameter_services


def steady_timer(node: Node, period_s: float, callback: Callable[[], None], callback_group=None):
    """A timer on the steady (monotonic) clock: it keeps running whatever ROS time does.

    Safety timers (the setpoint watchdog, the keep-alive, the setpoint stream, diagnostics) use it: a
    timer on the node's ROS clock stops with ``use_sim_time`` and no ``/clock``, or jumps with the
    system clock, and would leave the last pressure on the valves.
    """
    return node.create_timer(period_s, callback, callback_group, clock=Clock(clock_type=ClockType.STEADY_TIME))


def guard_services(node: Node) -> None:
    """Malformed or untimely requests to a node's standard services are refusals, never the end of the node.

    The parameter services as :func:`guard_parameter_services` says. A lifecycle node's ``~/change_state`` with a
    transition id that is not valid in the current state (what launch_ros's ``ChangeState`` event and ``ros2
    service call`` send: an id, no label) makes rclpy's state machine raise, which ended the hardware node (and
    srs_bringup with it) where rclcpp answers ``success: false``; a label is already checked by rclpy. Guarded, the
    request is answered ``success: false`` and the node stays in its state.
    """
    guard_parameter_services(node)
    for service in node.services:
        if service.srv_name.endswith("/change_state"):
            service.callback = _refusing_invalid_transitions(node, service.callback)


def _refusing_invalid_transitions(node: Node, callback):
    def guarded(request, response):
        try:
            return callback(request, response)
        except _rclpy.RCLError as exc:  # raised before any transition callback ran: the state is unchanged
            node.get_logger().warning(f"~/change_state refused transition id {request.transition.id} "
                                      f"{request.transition.label!r}: {str(exc).strip()}; "
                                      "`ros2 lifecycle list` shows the transitions available now")
            response.success = False
            return response
    return guarded


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


class _NodeLogHandler(logging.Handler):
    """Forwards Python log records to a node's logger (and so to /rosout)."""

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


def forward_python_logs(logger_name: str, node_logger) -> None:
    """Send the INFO and louder Python log records of ``logger_name`` to ``node_logger`` instead of stderr."""
    python_logger = logging.getLogger(logger_name)
    python_logger.addHandler(_NodeLogHandler(node_logger))
    python_logger.setLevel(logging.INFO)
    python_logger.propagate = False


class ShutdownSignals:
    """SIGINT and SIGTERM for a node process: the first asks for a clean shutdown; the rest are ignored.

    A terminal's Ctrl-C reaches every process of the group and ``ros2 launch`` sends its own SIGINT a
    few ms later, so each node gets two. rclpy's own handlers (which raise ``KeyboardInterrupt``
    anywhere, also inside the vent) are not installed (:func:`init_ros`); this handler only sets a
    flag that the spin loop polls; later signals find it set and change nothing. Once the node is cleaned
    up, :meth:`ignore_from_now` ignores both signals for the rest of the process (interpreter exit, where
    Python would otherwise restore the default action and die by the signal). Not earlier: a signal that
    arrived while the first one's handler waited to run (the main thread inside a timed ``spin_once``) would
    find its disposition changed to "ignore" and Python would print "Signal 15 ignored due to race
    condition" with a traceback (SIGINT then SIGTERM 5 ms apart, a helper's review). SIGKILL still ends a
    process that hangs.
    """

    def __init__(self) -> None:
        self.requested = ""  # the name of the first signal, once one came

    def install(self) -> None:
        """Handle SIGINT and SIGTERM from now on (main thread only)."""
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, self._handle)

    def _handle(self, signum: int, _frame) -> None:
        self.request(signal.Signals(signum).name)

    def request(self, reason: str) -> None:
        """Ask for the shutdown from the process itself (a worker thread that failed), as a signal would."""
        self.requested = self.requested or reason

    @staticmethod
    def ignore_from_now() -> None:
        """Ignore SIGINT and SIGTERM for the rest of the process (after the clean-up, before interpreter exit)."""
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
            guard_services(node)
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
        SHUTDOWN.ignore_from_now()
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
STARTUP_ERRORS = (SrsError, InvalidParameterValueException, ParameterException, NameValidationException)


def startup_error_text(exc: BaseException) -> str:
    """What to print when a node cannot start: the reason and what to do."""
    return (f"cannot start: {exc}\nFix the parameter (--ros-args -p name:=value or the params file) "
            "or the configuration file named above, then start again.")
