"""What the navigator says: its state, the gait command for the nodes, the answer to a goal, its progress."""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

from srs_ros.core.navigation.settings import DIRECTIONS, MODEL_INWARD_SIDE

#: The gait whose cycle the navigator plays (forward: inward rolling, backward: outward rolling).
GAIT = "inward_rolling"
#: The gait of the moves along the body's axis (:mod:`srs_ros.core.navigation.shuffle`): the paper's serpentine,
#: straight (its steady turning ``c`` 0), played forward or backward in time.
AXIS_GAIT = "serpentine"
#: The two directions along the body's axis: the serpentine played forward and backward (a robot on an
#: anisotropic floor moves head first and tail first; on an isotropic floor it hardly moves).
AXIS_DIRECTIONS = ("serpentine_forward", "serpentine_backward")


class NavigationState(enum.Enum):
    """Where the navigator is. REACHED, CANCELLED, POSE_LOST and FAILED are stopped until a new goal."""

    IDLE = "idle"
    DRIVING = "driving"
    STOPPING = "stopping"
    REACHED = "reached"
    CANCELLED = "cancelled"
    POSE_LOST = "pose_lost"
    FAILED = "failed"

    @property
    def active(self) -> bool:
        """True while the navigator is working toward a goal."""
        return self in (NavigationState.DRIVING, NavigationState.STOPPING)


@dataclass(frozen=True)
class GaitCommand:
    """What the gait should do now. ``direction`` None: stop (ramp out, all pressures to 0 bar).

    ``direction`` is ``inward_rolling`` or ``outward_rolling``. Both are played as the one cycle of :data:`GAIT`
    (its ``turn_phase_rad`` set), outward rolling by playing it backward in time (:attr:`reverse`): outward
    rolling is inward rolling reversed in time, and a reversal then ramps the signed frequency through 0
    instead of cross-fading two different shapes (which makes the body flop over). Or one of
    :data:`AXIS_DIRECTIONS`: the straight serpentine (:data:`AXIS_GAIT`, ``turn_phase_rad`` unused), forward or
    backward in time, only ever started from rest.
    """

    direction: str | None
    turn_phase_rad: float
    amplitude_bar: float
    frequency_hz: float
    reason: str = ""
    #: For a stop (``direction`` None): the gait phase in [0, 1) at which the player is to ramp out (it plays on
    #: until then, at most one cycle); None: ramp out at once. The navigator stops a cycle ahead at a set
    #: phase, so the stop is exact however late the command arrives (within the cycle).
    stop_phase: float | None = None
    #: The navigator took the body's head for its tail (:class:`~srs_ros.core.navigation.motion.TravelSides`): its
    #: moves along the axis then play the serpentine the other way in time.
    ends_swapped: bool = False
    #: The fine approach's creep (once raised, its amplitude may equal the cruise gait's).
    creep: bool = False

    @property
    def moving(self) -> bool:
        """True when a gait is to be played."""
        return self.direction is not None

    @property
    def along_axis(self) -> bool:
        """True for a move along the body's axis (the serpentine), not a rolling direction."""
        return self.direction in AXIS_DIRECTIONS

    @property
    def gait(self) -> str:
        """The gait whose cycle is played (the trajectory_server's ``gait``)."""
        return AXIS_GAIT if self.along_axis else GAIT

    @property
    def gait_parameters(self) -> dict[str, float]:
        """The gait's parameters the navigator sets (trajectory_server's ``<gait>.<name>``)."""
        return {"c_rad_per_unit": 0.0} if self.along_axis else {"turn_phase_rad": float(self.turn_phase_rad)}

    @property
    def reverse(self) -> bool:
        """True when the cycle is played backward: outward rolling, the serpentine backward (forward, ends swapped)."""
        if self.along_axis:
            return (self.direction == AXIS_DIRECTIONS[1]) != self.ends_swapped
        return self.direction == "outward_rolling"

    @property
    def cycle_key(self) -> tuple[str, float, float]:
        """What needs a new cycle when it changes: ``(gait, amplitude_bar, turn_phase_rad or 0)``."""
        return (self.gait, self.amplitude_bar, 0.0 if self.along_axis else self.turn_phase_rad)


@dataclass(frozen=True)
class GoalDecision:
    """The answer to a goal: accepted, or refused with the reason; ``unchanged``: the goal already driven to."""

    accepted: bool
    reason: str
    unchanged: bool = False


@dataclass(frozen=True)
class NavigationProgress:
    """The navigator's progress, for a topic and ``/diagnostics``."""

    state: NavigationState
    goal_xy_m: tuple[float, float] | None
    goal_index: int
    goal_count: int
    distance_to_go_m: float
    heading_error_rad: float
    direction: str
    turn_phase_rad: float
    elapsed_s: float
    message: str
    inward_side: str = MODEL_INWARD_SIDE
    #: The fine approach's creep amplitude now (bar): ``fine_amplitude_bar``, raised if the creep was too weak.
    creep_amplitude_bar: float | None = None
    #: What the navigator has learned of the robot's turning so far: per rolling direction, the turn rate
    #: (deg per cycle, counter-clockwise positive) at each turn level of ``turn_levels_rad``, the turning map's
    #: values corrected online from the camera.
    turn_rates_deg_per_cycle: dict[str, list[float]] | None = None

    @property
    def level(self) -> str:
        """``OK``, ``WARN`` (failed, cancelled) or ``ERROR`` (pose lost) for ``/diagnostics``."""
        if self.state is NavigationState.POSE_LOST:
            return "ERROR"
        return "WARN" if self.state in (NavigationState.FAILED, NavigationState.CANCELLED) else "OK"

    def values(self) -> dict[str, str]:
        """Key/values of a ``/diagnostics`` status (all text)."""
        goal = "none" if self.goal_xy_m is None else f"{self.goal_xy_m[0]:.3f}, {self.goal_xy_m[1]:.3f}"
        which = f"{self.goal_index + 1} of {self.goal_count}" if self.goal_count else "none"
        return {"state": self.state.value, "goal_m": goal, "goal": which,
                "distance_to_go_m": f"{self.distance_to_go_m:.3f}",
                "heading_error_deg": f"{math.degrees(self.heading_error_rad):.1f}", "direction": self.direction,
                "turn_phase_rad": f"{self.turn_phase_rad:.3f}", "elapsed_s": f"{self.elapsed_s:.1f}",
                "inward_side": self.inward_side,
                "creep_amplitude_bar": "" if self.creep_amplitude_bar is None else f"{self.creep_amplitude_bar:g}",
                **{f"turn_rates_deg_per_cycle.{direction}": " ".join(f"{rate:+.1f}" for rate in rates)
                   for direction, rates in (self.turn_rates_deg_per_cycle or dict.fromkeys(DIRECTIONS, ())).items()}}
