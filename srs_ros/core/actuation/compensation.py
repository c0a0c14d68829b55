"""Setpoint lengths -> regulator pressures, optionally leading the supply line's delay and lag (no ROS).

The paper's main limitation at high frequency (Sec. IV-C, IV-E) is the pneumatic line: a command
reaches the muscle ``d`` later (transport delay) and its pressure follows with a first-order lag of
time constant ``tau`` (:mod:`srs_ros.core.actuation.muscle_model`). With compensation on, the command at time
``t`` is the one that makes the lagging, delayed pressure follow the reference ``P_ref = map(l)``::

    l_lead = l + d * dl/dt                                  # where the setpoint will be when it arrives
    P_cmd  = map(l_lead) + tau * map'(l_lead) * dl/dt       # P + tau dP/dt inverts the first-order lag

per muscle, with the setpoint velocities ``dl/dt`` that ``gait_player`` publishes (or a finite
difference of successive setpoints when a sender gives none). ``P_cmd`` ALWAYS goes through the one
clamp (:func:`srs_ros.core.actuation.pressure.clamp_pressures_bar`): where the lead asks for more than
``[0, max_pressure_bar]`` (or more than a muscle's saturation) it is cut, never exceeded, and counted
(:attr:`SetpointShaper.compensation_clamped`).

Limits: the lead is a first-order prediction, so it cannot anticipate a kink of the setpoint stream
(a muscle leaving 0, a reversal) nor a step; a setpoint that stops arriving keeps its last
(compensated) command until the hardware node's setpoint timeout vents it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from srs_ros.core.actuation.muscle_calibration import (
    CALIBRATED_MAP,
    DYNAMIC_KEYS,
    MuscleCalibration,
    PressureMap,
    load_calibration,
    pressure_map,
)
from srs_ros.core.actuation.pressure import clamp_pressures_bar
from srs_ros.core.actuation.safety import clamped_joints
from srs_ros.core.errors import ConfigurationError
from srs_ros.core.robot import RobotDescription
from srs_ros.core.validation import finite_array

#: Setpoint rates beyond this many strokes (``max_extension_m``) per second are no gait: they are limited
#: so that the lead stays finite whatever finite velocity a sender publishes.
MAX_STROKES_PER_S = 1000.0
#: Successive setpoints further apart than this (s) give no finite-difference velocity (a pause, a restart).
MAX_DIFFERENCE_GAP_S = 0.1
#: Commands within this of the limits (bar) are rounding, not a cut lead.
CUT_TOLERANCE_BAR = 1e-9


@dataclass(frozen=True)
class LineDynamics:
    """Per muscle: the supply line's transport delay (s) and first-order pressure time constant (s)."""

    transport_delay_s: np.ndarray
    pressure_time_constant_s: np.ndarray

    @classmethod
    def from_calibration(cls, calibration: MuscleCalibration) -> LineDynamics:
        """The identified dynamics of ``calibration`` (ConfigurationError if it has none)."""
        if not calibration.has_dynamics:
            raise ConfigurationError(f"{calibration.source}: no {list(DYNAMIC_KEYS)} (the dynamics were not "
                                     "identified); run srs_identify on a rig with pressure read-back, or set "
                                     "compensation_delay_s and compensation_time_constant_s.")
        return cls(calibration.transport_delay_s.copy(), calibration.pressure_time_constant_s.copy())


def compensated_pressures_bar(pressure_map: PressureMap, dynamics: LineDynamics, lengths_m,
                              velocities_m_per_s) -> tuple[np.ndarray, np.ndarray]:
    """Pressures (bar) that lead the line's delay and invert its lag, through the clamp, and where it cut them.

    ``lengths_m`` and ``velocities_m_per_s`` are ``(..., 9)`` (m, m/s, finite). The setpoint is limited as
    the map limits it; the lead from there follows the map's line beyond its top (the demand a lead
    makes near full extension), and is then held to each muscle's top pressure (the map's at its
    limited length) and passed through the clamp. Returns the command and a boolean array, True where
    the lead asked for more than that (above the top, or below 0 bar while extending).

    Example: ``P = 100 l``, d = 0.03 s, tau = 0.08 s, l = 0.02 m rising at 0.1 m/s: the lead length is
    0.023 m, the command 2.3 + 0.08 * 100 * 0.1 = 3.1 bar.
    """
    robot = pressure_map.robot
    limited_m = pressure_map.limited_length_m
    lengths = np.clip(finite_array("lengths_m", lengths_m, (robot.joint_count,), "m"), 0.0, limited_m)
    speed_limit = MAX_STROKES_PER_S * robot.max_extension_m
    velocities = np.clip(finite_array("velocities_m_per_s", velocities_m_per_s, (robot.joint_count,), "m/s"),
                         -speed_limit, speed_limit)
    lead_m = lengths + dynamics.transport_delay_s * velocities  # finite: both terms are bounded
    gain = pressure_map.gain_bar_per_m
    top_bar = pressure_map.reference_pressures_bar(limited_m)
    wanted_bar = (pressure_map.reference_pressures_bar(lead_m) + gain * np.maximum(lead_m - limited_m, 0.0)
                  + np.where(lead_m > 0.0, dynamics.pressure_time_constant_s * gain * velocities, 0.0))
    cut = (wanted_bar < -CUT_TOLERANCE_BAR) | (wanted_bar > top_bar + CUT_TOLERANCE_BAR)
    return clamp_pressures_bar(np.minimum(wanted_bar, top_bar), robot), cut


