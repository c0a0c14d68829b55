"""The ``mock`` backend: nine simulated muscles (:mod:`srs_ros.core.muscle_model`) instead of regulators.

Options (``backend_options`` of a rig file, each validated with the key named on error):

- ``pressure_time_constant_s``: first-order lag of regulator + muscle, in [0, 10] s;
- ``transport_delay_s``: supply-line delay, in [0, 2] s (defaults of both:
  :data:`srs_ros.core.muscle_model.MUSCLE_OPTION_DEFAULTS`);
- ``deadzone_bar`` (default: the robot's ``deadzone_bar``): no extension below this pressure;
- ``max_extension_m`` (default: the robot's ``max_extension_m``): extension reached at the robot's
  ``max_pressure_bar`` and never exceeded;
- fault injection, for tests only: ``fail_after_writes`` (int >= 0, default off): every write after
  the first N since ``open()`` raises :class:`~srs_ros.core.errors.HardwareError`, as a dead bus would;
  ``fail_on_open`` (bool): ``open()`` raises :class:`~srs_ros.core.errors.HardwareError`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from srs_ros.backends.base import ActuatorBackend
from srs_ros.core.errors import ConfigurationError, HardwareError
from srs_ros.core.muscle_model import MuscleModel, muscle_parameters_from_options
from srs_ros.core.robot import RobotDescription

_FAULT_OPTIONS = ("fail_after_writes", "fail_on_open")


class MockBackend(ActuatorBackend):
    """Simulated rig: commands drive a :class:`MuscleModel`; ``read_state`` reports its pressures and lengths.

    ``clock`` (seconds, default ``time.monotonic``) can be replaced in unit tests to step time by hand.
    """

    name = "mock"
    drives_real_hardware = False

    def __init__(self, robot: RobotDescription | None = None, options: Mapping[str, Any] | None = None,
                 clock: Callable[[], float] = time.monotonic):
        """Validate the options (``ConfigurationError`` naming the key); the simulation starts at ``open()``."""
        super().__init__(robot, options)
        self.clock = clock
        self.params = muscle_parameters_from_options(self.options, self.robot, "mock backend_options",
                                                     extra_keys=_FAULT_OPTIONS)
        self.fail_after_writes = _fault_count(self.options.get("fail_after_writes"))
        self.fail_on_open = _flag(self.options, "fail_on_open")
        self.write_count = 0
        self.model: MuscleModel | None = None

    def _open(self) -> None:
        if self.fail_on_open:
            raise HardwareError("mock backend: open failed (fault injection option 'fail_on_open' is set).")
        self.write_count = 0
        self.model = MuscleModel(self.params, self.robot.joint_count, start_s=self.clock())

    def _write(self, pressure_bar: np.ndarray, command_v: np.ndarray) -> None:
        if self.fail_after_writes is not None and self.write_count >= self.fail_after_writes:
            raise HardwareError(f"mock backend: write {self.write_count + 1} failed (fault injection option "
                                f"'fail_after_writes' is {self.fail_after_writes}); reconfigure to reopen.")
        self.model.command(pressure_bar, self.clock())
        self.write_count += 1

    def _close(self) -> None:
        self.model = None

    def _measure(self) -> dict[str, Any]:
        pressure_bar, length_m = self.model.state(self.clock())
        return {"measured_pressure_bar": pressure_bar, "measured_length_m": length_m,
                "details": {"simulated": True, "writes": self.write_count}}


def _fault_count(value: Any) -> int | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ConfigurationError(f"mock backend_options: 'fail_after_writes' is {value!r}; expected an integer >= 0 "
                                 "(writes that succeed before every later one fails), or leave it out.")
    return value


def _flag(options: Mapping[str, Any], key: str) -> bool:
    value = options.get(key, False)
    if not isinstance(value, bool):
        raise ConfigurationError(f"mock backend_options: '{key}' is {value!r}; expected true or false.")
    return value
