"""trajectory_server: fits one gait cycle on request and latches it as a JointTrajectory.

Interface (relative names)::

    publishes   gait_trajectory   trajectory_msgs/JointTrajectory   reliable + transient_local (latched)
    services    ~/regenerate      std_srvs/Trigger
    parameters  gait, amplitude_bar, frequency_hz, samples, generate_on_start, reject_poor_fit,
                <gait>.<parameter> for every gait of config/gaits.yaml (e.g. serpentine.body_wavelengths),
                robot_description_file (read-only)

The trajectory holds one period: ``samples + 1`` points, point ``i`` at ``time_from_start = i / (samples *
frequency_hz)``, the last repeating the first to close the cycle; positions are actuator length changes
in metres (joint names ``m1_pma1 .. m3_pma3``), velocities in m/s.

Parameters take effect at the next ``~/regenerate`` (one is run at start-up unless
``generate_on_start`` is false). The last :data:`CACHED_CYCLES` cycles are kept: a request equal to one of
them is published again without a new fit (the navigator switches between a few turn levels several
times a minute; a rolling cycle costs 0.03 s to fit on an idle core, 0.2-0.7 s on a loaded one).
A request that cannot be fitted answers ``success=false`` with the reason, and the last good trajectory
stays latched. Samples whose fit error exceeds the gait's ``poor_fit_mm`` are listed in the response (a
constant-curvature body cannot follow a serpenoid exactly): with ``reject_poor_fit`` true such a cycle is
refused like a failure; by default it is published with a WARNING in the response and the log. The fit runs
on a reentrant callback group of a multi-threaded executor, so parameter services keep answering and a
second ``~/regenerate`` during a fit is answered at once with "busy".
"""

from __future__ import annotations

import threading
import time
import warnings
from collections import OrderedDict
from typing import Any

import numpy as np
from rcl_interfaces.msg import SetParametersResult
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from srs_ros.core.errors import ConfigurationError, SrsError
from srs_ros.core.gait.request import FREQUENCY_FIELD, SAMPLES_FIELD, gait_field
from srs_ros.core.gait.trajectory import PoorFitWarning, generate_cycle, list_gaits
from srs_ros.core.robot import RobotDescription, amplitude_field, load_robot
from srs_ros.ros.interfaces import FIT_BUSY_PREFIX, TRAJECTORY_TOPIC, latched_qos, nanoseconds_to_duration
from srs_ros.ros.parameters import ParameterSpec, check_parameters, declare_parameters, startup_value
from srs_ros.ros.process import run_node

#: Longest wait at shutdown for a running fit to finish before the node is destroyed.
SHUTDOWN_WAIT_S = 30.0
#: Fitted cycles kept for requests that come again (by gait, amplitude, frequency, samples and gait parameters).
CACHED_CYCLES = 32

ROBOT_FILE = ParameterSpec("robot_description_file", "",
                           "robot description YAML; '' = the package's config/robot.yaml", read_only=True)


def base_parameters(robot: RobotDescription, gait_names: list[str]) -> tuple[ParameterSpec, ...]:
    """The request parameters (:mod:`srs_ros.core.gait.request`); ``amplitude_bar`` is capped by the robot's limit."""
    return (
        *(ParameterSpec.from_field(f) for f in (gait_field(gait_names), amplitude_field(robot), FREQUENCY_FIELD,
                                                SAMPLES_FIELD)),
        ParameterSpec("generate_on_start", True, "fit and publish once at start-up"),
        ParameterSpec("reject_poor_fit", False,
                      "refuse a cycle with poor samples (false: publish it and report them as a warning)"),
    )


def gait_parameters(gaits: dict) -> tuple[ParameterSpec, ...]:
    """One ``<gait>.<parameter>`` spec per parameter of every gait, with its range and unit."""
    return tuple(ParameterSpec.from_field(p.field, name=f"{name}.{p.name}")
                 for name, spec in gaits.items() for p in spec.parameters)