class SetpointShaper:
    """The hardware node's setpoint -> pressure step: the selected map, and the lag compensation when on.

    ``compensation`` may be switched at any time (it needs ``dynamics``). Counters:
    :attr:`compensation_clamped` (setpoints whose lead the clamp cut).
    """

    def __init__(self, pressure_map: PressureMap, dynamics: LineDynamics | None = None, compensation: bool = False):
        """Shape setpoints with ``pressure_map``; ``dynamics`` enables the compensation."""
        self.map = pressure_map
        self.dynamics = dynamics
        self._compensation = False
        self.compensation = compensation
        self.compensation_clamped = 0
        self._previous: tuple[float, np.ndarray] | None = None  # (time s, lengths m) of the last setpoint

    @property
    def compensation(self) -> bool:
        """True while commands lead the line's delay and invert its lag."""
        return self._compensation

    @compensation.setter
    def compensation(self, enabled: bool) -> None:
        reason = self.compensation_refusal() if enabled else ""
        if reason:
            raise ConfigurationError(reason)
        self._compensation = bool(enabled)

    def compensation_refusal(self) -> str:
        """Why the compensation cannot be switched on ('' when it can)."""
        if self.dynamics is None:
            return ("lag compensation needs the line's delay and time constant: set calibration_file to a rig "
                    "calibration with dynamics (srs_identify), or compensation_delay_s and "
                    "compensation_time_constant_s.")
        return ""

    def limited_joints(self, lengths_m: np.ndarray) -> list[str]:
        """Actuators whose length the clamp changes under the selected map (below 0, above its limited length)."""
        return clamped_joints(lengths_m, self.map.robot, self.map.limited_length_m)

    def pressures_bar(self, lengths_m, velocities_m_per_s=None, now_s: float = 0.0) -> np.ndarray:
        """The clamped command (bar) for one setpoint of joint-ordered lengths (m) arriving at ``now_s`` (s).

        ``velocities_m_per_s`` (m/s) None: differenced from the previous setpoint (0 after a gap).
        """
        lengths = finite_array("lengths_m", lengths_m, (self.map.robot.joint_count,), "m")
        # Differenced as the map limits them: a huge but finite length (limited like any other) must not become an
        # infinite rate that refuses it and the setpoint after it.
        limited = np.clip(lengths, 0.0, self.map.limited_length_m)
        previous, self._previous = self._previous, (float(now_s), limited)
        if not self._compensation:
            return self.map.pressures_bar(lengths)
        if velocities_m_per_s is None:
            velocities_m_per_s = np.zeros_like(lengths)
            if previous is not None and 0.0 < now_s - previous[0] <= MAX_DIFFERENCE_GAP_S:
                velocities_m_per_s = (limited - previous[1]) / (now_s - previous[0])
        pressure, cut = compensated_pressures_bar(self.map, self.dynamics, lengths, velocities_m_per_s)
        self.compensation_clamped += bool(np.any(cut))
        return pressure


def setpoint_shaper(robot: RobotDescription, map_name: str, calibration_file: str = "", delay_s: float = 0.0,
                    time_constant_s: float = 0.0, compensation: bool = False) -> SetpointShaper:
    """A :class:`SetpointShaper` from the hardware node's parameters.

    ``calibration_file`` ('' = none) gives the calibrated map and the per-muscle dynamics; ``delay_s`` and
    ``time_constant_s`` (0 = the calibration's) set the same dynamics for every muscle instead.
    Raises :class:`ConfigurationError` with the reason (a missing or bad file, no dynamics for the
    compensation).
    """
    calibration = load_calibration(calibration_file, robot) if calibration_file else None
    if map_name == CALIBRATED_MAP and calibration is None:
        raise ConfigurationError(f"pressure_map is '{CALIBRATED_MAP}' but calibration_file is empty; expected the "
                                 "rig's calibration file (srs_identify --rig FILE --out FILE).")
    dynamics = None
    if calibration is not None and calibration.has_dynamics:
        dynamics = LineDynamics.from_calibration(calibration)
    if delay_s > 0.0 or time_constant_s > 0.0:
        count = robot.joint_count
        base = dynamics or LineDynamics(np.zeros(count), np.zeros(count))
        dynamics = LineDynamics(np.full(count, delay_s) if delay_s > 0.0 else base.transport_delay_s,
                                np.full(count, time_constant_s) if time_constant_s > 0.0
                                else base.pressure_time_constant_s)
    return SetpointShaper(pressure_map(map_name, robot, calibration), dynamics, compensation)
