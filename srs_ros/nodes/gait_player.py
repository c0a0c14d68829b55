"""gait_player: streams the latched gait cycle as joint-length setpoints at a fixed rate.

Interface (relative names)::

    subscribes  gait_trajectory   trajectory_msgs/JointTrajectory   reliable + transient_local (latched)
    publishes   joint_setpoints   sensor_msgs/JointState            best effort; names m1_pma1..m3_pma3,
                                                                    position (m), velocity (m/s), stamp = now
                gait_phase        sensor_msgs/JointState            best effort, phase_rate_hz while streaming:
                                                                    the cycle's phase (position, cycles) and
                                                                    signed frequency (velocity, cycles/s)
    services    ~/start, ~/stop   std_srvs/Trigger
    parameters  rate_hz, cycles, amplitude_scale, frequency_hz, reverse, stop_at_phase, ramp_time_s, blend_time_s,
                autostart, zero_hold_s, phase_rate_hz, robot_description_file and realtime_priority (read-only)

Behaviour, as a robotics user expects it:

- Nothing is published before ``~/start`` (or ``autostart``, which starts when the first trajectory
  arrives). ``~/start`` ramps every length in from 0 over ``ramp_time_s`` (raised cosine), from phase 0.
- ``~/stop`` (or the end of ``cycles`` > 0 cycles) ramps out to 0 over ``ramp_time_s`` while the
  cycle keeps moving; then zero lengths are published for ``zero_hold_s`` so the hardware sees a
  clean 0, and then the stream ends (the hardware node vents when setpoints go stale anyway).
- ``amplitude_scale`` and ``frequency_hz`` (0 = the trajectory's own) change live, each over
  ``ramp_time_s``; the phase is integrated, so neither makes a setpoint jump. ``reverse`` plays the cycle
  backward in time (live: the signed frequency ramps through 0 over ``ramp_time_s``); a rolling cycle
  played backward rolls the other way (outward rolling is inward rolling reversed), which the navigator uses.
  ``cycles`` is read at ``~/start``: a ``~/start`` while running only sets the end ``cycles`` from now (the
  navigator's dead man's handle). ``rate_hz`` changes live (the timer is re-created).
- ``stop_at_phase`` (set while playing) ramps out as the phase next passes it, at most one cycle later: a
  rolling robot stopped at the same phase comes to rest at the same place, so the navigator stops it there
  however late its call arrives. ``~/stop`` stops at once, a pending phase stop or not.
- A new trajectory cross-fades from the old one over ``blend_time_s`` at the same phase.
- The phase follows the monotonic clock, or with ``use_sim_time`` the ROS clock (the simulated world's
  ``/clock``, so a simulation that runs slower than real time still sees the gait's own frequency); after
  a stall longer than 50 ms (or two setpoint periods, below 40 Hz) it advances by that much only, so a late tick
  never makes the setpoint jump.

The playback logic lives in :mod:`srs_ros.core.gait.playback`; this node is the ROS wiring around it.
"""

from __future__ import annotations

import math
import time
from typing import Any

from rcl_interfaces.msg import SetParametersResult
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory

from srs_ros.core.errors import ConfigurationError, SrsError
from srs_ros.core.gait.playback import (
    MAX_TRAJECTORY_POINTS,
    GaitPlayback,
    PlaybackState,
    cycle_from_points,
    frequency_refusal,
)
from srs_ros.core.ramp import DEFAULT_RAMP_TIME_S
from srs_ros.core.robot import CYCLE_FREQUENCY_RANGE_HZ, load_robot
from srs_ros.ros.interfaces import (
    GAIT_PHASE_TOPIC,
    SETPOINT_TOPIC,
    TRAJECTORY_TOPIC,
    gait_phase_message,
    latched_qos,
    setpoint_qos,
    stamp_to_seconds,
)
from srs_ros.ros.parameters import REALTIME_PRIORITY, ParameterSpec, check_parameters, declare_parameters
from srs_ros.ros.process import request_realtime_priority, run_node, steady_timer

#: Largest phase step per tick, or two tick periods at a rate under 40 Hz: a stalled process resumes where it was
#: instead of jumping ahead (capped at 0.05 s, a 10 Hz stream played every gait at half its frequency).
MAX_STEP_S = 0.05
#: A setpoint's stamp and its phase time are read again when more than this apart (s): the process was paused.
CLOCK_PAIR_S = 1e-3
#: Largest serialized trajectory taken (bytes): MAX_TRAJECTORY_POINTS points of up to four arrays of nine
#: doubles (CDR: a 4-byte length, 4 bytes of padding, 72 bytes) and a duration (8 bytes) each, plus the header.
#: Checked before deserializing, which for a 100k-point message would hold the interpreter for 0.7 s and starve the
#: setpoint stream. (320 bytes a point refused a full 2049-point trajectory of 672,204 bytes.)
MAX_TRAJECTORY_BYTES = MAX_TRAJECTORY_POINTS * (4 * 80 + 8) + 4096