def _listing(indices, shown: int = 12) -> str:
    """``[1, 2, 3]``, ``[1, ..., 12, ...] (40 in all)`` or ``none``."""
    if not indices:
        return "none"
    more = f", ...] ({len(indices)} in all)" if len(indices) > shown else "]"
    return "[" + ", ".join(str(i) for i in indices[:shown]) + more


def trajectory_message(cycle, stamp) -> JointTrajectory:
    """One closed period of ``cycle`` (lengths (N, D) at phase i/N) as a JointTrajectory."""
    lengths = np.asarray(cycle.lengths_m, dtype=np.float64)
    count = lengths.shape[0]
    period_ns = round(1e9 / cycle.frequency_hz)
    slopes = cycle.velocities_at(np.arange(count) / count)
    msg = JointTrajectory()
    msg.header.stamp = stamp
    msg.joint_names = list(cycle.joint_names)
    for i in range(count + 1):
        t_ns = period_ns * i // count
        point = JointTrajectoryPoint()
        point.positions = lengths[i % count].tolist()
        point.velocities = slopes[i % count].tolist()
        point.time_from_start = nanoseconds_to_duration(t_ns)
        msg.points.append(point)
    return msg


class TrajectoryServer(Node):
    """ROS wiring of :func:`srs_ros.core.gait.trajectory.generate_cycle`: parameters in, latched trajectory out."""

    def __init__(self, **kwargs):
        super().__init__("trajectory_server", **kwargs)
        self._gaits = list_gaits()
        # amplitude_bar's range is the robot's limit: read the robot file first, then declare all in one call
        self._robot = load_robot(startup_value(self, ROBOT_FILE) or None)
        specs = (ROBOT_FILE, *base_parameters(self._robot, sorted(self._gaits)),
                 *gait_parameters(self._gaits))
        self._specs = declare_parameters(self, specs)
        self.add_on_set_parameters_callback(self._check_parameters)
        initial = self._check_parameters([self.get_parameter(name) for name in self._specs])
        if not initial.successful:
            raise ConfigurationError(f"trajectory_server: invalid start-up parameter: {initial.reason}")

        self._fit_lock = threading.Lock()
        self._fit_started: tuple[float, str] = (0.0, "")
        self._last_good = ""
        self._cycles: OrderedDict[str, Any] = OrderedDict()  # request -> fitted cycle, the newest last
        self._group = ReentrantCallbackGroup()
        self._publisher = self.create_publisher(JointTrajectory, TRAJECTORY_TOPIC, latched_qos())
        # Every call gets an answer ("busy" at once while a fit runs): a deep request queue, so a burst of
        # calls beyond rclpy's default depth of 10 is not dropped unanswered.
        self.create_service(Trigger, "~/regenerate", self._on_regenerate, callback_group=self._group,
                            qos_profile=QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE))
        self._startup_timer = None
        if self.get_parameter("generate_on_start").value:
            # A group of its own, mutually exclusive: in the reentrant one a second thread took the 0 s timer again
            # before the first callback cancelled it, and rcl refused the cancelled timer: the node died at start
            # ("failed to call timer: timer is canceled", seen once in a full suite run).
            self._startup_timer = self.create_timer(0.0, self._on_startup,
                                                    callback_group=MutuallyExclusiveCallbackGroup())
        self.get_logger().info(f"gaits: {sorted(self._gaits)}; call ~/regenerate after changing parameters")

    # ------------------------------------------------------------- parameters
    def _check_parameters(self, params) -> SetParametersResult:
        return check_parameters(self._specs, params)

    def _request(self) -> dict[str, Any]:
        """The fit request from the current parameters (read once, so a fit sees one consistent set)."""
        gait = self.get_parameter("gait").value
        params = {name: p.value for name, p in self.get_parameters_by_prefix(gait).items()}
        return {"gait": gait, "amplitude_bar": self.get_parameter("amplitude_bar").value,
                "frequency_hz": self.get_parameter("frequency_hz").value,
                "samples": self.get_parameter("samples").value, "robot": self._robot, "params": params}

    # ------------------------------------------------------------- fitting
    def regenerate(self) -> tuple[bool, str]:
        """Fit and publish the cycle for the current parameters; (success, what happened)."""
        if not self._fit_lock.acquire(blocking=False):
            started_s, what = self._fit_started
            return False, (f"{FIT_BUSY_PREFIX} a fit of {what} is running for {time.monotonic() - started_s:.1f} s; "
                           "try again when it finishes")
        try:
            request = self._request()
            what = f"{request['gait']} at {request['amplitude_bar']:g} bar, {request['frequency_hz']:g} Hz"
            self._fit_started = (time.monotonic(), what)
            try:
                cycle, cached = self._cycle(request)
            except (SrsError, ValueError, ArithmeticError) as exc:
                return False, f"fit of {what} failed: {str(exc).rstrip('.')}; {self._kept()}"
            elapsed_s = time.monotonic() - self._fit_started[0]
            errors = np.asarray(cycle.fit_error_mm, dtype=np.float64)
            quality = (f"{len(errors)} samples, fit error mean {errors.mean():.2f} mm, worst {errors.max():.2f} mm, "
                       f"poor samples {_listing(cycle.poor_samples)}")
            if not self.context.ok():
                return False, f"fit of {what} discarded: the node is shutting down"
            if not cycle.ok and self.get_parameter("reject_poor_fit").value:
                return False, f"fit of {what} refused, reject_poor_fit is true ({quality}); {self._kept()}"
            self._publisher.publish(trajectory_message(cycle, self.get_clock().now().to_msg()))
            self._last_good = what
            warning = "" if cycle.ok else "WARNING: poor samples do not follow the gait shape; "
            how = "the same request's cycle, kept from before" if cached else f"fitted in {elapsed_s:.1f} s"
            return True, f"{warning}published {what} on {self._publisher.topic_name} ({quality}; {how})"
        finally:
            self._fit_lock.release()

    def _cycle(self, request: dict[str, Any]) -> tuple[Any, bool]:
        """The fitted cycle of ``request`` and whether it came from the cache (the last CACHED_CYCLES fits)."""
        key = repr([(name, sorted(value.items()) if isinstance(value, dict) else value)
                    for name, value in sorted(request.items()) if name != "robot"])
        if key in self._cycles:
            self._cycles.move_to_end(key)
            return self._cycles[key], True
        with warnings.catch_warnings():  # poor samples are reported in the response instead
            warnings.simplefilter("ignore", PoorFitWarning)
            cycle = generate_cycle(**request)
        self._cycles[key] = cycle
        while len(self._cycles) > CACHED_CYCLES:
            self._cycles.popitem(last=False)
        return cycle, False

    def _kept(self) -> str:
        if self._last_good:
            return f"the last good trajectory ({self._last_good}) stays published"
        return "no trajectory has been published yet"

    def _on_regenerate(self, _request, response):
        response.success, response.message = self.regenerate()
        self._log(response.success, f"~/regenerate: {response.message}")
        return response

    def _on_startup(self) -> None:
        self._startup_timer.cancel()
        success, message = self.regenerate()
        self._log(success, f"start-up fit: {message}")

    def _log(self, success: bool, text: str) -> None:
        # rclpy refuses two severities from one call site, hence one line per severity.
        if not success:
            self.get_logger().error(text)
        elif "WARNING" in text:
            self.get_logger().warning(text)
        elif "kept from before" in text:  # a repeat (the navigator's turn levels): said once a minute at most
            self.get_logger().info(text, throttle_duration_sec=60.0)
        else:
            self.get_logger().info(text)

    def wait_for_fit(self, timeout_s: float = SHUTDOWN_WAIT_S) -> bool:
        """Block until no fit is running (True) or ``timeout_s`` passed (False)."""
        if self._fit_lock.acquire(timeout=timeout_s):
            self._fit_lock.release()
            return True
        return False


def main(args: list[str] | None = None) -> int:
    """Console script ``trajectory_server``."""
    return run_node(TrajectoryServer, args, executor_factory=lambda: MultiThreadedExecutor(num_threads=3),
                    on_shutdown=lambda node: node.wait_for_fit())


if __name__ == "__main__":
    raise SystemExit(main())
