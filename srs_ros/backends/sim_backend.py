"""The ``sim`` backend: regulator commands over a DDS topic to the ``sim_world`` node, as frames to a DAC board.

The simulated robot runs in its own node (``sim_world``, MuJoCo). This backend drives it the way the
``can`` backend drives a regulator board: every command (already through the one clamp) is published on a
reliable, depth-1 command topic that acts as the bus, and the world answers on a monitor topic with the
regulators' pressure read-back and the muscles' lengths (a simulated rig can measure them).

A simulator is not a board: it runs on a shared computer and stalls now and then (CPU load, a debugger,
SIGSTOP). So its silence has two meanings (docs/simulation.md, docs/safety.md):

- a *short* silence (more than ``readback_timeout_s``, less than ``world_lost_timeout_s``) is a pause:
  :meth:`SimBackend.holding_reason` says so, the hardware node vents (0 bar on the bus) and ramps back in
  by itself when the world answers again, as after stale setpoints;
- a *long* silence (``world_lost_timeout_s``) heard by a listening bus, no first answer within
  ``startup_timeout_s``, or the world gone from the ROS graph is a :class:`~srs_ros.core.errors.HardwareError`,
  as a dead board: vent, error state, /diagnostics. A silence counts as long only while the backend's own bus
  thread was there to hear it (from its last return after a hold-up): on a busy machine the thread that receives
  the read-back can itself be held up while the control loop goes on, and the world is not lost for that (a pause
  meanwhile: the output holds). Any silence of ``BUS_DEAF_TIMEOUT_S`` (10 s, at least ``world_lost_timeout_s``)
  is a lost world however often the bus was held up.
  The simulated rig then recovers by itself (``recovers_by_itself``): the hardware node configures and
  activates again and holds 0 bar until the world answers.

``sim_world`` itself vents like a real board when commands stop for :data:`SIM_BOARD_TIMEOUT_S` of world
time, so a hardware node that dies leaves the simulated robot at rest (``host_loss_timeout_s``).

The bus is rclpy: the backend owns a small node (``sim_backend_bus``, in the process's default context, with
the process's namespace and remappings, so ``__ns:=/snake1`` moves its topics with every other node of the
process) and spins it on its own thread with timed ``spin_once`` calls, as python-can's buses own a receive
thread.

Options (``backend_options`` of a rig file, each validated with the key named on error):

- ``command_topic`` (default ``sim/regulator_command``): sensor_msgs/JointState, ``effort`` = pressure (bar);
- ``monitor_topic`` (default ``sim/regulator_monitor``): sensor_msgs/JointState from the world,
  ``effort`` = measured pressure (bar), ``position`` = muscle length (m);
- ``readback_timeout_s`` (default 0.2, in [0.02, 5]): the world silent this long -> vent and hold (a pause);
- ``world_lost_timeout_s`` (default 2, in [0.1, 60], at least ``readback_timeout_s``): silent this long ->
  HardwareError;
- ``startup_timeout_s`` (default 15, in [0.1, 120]): how long after ``open`` the world may take to answer
  for the first time (it may start after the hardware node); output holds at 0 bar meanwhile.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Mapping
from typing import Any

import numpy as np

from srs_ros.backends.base import ActuatorBackend
from srs_ros.core.errors import HardwareError
from srs_ros.core.robot import RobotDescription
from srs_ros.core.schema import Field, Table, refusal
from srs_ros.ros.interfaces import SIM_BOARD_TIMEOUT_S, SIM_COMMAND_TOPIC, SIM_MONITOR_TOPIC, bus_qos, readback_qos
from srs_ros.sim.realtime import ReceiverWatch

#: The node name of the backend's bus (under the process's namespace).
BUS_NODE_NAME = "sim_backend_bus"
#: The bus thread silent this long (s; dead, or starved of CPU) counts as a lost world whatever it last heard; so does
#: a silence this long however often the bus was held up (at least ``world_lost_timeout_s``).
BUS_DEAF_TIMEOUT_S = 10.0
#: How long closing the bus waits for the world to acknowledge the last command (the vent), s.
VENT_ACK_TIMEOUT_S = 0.5

_LOG = logging.getLogger(__name__)

#: Where an option error says it is.
WHERE = "sim backend_options"
#: The options of the sim backend (``backend_options`` of a rig file).
SIM_OPTIONS = Table("", (
    Field("command_topic", str, SIM_COMMAND_TOPIC, nonempty=True, description="the bus to sim_world (pressures)"),
    Field("monitor_topic", str, SIM_MONITOR_TOPIC, nonempty=True, description="sim_world's read-back"),
    Field("readback_timeout_s", float, 0.2, 0.02, 5.0, "s", "the world silent this long: vent and hold (a pause)"),
    Field("world_lost_timeout_s", float, 2.0, 0.1, 60.0, "s", "silent this long: HardwareError"),
    Field("startup_timeout_s", float, 15.0, 0.1, 120.0, "s", "how long the world may take to answer first"),
), description="a mapping of option: value")


def _check_topic_name(key: str, name: str) -> None:
    from rclpy.exceptions import InvalidTopicNameException
    from rclpy.validate_topic_name import validate_topic_name

    try:
        validate_topic_name(name)
    except InvalidTopicNameException as exc:
        reason = str(exc).splitlines()[0].removeprefix("Invalid topic name: ")
        raise refusal(WHERE, key, name, f"a ROS topic name ({reason})") from None


class SimBackend(ActuatorBackend):
    """Commands to ``sim_world`` over DDS, read-back from it; a pause holds output, a long silence faults."""

    name = "sim"
    drives_real_hardware = False
    recovers_by_itself = True
    measures_pressure = True
    measures_length = True
    needs_rclpy = True
    host_loss_timeout_s = SIM_BOARD_TIMEOUT_S  # sim_world's board vents by itself, as a real board must

    def __init__(self, robot: RobotDescription | None = None, options: Mapping[str, Any] | None = None):
        """Validate the options (``ConfigurationError`` naming the key); nothing connects before ``open()``."""
        super().__init__(robot, options)
        options = SIM_OPTIONS.read(self.options, WHERE)
        self.command_topic: str = options["command_topic"]
        self.monitor_topic: str = options["monitor_topic"]
        self.readback_timeout_s: float = options["readback_timeout_s"]
        self.world_lost_timeout_s: float = options["world_lost_timeout_s"]
        self.startup_timeout_s: float = options["startup_timeout_s"]
        for key in ("command_topic", "monitor_topic"):  # refused here, naming the key, not at open by rclpy
            _check_topic_name(key, options[key])
        if self.world_lost_timeout_s < self.readback_timeout_s:
            raise refusal(WHERE, "world_lost_timeout_s", self.world_lost_timeout_s,
                          f"at least readback_timeout_s = {self.readback_timeout_s:g} s (a pause first holds, only "
                          "a longer silence is a fault)")
        self._node = self._executor = self._thread = self._publisher = None
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._monitor: tuple[float, np.ndarray, np.ndarray] | None = None  # (monotonic s, bar, m)
        self._opened_s = 0.0
        # The bus thread's returns from its timed spin_once (0.05 s): two more than RECEIVER_BEHIND_S apart, it was
        # held up, and the silence before is not heard.
        self._listener = ReceiverWatch(stuck_s=math.inf)
        self.monitor_count = 0

    # -- the contract -----------------------------------------------------------------------
    def _open(self) -> None:
        import rclpy
        from rclpy.experimental import EventsExecutor
        from sensor_msgs.msg import JointState

        if not rclpy.ok():
            raise HardwareError("sim backend: rclpy is not initialised; the sim backend runs inside a ROS node "
                                "(hardware_node or srs_bringup).")
        # The process's own arguments (namespace, remappings, use_sim_time) apply, as to every node it creates;
        # only the name is the bus's own, so a process-wide __node:= remap cannot give it the host node's name.
        self._node = rclpy.create_node(BUS_NODE_NAME, cli_args=["--ros-args", "-r", f"__node:={BUS_NODE_NAME}"],
                                       start_parameter_services=False)
        self._publisher = self._node.create_publisher(JointState, self.command_topic, bus_qos())
        # Best effort: only the newest read-back matters, and a reliable reader would hold later samples until a
        # lost one is repaired. The world's reliable publisher serves it (and any reliable reader) alike.
        self._node.create_subscription(JointState, self.monitor_topic, self._on_monitor, readback_qos())
        self._executor = EventsExecutor()  # spun by a timed spin_once loop (_spin): its spin() never runs a callback
        self._executor.add_node(self._node)
        self._stop.clear()
        self._monitor = None
        self._opened_s = time.monotonic()
        self._listener = ReceiverWatch(stuck_s=math.inf)
        self._listener.start(self._opened_s)
        self._thread = threading.Thread(target=self._spin, name="sim_backend_bus", daemon=True)
        self._thread.start()
        self._message = JointState(name=list(self.robot.joint_names))

    def _write(self, pressure_bar: np.ndarray, command_v: np.ndarray) -> None:
        msg = self._message
        msg.header.stamp = self._node.get_clock().now().to_msg()
        msg.effort = pressure_bar.tolist()
        self._publisher.publish(msg)  # on the bus first: a vent always goes out, whoever listens
        if np.any(pressure_bar > 0.0):  # a tool driving the rig directly learns here that the world is gone
            self._check_alive(time.monotonic())

    def holding_reason(self) -> str:
        """'' while the world answers; why output must hold at 0 bar during a pause; HardwareError once it is lost."""
        now_s = time.monotonic()
        self._check_alive(now_s)
        with self._lock:
            monitor = self._monitor
        if monitor is None:
            return f"waiting for sim_world's first read-back on {self._resolved_monitor_topic()}"
        silent_s = now_s - monitor[0]
        if silent_s > self.readback_timeout_s:
            return f"sim_world silent for {silent_s:.2f} s (paused or starved of CPU)"
        return ""

    def _close(self) -> None:
        if self._publisher is not None:  # the last command (the vent) reaches a world that is alive
            from rclpy.duration import Duration

            if not self._publisher.wait_for_all_acked(Duration(seconds=VENT_ACK_TIMEOUT_S)):
                _LOG.warning("sim backend: sim_world did not acknowledge the vent within %g s (paused or gone): "
                             "its own board vents after command_timeout_s without a command", VENT_ACK_TIMEOUT_S)
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        if self._thread is not None and self._thread.is_alive():
            # Destroying a node another thread still spins can crash the process: leave the bus to the exit.
            _LOG.warning("sim backend: the bus thread did not stop within 2 s; its node is left to the process exit")
        else:
            if self._executor is not None:
                self._executor.shutdown()
            if self._node is not None:
                self._node.destroy_node()
        self._node = self._executor = self._thread = self._publisher = None

    def _measure(self) -> dict[str, Any]:
        with self._lock:
            monitor = self._monitor
        if monitor is None:
            return {"details": {"simulated": True, "monitor_messages": self.monitor_count}}
        received_s, pressure_bar, length_m = monitor
        return {"measured_pressure_bar": pressure_bar, "measured_length_m": length_m,
                "details": {"simulated": True, "monitor_age_s": time.monotonic() - received_s,
                            "monitor_messages": self.monitor_count}}

    # -- the bus ----------------------------------------------------------------------------
    def _spin(self) -> None:
        while not self._stop.is_set():
            try:
                self._executor.spin_once(timeout_sec=0.05)
            except Exception:  # the context went down under us (process exit): the bus is gone
                return
            with self._lock:  # a spin after a hold-up may take another handler first: it resumes the listening
                self._listener.ran(time.monotonic())

    def _on_monitor(self, msg) -> None:
        count = self.robot.joint_count
        if list(msg.name) != list(self.robot.joint_names) or len(msg.effort) != count or len(msg.position) != count:
            return  # not a read-back of this robot: ignored, and silence will say so
        pressure = np.asarray(msg.effort, dtype=np.float64)
        length = np.asarray(msg.position, dtype=np.float64)
        if not (np.all(np.isfinite(pressure)) and np.all(np.isfinite(length))):
            return
        with self._lock:
            self._monitor = (time.monotonic(), pressure, length)
            self.monitor_count += 1

    def _resolved_monitor_topic(self) -> str:
        return self._node.resolve_topic_name(self.monitor_topic) if self._node is not None else self.monitor_topic

    def _check_alive(self, now_s: float) -> None:
        """Raise HardwareError if the world never answered, fell silent for good, or left the graph."""
        with self._lock:
            monitor, listener = self._monitor, self._listener
        if monitor is None:
            if now_s - self._opened_s > self.startup_timeout_s:
                raise HardwareError(f"sim backend: no read-back from sim_world on {self._resolved_monitor_topic()!r} "
                                    f"within startup_timeout_s {self.startup_timeout_s:g} s; start sim_world (it is "
                                    "part of srs_bringup and the launch file) on the same ROS_DOMAIN_ID and namespace.")
            return
        silent_s = now_s - monitor[0]
        heard_s = listener.heard_silence_s(monitor[0])  # the silence the bus listened to since it last resumed
        deaf_limit_s, deaf_s = max(BUS_DEAF_TIMEOUT_S, self.world_lost_timeout_s), listener.deaf_s(now_s)
        lost = heard_s > self.world_lost_timeout_s or max(silent_s, deaf_s) > deaf_limit_s
        if lost and deaf_s > self.world_lost_timeout_s:
            raise HardwareError(f"sim backend: its bus thread has not listened for {deaf_s:.1f} s (stopped, or "
                                f"starved of CPU; the limit is {deaf_limit_s:g} s): the read-back of sim_world cannot "
                                "be heard. The sim rig reopens its backend by itself.")
        if lost:
            raise HardwareError(f"sim backend: sim_world silent for {silent_s:.3f} s on "
                                f"{self._resolved_monitor_topic()!r} (more than world_lost_timeout_s "
                                f"{self.world_lost_timeout_s:g} s): the simulated robot stopped, died or diverged; "
                                "the sim rig resumes by itself once sim_world answers again (restart it, or ~/reset "
                                "it after a divergence).")
        if silent_s > self.readback_timeout_s and self._node.count_publishers(self._resolved_monitor_topic()) == 0:
            raise HardwareError(f"sim backend: sim_world left the ROS graph (nothing publishes "
                                f"{self._resolved_monitor_topic()!r}); the sim rig resumes by itself once it is back.")