PARAMETERS = (
    # 10 Hz = two setpoints per 0.2 s, the shipped rigs' setpoint timeout (a slower stream makes the valves pulse).
    ParameterSpec("rate_hz", 200.0, "setpoint rate in Hz (live); at least two per the hardware's setpoint timeout",
                  10.0, 1000.0),
    ParameterSpec("cycles", 0, "cycles to play after ~/start, then ramp out; 0 = forever (read at ~/start)",
                  0, 1_000_000),
    ParameterSpec("amplitude_scale", 1.0, "scale of every length, 0..1 (live, reached over ramp_time_s)", 0.0, 1.0),
    ParameterSpec("frequency_hz", 0.0, "playback frequency in Hz, 0 = the trajectory's own, else at least "
                  f"{CYCLE_FREQUENCY_RANGE_HZ[0]:g} Hz (live)",
                  0.0, CYCLE_FREQUENCY_RANGE_HZ[1]),
    ParameterSpec("reverse", False, "play the cycle backward in time (live; the signed frequency ramps through 0 "
                  "over ramp_time_s): a rolling gait rolls the other way"),
    ParameterSpec("stop_at_phase", -1.0, "set while playing: ramp out as the cycle's phase next passes this "
                  "phase (0..1, at most one cycle later; the navigator stops the robot exactly at a set phase "
                  "however late its call); -1 = none; ~/stop still stops at once (live)", -1.0, 1.0),
    ParameterSpec("ramp_time_s", DEFAULT_RAMP_TIME_S, "soft start/stop and live-change duration in s", 0.05, 60.0),
    ParameterSpec("blend_time_s", 0.5, "cross-fade duration in s when a new trajectory takes over", 0.05, 10.0),
    ParameterSpec("autostart", False, "start as soon as the first trajectory arrives"),
    ParameterSpec("phase_rate_hz", 50.0, "gait_phase messages per second while streaming (the navigator stops the "
                  "robot at set phases of the cycle); 0 = none (live)", 0.0, 1000.0),
    ParameterSpec("zero_hold_s", 0.5, "zero lengths are published this long after a ramp-out, in s", 0.0, 10.0),
    ParameterSpec("robot_description_file", "", "robot description YAML; '' = the package's config/robot.yaml",
                  read_only=True),
    REALTIME_PRIORITY,
)


