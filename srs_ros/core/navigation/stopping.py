"""Where the robot comes to rest after a stop, learned per rolling direction and gait phase.

A rolling body is curled; stopped, it rolls on while the gait ramps out and straightens, and its reference
point (the midpoint of its end markers) moves by up to 0.3 m. Stopped at one gait phase it rests at the
same place relative to its pose every time (millimetres), stopped anywhere within +-10 cm. So the navigator
stops only as the gait passes one of :data:`~srs_ros.core.navigation.settings.STOP_PHASES`, and predicts the
resting point from the offset learned at that phase.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from srs_ros.core.navigation.motion import Pose2D
from srs_ros.core.navigation.settings import DIRECTIONS, STOP_PHASES, TurningMap

#: A predicted resting point this close to the goal (times the tolerance) triggers the stop.
STOP_WITHIN = 0.8

#: Spread of one turn level's correction to its unmeasured neighbours (rad of turn_phase).
NEIGHBOUR_SPREAD_RAD = 0.2

#: A stop near the goal (not on it) waits for a later stop phase predicted to rest on it: the line through the last
#: two predicted resting points passes the goal more than this many of their steps ahead.
NEARER_AHEAD_STEPS = 0.5


@dataclasses.dataclass
class StopPlan:
    """A stop near the goal: how it was decided, where the robot is predicted to rest, where it stopped.

    Decided at ``decided`` (as the gait passed stop phase ``phase_index``), done at ``stopped`` (the pose as the
    gait passes that phase a cycle later, or at once), learned from after ``settle_s``.
    """

    decided: Pose2D
    direction: str
    level: int | None
    phase_index: int
    ahead: bool
    predicted_xy_m: tuple[float, float]
    stopped: Pose2D | None = None
    heading_rad: float = 0.0
    #: A stop of the fine approach's creep (:mod:`srs_ros.core.navigation.fine`): its resting points are learned there,
    #: and its settling ends once the robot is seen at rest (``cruise_stop.SETTLED_*``).
    fine: bool = False
    #: The gait's period when the stop was decided (s): the stop phase comes within it.
    period_s: float = 1.0


def crossed_phase(before: float, after: float, reverse: bool) -> int | None:
    """The index of the stop phase passed going from phase ``before`` to ``after`` (backward if ``reverse``)."""
    step = (before - after) % 1.0 if reverse else (after - before) % 1.0
    if step > 0.5:                     # a jump, not a step of the gait
        return None
    for index, phase in enumerate(STOP_PHASES):
        to_phase = (before - phase) % 1.0 if reverse else (phase - before) % 1.0
        if 0.0 < to_phase <= step or (to_phase == 0.0 and step > 0.0):
            return index
    return None


def landing_ahead(previous_xy_m, rest_xy_m, goal_xy_m, within_m: float) -> bool:
    """True when a later stop phase is predicted to rest on the goal (within ``within_m``) and this one is not.

    ``previous_xy_m`` and ``rest_xy_m``: the resting points predicted at the last stop phase and at this one (m);
    the later ones are taken on along their line: it passes the goal within ``within_m`` more than
    NEARER_AHEAD_STEPS of their steps beyond ``rest_xy_m``.
    """
    rest = np.asarray(rest_xy_m, dtype=np.float64)
    step = rest - np.asarray(previous_xy_m, dtype=np.float64)
    to_goal = np.asarray(goal_xy_m, dtype=np.float64) - rest
    length2 = float(step @ step)
    if length2 < 1e-6 or float(to_goal @ to_goal) <= within_m ** 2:  # no direction to go on along, or here already
        return False
    miss_m = abs(float(step[0] * to_goal[1] - step[1] * to_goal[0])) / math.sqrt(length2)
    return float(to_goal @ step) / length2 > NEARER_AHEAD_STEPS and miss_m <= within_m


def rotate(along_across: np.ndarray, heading_rad: float) -> np.ndarray:
    """(along, across) a heading -> floor (x, y)."""
    cos, sin = math.cos(heading_rad), math.sin(heading_rad)
    along, across = along_across
    return np.array([along * cos - across * sin, along * sin + across * cos])


class StopModel:
    """Per direction, turn level and stop phase, where the robot rests after a stop: (along, across) its travel (m).

    Starts from the turn map (per level when the map has them) and learns from every stop; a level's
    correction is shared with the levels not measured yet (as :class:`~srs_ros.core.navigation.motion.TurnModel`).
    """

    def __init__(self, turning_map: TurningMap, learning_rate: float, levels_rad=(0.0,)):
        self.learning_rate = float(learning_rate)
        self.levels_rad = np.asarray(levels_rad, dtype=np.float64)
        self.offset_m = {d: turning_map[d].stop_offset_at(self.levels_rad) for d in DIRECTIONS}
        self.measured = {d: np.zeros((len(self.levels_rad), len(STOP_PHASES)), dtype=int) for d in DIRECTIONS}

    def rest_offset(self, direction: str, phase_index: int, heading_rad: float,
                    level_index: int | None = None) -> np.ndarray:
        """Where the robot will rest, relative to its pose (floor frame, m), if stopped now at the phase.

        ``level_index`` None: the mean over the turn levels.
        """
        offsets = self.offset_m[direction][:, phase_index]
        return rotate(offsets.mean(axis=0) if level_index is None else offsets[level_index], heading_rad)

    def learn(self, direction: str, phase_index: int, heading_rad: float, moved_m: np.ndarray,
              level_index: int | None = None) -> None:
        """Take the measured move from the stop to the rest (floor frame) into the level's and phase's estimate.

        ``level_index`` None: every level; otherwise the unmeasured levels near it get a share.
        """
        measured = rotate(moved_m, -heading_rad)  # (along, across) the travel
        offsets = self.offset_m[direction]
        if level_index is None:
            weight = np.ones(len(self.levels_rad))
        else:
            spread = np.exp(-np.abs(self.levels_rad - self.levels_rad[level_index]) / NEIGHBOUR_SPREAD_RAD)
            weight = np.where(self.measured[direction][:, phase_index] == 0, spread, 0.0)
            weight[level_index] = 1.0
            self.measured[direction][level_index, phase_index] += 1
        offsets[:, phase_index] += self.learning_rate * weight[:, None] * (measured - offsets[:, phase_index])

    def mean_rest_offset(self, direction: str, heading_rad: float, level_index: int | None = None) -> np.ndarray:
        """:meth:`rest_offset` averaged over the stop phases (where to aim before knowing the phase).

        At the turn level ``level_index`` (None: averaged over the levels too).
        """
        offsets = self.offset_m[direction]
        return rotate((offsets.mean(axis=(0, 1)) if level_index is None else offsets[level_index].mean(axis=0)),
                      heading_rad)

    def steadiest_direction(self) -> str:
        """The direction whose learned rests lie nearest where it stopped (mean distance over levels and phases)."""
        return min(DIRECTIONS, key=lambda d: float(np.linalg.norm(self.offset_m[d], axis=-1).mean()))
