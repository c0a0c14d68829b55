"""Simulated McKibben muscles behind pressure regulators, for the mock backend (no ROS, no hardware).

The model of one muscle (vectorised over all muscles with NumPy):

1. transport delay: a command issued at ``t`` reaches the regulator at ``t + transport_delay_s``
   (the supply line);
2. first-order pressure lag: ``dP/dt = (P_cmd - P) / pressure_time_constant_s``, no faster than
   ``max_pressure_rate_bar_per_s`` (a flow-limited supply: a choked orifice or a long thin line fills and
   empties the muscle at a bounded rate; 0 = no limit), integrated exactly for the piecewise-constant delayed
   command;
3. extension: nothing below the deadzone, then linear up to ``max_extension_m`` at
   ``full_extension_pressure_bar`` and saturated beyond:
   ``l = l_max * clip((P - P_dz) / (P_full - P_dz), 0, 1)``.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from srs_ros.core.robot import ABSOLUTE_MAX_PRESSURE_BAR, RobotDescription
from srs_ros.core.schema import REQUIRED, Field, Table, refusal
from srs_ros.core.validation import finite_array

#: The options of simulated muscles (a rig's ``backend_options``, ``muscles:`` of ``config/sim.yaml``).
#: Deadzone and largest extension default to the robot's (:func:`muscle_parameters_from_options`).
MUSCLE_OPTIONS = Table("", (
    Field("pressure_time_constant_s", float, 0.08, 0.0, 10.0, "s", "first-order lag of regulator + muscle"),
    Field("transport_delay_s", float, 0.03, 0.0, 2.0, "s", "supply-line transport delay"),
    Field("max_pressure_rate_bar_per_s", float, 0.0, 0.0, 1000.0, "bar/s",
          "fastest filling or venting of a muscle (a flow-limited supply); 0 = no limit"),
    Field("deadzone_bar", float, REQUIRED, 0.0, ABSOLUTE_MAX_PRESSURE_BAR, "bar",
          "no extension below this pressure (default: the robot's)"),
    Field("max_extension_m", float, REQUIRED, 1e-4, 1.0, "m",
          "extension at the robot's max_pressure_bar, never exceeded (default: the robot's)"),
), description="a mapping of option: value")
#: Muscle option -> (lowest, highest) accepted value (from :data:`MUSCLE_OPTIONS`).
MUSCLE_OPTION_RANGES: dict[str, tuple[float, float]] = {f.name: (f.minimum, f.maximum) for f in MUSCLE_OPTIONS}
#: Defaults of the options the robot description does not give: first-order lag of regulator + muscle
#: and supply-line transport delay (deadzone and largest extension default to the robot's).
MUSCLE_OPTION_DEFAULTS: dict[str, float] = {k: v for k, v in MUSCLE_OPTIONS.defaults.items()}


@dataclass(frozen=True)
class MuscleParameters:
    """Constants of the simulated muscles (all >= 0; ``full_extension_pressure_bar > deadzone_bar``).

    Built by :func:`muscle_parameters_from_options` from the robot description and a mapping of options
    (a rig's ``backend_options``, the ``muscles:`` section of ``config/sim.yaml``).
    """

    deadzone_bar: float
    pressure_time_constant_s: float
    transport_delay_s: float
    max_extension_m: float
    full_extension_pressure_bar: float
    max_pressure_rate_bar_per_s: float = 0.0


def muscle_parameters_from_options(options: Mapping[str, Any], robot: RobotDescription, where: str,
                                   extra_keys: tuple[str, ...] = (), path: str = "") -> MuscleParameters:
    """Validated :class:`MuscleParameters` from ``options`` (keys of :data:`MUSCLE_OPTIONS`).

    Missing keys take :data:`MUSCLE_OPTION_DEFAULTS` or the robot's ``deadzone_bar`` / ``max_extension_m``;
    full extension is reached at the robot's ``max_pressure_bar``. ``extra_keys`` are other options the
    caller handles itself (not refused as unknown). Raises :class:`ConfigurationError` starting with
    ``where`` (the file or component) and naming the key (at dotted ``path``), the value and what is expected.
    """
    table = MUSCLE_OPTIONS.at(path).with_defaults(deadzone_bar=robot.deadzone_bar,
                                                   max_extension_m=robot.max_extension_m)
    values = table.read(options, where, extra=extra_keys)
    if values["deadzone_bar"] >= robot.max_pressure_bar:
        raise refusal(where, table.key("deadzone_bar"), values["deadzone_bar"],
                      f"less than the robot's max_pressure_bar = {robot.max_pressure_bar:g} bar")
    return MuscleParameters(full_extension_pressure_bar=robot.max_pressure_bar, **values)


def extension_m(pressure_bar, params: MuscleParameters) -> np.ndarray:
    """Static extension (m) of muscles at ``pressure_bar``: 0 in the deadzone, saturating at ``max_extension_m``.

    Example: deadzone 1 bar, full extension 0.065 m at 4 bar -> 2.5 bar gives 0.0325 m, 6 bar gives 0.065 m.
    """
    pressure = np.asarray(pressure_bar, dtype=np.float64)
    span_bar = params.full_extension_pressure_bar - params.deadzone_bar
    return params.max_extension_m * np.clip((pressure - params.deadzone_bar) / span_bar, 0.0, 1.0)


def lag_step(pressure_bar: np.ndarray, target_bar: np.ndarray, dt_s: float, time_constant_s: float,
             max_rate_bar_per_s: float = 0.0) -> np.ndarray:
    """Exact step over ``dt_s`` of ``dP/dt = clip((target - P) / tau, -rate, rate)`` for a constant target.

    tau 0 = no lag; ``max_rate_bar_per_s`` 0 = no rate limit. With both, a muscle far from its target
    ramps at the limit until it is ``rate * tau`` away, then closes in exponentially.
    """
    if dt_s <= 0.0:
        return pressure_bar
    target = np.asarray(target_bar, dtype=np.float64)
    if max_rate_bar_per_s <= 0.0:
        if time_constant_s <= 0.0:
            return np.array(target, dtype=np.float64)
        return pressure_bar + (1.0 - math.exp(-dt_s / time_constant_s)) * (target - pressure_bar)
    error = target - pressure_bar
    ramp_s = np.minimum(np.maximum(np.abs(error) / max_rate_bar_per_s - time_constant_s, 0.0), dt_s)
    ramped = pressure_bar + np.sign(error) * max_rate_bar_per_s * ramp_s
    if time_constant_s <= 0.0:
        return np.where(ramp_s < dt_s, target, ramped)
    return target - (target - ramped) * np.exp(-(dt_s - ramp_s) / time_constant_s)


class MuscleModel:
    """``count`` simulated muscles that start vented at ``start_s`` and advance with the caller's clock.

    ``command(p, t)`` issues regulator set-points (bar) at time ``t`` (s); ``state(t)`` returns the
    pressures (bar) and extensions (m) at ``t``. Times must not go backwards.
    """

    def __init__(self, params: MuscleParameters, count: int, start_s: float = 0.0):
        """Create ``count`` vented muscles at time ``start_s``."""
        self.params = params
        self.count = count
        self._time_s = float(start_s)
        self._pressure_bar = np.zeros(count)
        self._input_bar = np.zeros(count)  # the command the regulators currently see
        self._in_flight: deque[tuple[float, np.ndarray]] = deque()  # (arrival time s, command bar)

    def command(self, pressure_bar, now_s: float) -> None:
        """Issue set-points (bar, shape ``(count,)``) at ``now_s``; they arrive after the transport delay."""
        pressure = finite_array("pressure_bar", pressure_bar, (self.count,), "bar").copy()
        self.advance(now_s)
        self._in_flight.append((float(now_s) + self.params.transport_delay_s, pressure))
        self.advance(now_s)  # a zero delay takes effect at once

    def advance(self, now_s: float) -> None:
        """Integrate up to ``now_s``, switching the regulator input at each command's arrival time."""
        while self._in_flight and self._in_flight[0][0] <= now_s:
            arrival_s, pressure = self._in_flight.popleft()
            self._step_to(arrival_s)
            self._input_bar = pressure
        self._step_to(now_s)

    def state(self, now_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Pressures (bar) and extensions (m) of every muscle at ``now_s``."""
        self.advance(now_s)
        pressure = self._pressure_bar.copy()
        return pressure, extension_m(pressure, self.params)

    def _step_to(self, time_s: float) -> None:
        dt_s = time_s - self._time_s
        if dt_s > 0.0:
            self._pressure_bar = lag_step(self._pressure_bar, self._input_bar, dt_s,
                                          self.params.pressure_time_constant_s,
                                          self.params.max_pressure_rate_bar_per_s)
            self._time_s = time_s
