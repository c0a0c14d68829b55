"""The one actuator-backend contract (as python-can's ``BusABC``): open, write pressures, read state, vent, close.

Concrete backends (``mock``, ``can``, ``daq``) implement the four abstract methods. The public
:meth:`ActuatorBackend.write_pressures` and :meth:`ActuatorBackend.vent` are final: they pass every
command through the one clamp of :mod:`srs_ros.core.actuation.pressure` and convert it to regulator volts, so
a backend never sees an unclamped value.
"""

from __future__ import annotations

import abc
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from srs_ros.core.actuation.pressure import clamp_pressures_bar, pressures_to_command_v
from srs_ros.core.errors import HardwareError, InvalidInputError
from srs_ros.core.robot import RobotDescription, default_robot


@dataclass
class ActuatorState:
    """What a backend knows about the actuators at ``stamp_s`` (``time.monotonic()`` seconds).

    Arrays have one entry per actuator in joint order; ``None`` where the backend cannot measure.
    """

    stamp_s: float
    commanded_pressure_bar: np.ndarray
    command_v: np.ndarray
    measured_pressure_bar: np.ndarray | None = None
    measured_length_m: np.ndarray | None = None
    details: dict[str, Any] = field(default_factory=dict)


class ActuatorBackend(abc.ABC):
    """Drives the nine pressure regulators of the SRS.

    Life cycle: ``open()`` -> any number of ``write_pressures()`` / ``read_state()`` -> ``vent()``
    -> ``close()``. ``close()`` vents first and may be called more than once. Usable as a context
    manager (``with create_backend('mock') as backend: ...``), which vents and closes on exit.

    Errors: :class:`~srs_ros.core.errors.ConfigurationError` for bad options (raised by the
    constructor or ``open``), :class:`~srs_ros.core.errors.BackendUnavailableError` when a driver is
    missing, :class:`~srs_ros.core.errors.HardwareError` for failures while talking to hardware.
    """

    #: The name the backend is chosen by (``backend`` parameter).
    name: str = "abstract"
    #: True where the backend drives real regulators with real air: the hardware node then commands
    #: nothing above 0 bar until an operator arms it (``~/arm``). Simulated backends set it False.
    drives_real_hardware: bool = True
    #: What ``read_state`` reports once open: the regulators' pressure read-back (``measured_pressure_bar``)
    #: and the muscles' lengths (``measured_length_m``). ``srs_identify`` refuses to measure what a rig cannot.
    measures_pressure: bool = False
    measures_length: bool = False
    #: True where the hardware comes back by itself after a fault (a simulator restarted): the hardware node then
    #: configures and activates again on its own. Real rigs keep the operator in the loop (False).
    recovers_by_itself: bool = False
    #: True where the backend talks over rclpy/DDS (``sim``): a tool outside a ROS node initialises rclpy first.
    needs_rclpy: bool = False
    #: Seconds the hardware holds the last command without a new one before it vents by itself (a CAN
    #: board's alive-counter timeout, an NI watchdog), or None where it holds it for ever if the host dies.
    host_loss_timeout_s: float | None = None
    #: Where only some outputs vent by themselves (an NI watchdog on some devices only): their timeout (s); the
    #: others hold for ever, so ``host_loss_timeout_s`` is None. Checked against the command period all the same.
    partial_host_loss_timeout_s: float | None = None

    @property
    def silence_vent_s(self) -> float | None:
        """The shortest time without a write after which any output vents by itself (s), None if none does."""
        return self.host_loss_timeout_s if self.host_loss_timeout_s is not None else self.partial_host_loss_timeout_s

    def __init__(self, robot: RobotDescription | None = None, options: Mapping[str, Any] | None = None):
        """Store the robot description and the backend's own options (validated by the subclass)."""
        self.robot = robot or default_robot()
        self.options = dict(options or {})
        zeros = np.zeros(self.robot.joint_count)
        self._last_pressure_bar = zeros
        self._last_command_v = zeros.copy()
        self._last_write_s = float("nan")
        self.is_open = False

    # -- the contract -----------------------------------------------------------------------
    @abc.abstractmethod
    def _open(self) -> None:
        """Connect to the hardware and leave every regulator at 0 bar. Raise on failure."""

    @abc.abstractmethod
    def _write(self, pressure_bar: np.ndarray, command_v: np.ndarray) -> None:
        """Send one command: clamped pressures (bar) and their regulator voltages (V), shape (9,)."""

    @abc.abstractmethod
    def _close(self) -> None:
        """Release the hardware (after a vent). Must not raise for an already-closed device."""

    def _measure(self) -> dict[str, Any]:
        """Optional measurements: keys ``measured_pressure_bar``, ``measured_length_m``, ``details``."""
        return {}

    def holding_reason(self) -> str:
        """Why the hardware cannot follow commands right now ('' when it can).

        A simulator that pauses (``sim``) says so here: the hardware node then sends 0 bar and ramps back
        in when the reason clears, as after stale setpoints. Raises
        :class:`~srs_ros.core.errors.HardwareError` when the hardware is lost for good. Real boards never hold.
        """
        return ""

    # -- final public API -------------------------------------------------------------------
    def open(self) -> None:
        """Open the backend (idempotent); regulators start vented."""
        if not self.is_open:
            self._open()
            self.is_open = True

    def write_pressures(self, pressure_bar) -> np.ndarray:
        """Command pressures (bar, shape (9,)) through the one clamp; return what was sent (bar).

        Raises :class:`~srs_ros.core.errors.InvalidInputError` for NaN or a wrong size (nothing is
        sent), :class:`~srs_ros.core.errors.HardwareError` if the backend is not open or fails.
        """
        pressure = clamp_pressures_bar(pressure_bar, self.robot)
        if pressure.shape != (self.robot.joint_count,):
            raise InvalidInputError(f"pressure_bar: expected one command of shape ({self.robot.joint_count},) "
                                    f"in bar, got shape {pressure.shape}; send batches one row at a time.")
        self._send(pressure)
        return pressure

    def vent(self) -> None:
        """Command 0 bar on every regulator."""
        self._send(np.zeros(self.robot.joint_count))

    def read_state(self) -> ActuatorState:
        """The last command and whatever the backend measures."""
        extra = self._measure() if self.is_open else {}
        return ActuatorState(
            stamp_s=time.monotonic(),
            commanded_pressure_bar=self._last_pressure_bar.copy(),
            command_v=self._last_command_v.copy(),
            measured_pressure_bar=extra.get("measured_pressure_bar"),
            measured_length_m=extra.get("measured_length_m"),
            details=extra.get("details", {}),
        )

    def close(self) -> None:
        """Vent (best effort) and release the hardware; safe to call twice."""
        if not self.is_open:
            return
        try:
            self.vent()
        finally:
            self.is_open = False
            self._close()

    def __enter__(self) -> ActuatorBackend:
        self.open()
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def _send(self, pressure_bar: np.ndarray) -> None:
        if not self.is_open:
            raise HardwareError(f"{self.name} backend is not open; call open() (configure the hardware node) first.")
        command_v = pressures_to_command_v(pressure_bar, self.robot)
        self._write(pressure_bar, command_v)
        self._last_pressure_bar, self._last_command_v = pressure_bar, command_v
        self._last_write_s = time.monotonic()
