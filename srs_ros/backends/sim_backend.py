"""The ``sim`` backend: regulator commands over a DDS topic to the ``sim_world`` node, as frames to a DAC board.

The simulated robot runs in its own node (``sim_world``, MuJoCo). This backend drives it the way the
``can`` backend drives a regulator board: every command (already through the one clamp) is published on a
reliable, depth-1 command topic that acts as the bus, and the world answers on a monitor topic with the
regulators' pressure read-back and the muscles' lengths (a simulated rig can measure them). If the
world stops answering, the backend raises :class:`~srs_ros.core.errors.HardwareError` on the next write
of a pressure, as a dead CAN board would: the hardware node vents (a vent is always published), goes to
its error state and says so on /diagnostics.

The bus is rclpy: the backend owns a small node (``<name>``, in the process's default context) and spins
it on its own thread with timed ``spin_once`` calls, as python-can's buses own a receive thread.

Options (``backend_options`` of a rig file, each validated with the key named on error):

- ``command_topic`` (default ``sim/regulator_command``): sensor_msgs/JointState, ``effort`` = pressure (bar);
- ``monitor_topic`` (default ``sim/regulator_monitor``): sensor_msgs/JointState from the world,
  ``effort`` = measured pressure (bar), ``position`` = muscle length (m);
- ``readback_timeout_s`` (default 0.2, in [0.02, 5]): the world silent this long -> HardwareError;
- ``startup_timeout_s`` (default 15, in [0.1, 120]): how long after ``open`` the world may take to answer
  for the first time (it may start after the hardware node); nothing blocks meanwhile.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Mapping
from typing import Any

import numpy as np

from srs_ros.backends.base import ActuatorBackend
from srs_ros.core.errors import ConfigurationError, HardwareError
from srs_ros.core.robot import RobotDescription

SIM_COMMAND_TOPIC = "sim/regulator_command"
SIM_MONITOR_TOPIC = "sim/regulator_monitor"

#: option -> (default, lowest, highest) of the numeric options.
_NUMBERS: dict[str, tuple[float, float, float]] = {
    "readback_timeout_s": (0.2, 0.02, 5.0),
    "startup_timeout_s": (15.0, 0.1, 120.0),
}
_TOPICS = {"command_topic": SIM_COMMAND_TOPIC, "monitor_topic": SIM_MONITOR_TOPIC}


def bus_qos():
    """The command 'bus': reliable, depth 1 (only the newest command matters, none is silently dropped)."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)


class SimBackend(ActuatorBackend):
    """Commands to ``sim_world`` over DDS; read-back (pressures, lengths) from it; silence is a hardware error."""

    name = "sim"
    drives_real_hardware = False
    measures_pressure = True
    measures_length = True
    needs_rclpy = True

    def __init__(self, robot: RobotDescription | None = None, options: Mapping[str, Any] | None = None):
        """Validate the options (``ConfigurationError`` naming the key); nothing connects before ``open()``."""
        super().__init__(robot, options)
        unknown = sorted(set(self.options) - set(_NUMBERS) - set(_TOPICS))
        if unknown:
            raise ConfigurationError(f"sim backend_options: unknown key {unknown[0]!r}; expected some of "
                                     f"{sorted(_NUMBERS) + sorted(_TOPICS)}.")
        for key, (default, low, high) in _NUMBERS.items():
            value = self.options.get(key, default)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (low <= value <= high):
                raise ConfigurationError(f"sim backend_options: '{key}' is {value!r}; expected a number in "
                                         f"[{low}, {high}] s.")
            setattr(self, key, float(value))
        for key, default in _TOPICS.items():
            value = self.options.get(key, default)
            if not isinstance(value, str) or not value:
                raise ConfigurationError(f"sim backend_options: '{key}' is {value!r}; expected a topic name.")
            setattr(self, key, value)
        self.host_loss_timeout_s = None  # the world holds the last command if the host dies, as a DAC board would
        self._node = self._executor = self._thread = self._publisher = None
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._monitor: tuple[float, np.ndarray, np.ndarray] | None = None  # (monotonic s, bar, m)
        self._opened_s = 0.0
        self.monitor_count = 0

    # -- the contract -----------------------------------------------------------------------
    def _open(self) -> None:
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from sensor_msgs.msg import JointState

        if not rclpy.ok():
            raise HardwareError("sim backend: rclpy is not initialised; the sim backend runs inside a ROS node "
                                "(hardware_node or srs_bringup).")
        self._node = rclpy.create_node("sim_backend_bus", use_global_arguments=False)
        self._publisher = self._node.create_publisher(JointState, self.command_topic, bus_qos())
        self._node.create_subscription(JointState, self.monitor_topic, self._on_monitor, bus_qos())
        self._executor = SingleThreadedExecutor()
        self._executor.add_node(self._node)
        self._stop.clear()
        self._monitor = None
        self._opened_s = time.monotonic()
        self._thread = threading.Thread(target=self._spin, name="sim_backend_bus", daemon=True)
        self._thread.start()
        self._message = JointState(name=list(self.robot.joint_names))

    def _write(self, pressure_bar: np.ndarray, command_v: np.ndarray) -> None:
        msg = self._message
        msg.header.stamp = self._node.get_clock().now().to_msg()
        msg.effort = pressure_bar.tolist()
        self._publisher.publish(msg)  # on the bus first: a vent always goes out, whoever listens
        if np.any(pressure_bar > 0.0):
            self._check_alive()

    def _close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
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

    def _check_alive(self) -> None:
        now_s = time.monotonic()
        with self._lock:
            monitor = self._monitor
        if monitor is None:
            if now_s - self._opened_s > self.startup_timeout_s:
                raise HardwareError(f"sim backend: no read-back from sim_world on {self.monitor_topic!r} within "
                                    f"startup_timeout_s {self.startup_timeout_s:g} s; start sim_world (it is part of "
                                    "srs_bringup and the launch file) on the same ROS_DOMAIN_ID.")
            return
        silent_s = now_s - monitor[0]
        if silent_s > self.readback_timeout_s:
            raise HardwareError(f"sim backend: sim_world silent for {silent_s:.3f} s on {self.monitor_topic!r} "
                                f"(more than readback_timeout_s {self.readback_timeout_s:g} s): the simulated "
                                "robot stopped or diverged; restart sim_world, then configure and activate.")