class GaitPlayer(Node):
    """ROS wiring of :class:`GaitPlayback`: trajectory in, timed JointState setpoints out."""

    def __init__(self, **kwargs):
        super().__init__("gait_player", **kwargs)
        self._specs = declare_parameters(self, PARAMETERS)
        initial = self._check_parameters([self.get_parameter(name) for name in self._specs])
        if not initial.successful:  # checked as a set would be: -p stop_at_phase:=-0.5 started and meant nothing
            raise ConfigurationError(f"gait_player: invalid start-up parameter: {initial.reason}")
        if self._param("stop_at_phase") >= 0.0:
            self.get_logger().warning(f"stop_at_phase {self._param('stop_at_phase'):g} at start-up does nothing: it "
                                      "is set while playing (after ~/start) and ramps out as the phase passes it")
        request_realtime_priority(self._param("realtime_priority"), self.get_logger())
        self._robot = load_robot(self._param("robot_description_file") or None)
        self._playback = GaitPlayback(self._param("ramp_time_s"), self._param("blend_time_s"),
                                      max_length_m=self._robot.max_extension_m)
        self._playback.set_amplitude_scale(self._param("amplitude_scale"))
        self._playback.set_frequency_override(self._param("frequency_hz"))
        self._playback.set_reverse(self._param("reverse"))
        self._zeros_until = 0.0
        self._sim_time = bool(self.get_parameter("use_sim_time").value)
        self._last_tick = self._read_clocks()[2]
        self._message = JointState()
        self.published_count = 0  # setpoints published since start-up (printed at exit, for loss checks)
        self._message.name = list(self._robot.joint_names)

        self.add_on_set_parameters_callback(self._check_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        self._publisher = self.create_publisher(JointState, SETPOINT_TOPIC, setpoint_qos())
        self._phase_publisher = self.create_publisher(JointState, GAIT_PHASE_TOPIC, setpoint_qos())
        self._phase_period_s = self._period(self._param("phase_rate_hz"))
        self._phase_due = 0.0 if math.isfinite(self._phase_period_s) else math.inf  # steady s of the next one
        self.create_subscription(JointTrajectory, TRAJECTORY_TOPIC, self._on_trajectory, latched_qos(), raw=True)
        self.create_service(Trigger, "~/start", self._on_start)
        self.create_service(Trigger, "~/stop", self._on_stop)
        self._timer = None
        self._set_rate(self._param("rate_hz"))
        self.get_logger().info(
            f"streaming {SETPOINT_TOPIC} at {self._param('rate_hz'):g} Hz once started; waiting for "
            f"{TRAJECTORY_TOPIC} (autostart={self._param('autostart')})")

    def _param(self, name: str) -> Any:
        return self.get_parameter(name).value

    # ------------------------------------------------------------- parameters
    def _check_parameters(self, params) -> SetParametersResult:
        result = check_parameters(self._specs, params)
        for param in params if result.successful else ():
            if param.name == "stop_at_phase" and -1.0 < float(param.value) < 0.0:  # (-1, 0) meant "none" silently
                return SetParametersResult(successful=False, reason=f"stop_at_phase {param.value:g}: expected a phase "
                                                                    "in [0, 1], or -1 for none")
            if param.name == "frequency_hz" and 0.0 < float(param.value) < CYCLE_FREQUENCY_RANGE_HZ[0]:
                return SetParametersResult(successful=False, reason=frequency_refusal(float(param.value)))
        return result

    def _apply_parameters(self, params) -> None:
        for param in params:
            if param.name == "amplitude_scale":
                self._playback.set_amplitude_scale(param.value)
            elif param.name == "frequency_hz":
                self._playback.set_frequency_override(param.value)
            elif param.name == "reverse":
                self._playback.set_reverse(param.value)
            elif param.name == "stop_at_phase":
                self._stop_at_phase(float(param.value))
            elif param.name == "ramp_time_s":
                self._playback.set_ramp_time(param.value)
            elif param.name == "blend_time_s":
                self._playback.set_blend_time(param.value)
            elif param.name == "phase_rate_hz":
                self._phase_period_s = self._period(param.value)
                self._phase_due = 0.0 if math.isfinite(self._phase_period_s) else math.inf  # 0 = none: not one
            elif param.name == "rate_hz":
                self._set_rate(float(param.value))

    def _stop_at_phase(self, phase: float) -> None:
        playing = self._playback.state in (PlaybackState.STARTING, PlaybackState.RUNNING)
        self._playback.stop_at_phase(phase % 1.0 if phase >= 0.0 and playing else None)
        if phase >= 0.0 and playing:
            self.get_logger().info(f"ramping out as the phase passes {phase % 1.0:g} (at most one cycle from now)")
        elif phase >= 0.0:  # taken (the navigator sets it as it stops), but it arms nothing: say so
            self.get_logger().warning(f"stop_at_phase {phase:g} ignored: the gait is {self._playback.state.value}; "
                                      "set it while playing (after ~/start)")

    def _set_rate(self, rate_hz: float) -> None:
        """The setpoint timer at ``rate_hz``, and the largest phase step of a tick with it (:data:`MAX_STEP_S`)."""
        if self._timer is not None:
            self.destroy_timer(self._timer)
        self._timer = steady_timer(self, 1.0 / rate_hz, self._on_tick)
        self._max_step_s = max(MAX_STEP_S, 2.0 / rate_hz)

    @staticmethod
    def _period(rate_hz: float) -> float:
        return 1.0 / rate_hz if rate_hz > 0 else math.inf

    # ------------------------------------------------------------- inputs
    def _on_trajectory(self, serialized: bytes) -> None:
        if len(serialized) > MAX_TRAJECTORY_BYTES:
            self.get_logger().error(f"ignored the trajectory on {TRAJECTORY_TOPIC}: {len(serialized)} bytes, more than "
                                    f"{MAX_TRAJECTORY_BYTES} ({MAX_TRAJECTORY_POINTS} points); send one period of at "
                                    "most that many points. The previous trajectory (if any) keeps playing.")
            return
        try:
            self._take_trajectory(deserialize_message(serialized, JointTrajectory))
        except Exception as exc:  # a malformed message must never stop the stream
            self.get_logger().error(f"ignored the trajectory on {TRAJECTORY_TOPIC} (unexpected error, please report): "
                                    f"{type(exc).__name__}: {exc}. The previous trajectory (if any) keeps playing.")

    def _take_trajectory(self, msg: JointTrajectory) -> None:
        if not (5 <= len(msg.points) <= MAX_TRAJECTORY_POINTS):  # before any per-point work
            self.get_logger().error(f"ignored the trajectory on {TRAJECTORY_TOPIC}: {len(msg.points)} points; expected "
                                    f"5 to {MAX_TRAJECTORY_POINTS}. The previous trajectory (if any) keeps playing.")
            return
        times = [stamp_to_seconds(p.time_from_start) for p in msg.points]
        try:
            samples, frequency_hz = cycle_from_points(
                msg.joint_names, times, [p.positions for p in msg.points], self._robot.joint_names,
                self._robot.max_extension_m)
            was_idle = self._playback.state is PlaybackState.IDLE
            first = not self._playback.has_cycle
            self._playback.load(samples, frequency_hz)
        except SrsError as exc:
            self.get_logger().error(f"ignored the trajectory on {TRAJECTORY_TOPIC}: {exc} "
                                    "The previous trajectory (if any) keeps playing.")
            return
        how = "loaded" if was_idle else f"taking over with a {self._playback.blend_time_s:g} s cross-fade"
        self.get_logger().info(f"trajectory {how}: {samples.shape[0]} samples, {frequency_hz:g} Hz")
        if first and self._param("autostart"):
            self._start()

    def _start(self) -> str:
        cycles = int(self._param("cycles"))
        state = self._playback.state
        self._playback.start(cycles)
        if state is PlaybackState.RUNNING:
            return "already running" + (f"; ramps out after {cycles} more cycles" if cycles else "")
        text = (f"starting: ramp in over {self._playback.ramp_time_s:g} s, "
                f"{self._playback.frequency_hz:g} Hz, " + (f"{cycles} cycles" if cycles else "until ~/stop"))
        self.get_logger().info(text)
        return text

    def _on_start(self, _request, response):
        if not self._playback.has_cycle:
            response.success = False
            response.message = (f"no trajectory received on {self.resolve_topic_name(TRAJECTORY_TOPIC)} yet; "
                                "start trajectory_server (or call its ~/regenerate), then call ~/start again")
            return response
        response.success, response.message = True, self._start()
        return response

    def _on_stop(self, _request, response):
        if self._playback.state in (PlaybackState.IDLE, PlaybackState.STOPPING):
            response.success, response.message = True, f"already {self._playback.state.value}"
            return response
        self._playback.stop()
        response.success = True
        response.message = f"stopping: ramp out over {self._playback.ramp_time_s:g} s"
        self.get_logger().info(response.message)
        return response

    # ------------------------------------------------------------- output
    def _read_clocks(self):
        """The ROS clock's time (the stamp), the steady clock's (s) and the phase's clock (s), read together.

        The phase follows ROS time with use_sim_time (the world's /clock), else the steady clock.

        A pause of the process between two readings would date the setpoint away from the instant its phase
        is computed for (a jump against its stamps, seen once in a loaded suite).
        """
        for _ in range(3):
            before_s = time.monotonic()
            stamp = self.get_clock().now()
            now_s = time.monotonic()
            if now_s - before_s < CLOCK_PAIR_S:
                break
        return stamp, now_s, stamp.nanoseconds * 1e-9 if self._sim_time else now_s

    def _on_tick(self) -> None:
        stamp, now, phase_s = self._read_clocks()  # the instant this setpoint is computed for, on every clock
        dt_s = min(max(phase_s - self._last_tick, 0.0), self._max_step_s)
        self._last_tick = phase_s
        if not self._playback.has_cycle:
            return
        before = self._playback.state
        setpoint = self._playback.step(dt_s)
        if setpoint.state is PlaybackState.IDLE:
            if before is not PlaybackState.IDLE:
                self._zeros_until = now + self._param("zero_hold_s")
                self.get_logger().info("stopped: ramp-out done, holding zero lengths")
            if now > self._zeros_until:
                return
        msg = self._message
        msg.header.stamp = stamp.to_msg()
        msg.position = setpoint.positions_m.tolist()
        msg.velocity = setpoint.velocities_m_per_s.tolist()
        self._publisher.publish(msg)
        self.published_count += 1
        if now >= self._phase_due:
            self._phase_due = max(self._phase_due + self._phase_period_s, now)
            self._phase_publisher.publish(gait_phase_message(msg.header.stamp, setpoint.phase, setpoint.frequency_hz,
                                                             setpoint.cycles_done))

    @property
    def playback(self) -> GaitPlayback:
        """The playback state (for an in-process bringup's status line)."""
        return self._playback


def main(args: list[str] | None = None) -> int:
    """Console script ``gait_player``."""
    return run_node(GaitPlayer, args, executor_factory=EventsExecutor, on_shutdown=_report_count)


def _report_count(player: GaitPlayer) -> None:
    print(f"gait_player: published {player.published_count} setpoints", flush=True)


if __name__ == "__main__":
    raise SystemExit(main())
