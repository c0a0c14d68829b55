"""What the navigator learns from the camera while it drives: recent poses, turn rates, travel directions.

Nothing here assumes an exact model of the robot. :class:`TurnModel` starts from the identified turn map
and replaces it, level by level, with the turn rates the camera measured over whole cycles;
:class:`TravelModel` learns the angle between the body axis and the direction the robot actually rolls.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from srs_ros.core.errors import InvalidInputError
from srs_ros.core.navigation.settings import DIRECTIONS, MODEL_INWARD_SIDE, TurningMap, square_rad

#: Cycles after a gait change before the camera's cycle measurements count (the cross-fade and the body settle).
SETTLE_CYCLES = 0.5
#: Spread of one level's correction to its neighbours (rad of turn_phase): a measured bias is shared.
NEIGHBOUR_SPREAD_RAD = 0.2
#: The travel direction learned stays within this of square to the body (rad): a rolling body travels roughly
#: across its axis; a cycle measured beyond it (a reversal, a flop of the body) is not taken.
MAX_TRAVEL_SKEW_RAD = math.radians(60.0)
#: A cycle that moved the robot less than this (m) says nothing of where it travels.
MIN_CYCLE_TRAVEL_M = 0.02
#: Rolling cycles in a row that travel to the other side of the body before the navigator swaps its ends
#: (:class:`TravelSides`), and how near square to the body on that side such a cycle travels (rad).
SIDE_VOTES = 3
OTHER_SIDE_RAD = math.radians(45.0)
#: A level is kept unless another one comes this much closer to the asked rate (deg per cycle).
LEVEL_HYSTERESIS_DEG = 2.0


@dataclass(frozen=True)
class Pose2D:
    """The camera's pose of the robot: reference point (m, floor frame), yaw tail -> head (rad), time (s)."""

    x_m: float
    y_m: float
    yaw_rad: float
    time_s: float

    def check(self) -> Pose2D:
        """``self`` if every value is finite, else :class:`InvalidInputError` naming the bad one."""
        for name in ("x_m", "y_m", "yaw_rad", "time_s"):
            value = getattr(self, name)
            if not isinstance(value, (int, float, np.floating, np.integer)) or not math.isfinite(value):
                raise InvalidInputError(f"pose: {name} is {value!r}; expected a finite number.")
        return self


def wrap_rad(angle_rad: float) -> float:
    """``angle_rad`` wrapped to [-pi, pi)."""
    return (float(angle_rad) + math.pi) % (2.0 * math.pi) - math.pi


def arc_miss_m(radius_m: float, distance_m: float, error_rad: float) -> float:
    """How far the tightest arc toward a goal passes from it (m); 0 when an arc at least that wide reaches it.

    The arc has ``radius_m`` and starts heading ``error_rad`` away from a goal ``distance_m`` off. Its centre lies
    ``radius_m`` square to the heading on the goal's side; a goal inside that circle is missed by the radius less
    its distance from the centre, and no wider arc passes nearer to it.
    """
    along, across = distance_m * math.cos(error_rad), distance_m * abs(math.sin(error_rad))
    return max(0.0, radius_m - math.hypot(along, across - radius_m))


class PoseHistory:
    """The last ``keep_s`` seconds of poses, yaw unwrapped, with line fits over a recent window."""

    def __init__(self, keep_s: float = 10.0):
        self.keep_s = float(keep_s)
        self._rows: deque[tuple[float, float, float, float]] = deque()

    def __len__(self) -> int:
        return len(self._rows)

    def clear(self) -> None:
        """Forget every pose (after a gap, the unwrapped yaw would be meaningless)."""
        self._rows.clear()

    def add(self, pose: Pose2D) -> bool:
        """Append ``pose`` (checked); False (ignored) when it is not newer than the last one."""
        pose.check()
        if self._rows and pose.time_s <= self._rows[-1][0]:
            return False
        yaw = pose.yaw_rad
        if self._rows:
            yaw = self._rows[-1][3] + wrap_rad(pose.yaw_rad - self._rows[-1][3])
        self._rows.append((float(pose.time_s), float(pose.x_m), float(pose.y_m), float(yaw)))
        while self._rows and self._rows[-1][0] - self._rows[0][0] > self.keep_s:
            self._rows.popleft()
        return True

    def window(self, duration_s: float) -> np.ndarray:
        """Rows ``(n, 4)``: time_s, x_m, y_m, unwrapped yaw_rad, of the last ``duration_s``."""
        if not self._rows:
            return np.zeros((0, 4))
        rows = np.array(self._rows)
        return rows[rows[:, 0] >= rows[-1, 0] - duration_s]

    def at_rest(self, duration_s: float, within_m: float = 0.005) -> bool:
        """True when poses cover the last ``duration_s`` and the reference point stayed within ``within_m``."""
        rows = self.window(duration_s)
        if len(rows) < 3 or rows[-1, 0] - rows[0, 0] < 0.8 * duration_s:
            return False
        return float(np.max(np.linalg.norm(rows[:, 1:3] - rows[-1, 1:3], axis=1))) <= within_m

    def turn_yaws(self, delta_rad: float) -> None:
        """Add ``delta_rad`` to every stored yaw (the controller took the body's other end as its head)."""
        self._rows = deque((t, x, y, yaw + float(delta_rad)) for t, x, y, yaw in self._rows)

    def smoothed_yaw_rad(self, duration_s: float) -> float:
        """The yaw now from a line fit over the last ``duration_s`` (a rolling body's yaw wobbles within a cycle)."""
        rows = self.window(duration_s)
        if len(rows) < 3 or rows[-1, 0] - rows[0, 0] < 0.2 * duration_s:
            return float(rows[-1, 3]) if len(rows) else 0.0
        slope, intercept = np.polyfit(rows[:, 0] - rows[-1, 0], rows[:, 3], 1)
        return float(intercept)


@dataclass(frozen=True)
class CycleMeasurement:
    """One whole cycle seen by the camera: turn (deg, counter-clockwise positive), displacement (m), mean yaw."""

    turn_deg: float
    displacement_m: np.ndarray
    mean_yaw_rad: float


def measure_cycle(history: PoseHistory, period_s: float) -> CycleMeasurement | None:
    """The last ``period_s`` of poses as a :class:`CycleMeasurement`; None when too few poses cover it."""
    rows = history.window(period_s)
    if len(rows) < 5 or rows[-1, 0] - rows[0, 0] < 0.8 * period_s:
        return None
    slope = np.polyfit(rows[:, 0], rows[:, 3], 1)[0]
    return CycleMeasurement(math.degrees(slope * period_s), rows[-1, 1:3] - rows[0, 1:3], float(np.mean(rows[:, 3])))


class TravelSides:
    """Which side of the body the rolling gaits travel to, as the camera sees it: the model's, or the other.

    The model's robot rolls inward to the left of its tail -> head heading and outward to the right (config/sim.yaml,
    docs/studies/simulation.md "Which way a held spin rolls"). A robot wired as its mirror image (each module's muscles
    relabelled as a mirror relabels them), or one whose body holds its spin (config/sim_held_spin.yaml), rolls
    inward to the right: to the sides of the model's robot seen from its other end (its turn rates and rests after
    a stop are its own: give it its own turn map). After
    :data:`SIDE_VOTES` cycles in a row that travelled within :data:`OTHER_SIDE_RAD` of square to the body on the
    other side, the navigator takes the head for the tail: its poses' yaw turned by pi (:attr:`yaw_offset_rad`) and
    its moves along the axis swapped forward for backward. One flag for every gait setting: a body whose side
    changed with the frequency would swap back and forth between cruise and creep.
    """

    def __init__(self, votes_needed: float = SIDE_VOTES):
        """``votes_needed``: cycles in a row on the other side that swap the ends (``math.inf``: never)."""
        self.swapped = False  # False: inward rolling travels to the left, as the model's robot (MODEL_INWARD_SIDE)
        self.votes_needed = votes_needed
        self._votes = 0

    @property
    def yaw_offset_rad(self) -> float:
        """What to add to the camera's tail -> head yaw."""
        return math.pi if self.swapped else 0.0

    @property
    def inward_side(self) -> str:
        """Where inward rolling travels, seen along the camera's tail -> head heading."""
        return "right" if self.swapped else MODEL_INWARD_SIDE

    def observe(self, direction: str, cycle: CycleMeasurement) -> bool:
        """Count a rolling cycle (its yaw in the controller's frame); True when it swaps the ends now.

        A cycle that travelled at least :data:`MIN_CYCLE_TRAVEL_M` counts: on the other side it is a vote, anywhere
        else (the model's side, along the axis, a flop) it starts the count again.
        """
        dx, dy = cycle.displacement_m
        if direction not in DIRECTIONS or math.hypot(dx, dy) < MIN_CYCLE_TRAVEL_M:
            return False
        measured = wrap_rad(math.atan2(dy, dx) - cycle.mean_yaw_rad)
        other_side = abs(wrap_rad(measured - square_rad(direction) - math.pi)) <= OTHER_SIDE_RAD
        self._votes = self._votes + 1 if other_side else 0
        if self._votes < self.votes_needed:
            return False
        self.swapped, self._votes = not self.swapped, 0
        return True


class TurnModel:
    """Turn rate (deg per cycle) per rolling direction and turn level: the map's guess, corrected online."""

    def __init__(self, turning_map: TurningMap, levels_rad, learning_rate: float):
        self.levels_rad = np.asarray(levels_rad, dtype=np.float64)
        self.learning_rate = float(learning_rate)
        self.rates = {d: turning_map[d].rate_at(self.levels_rad).astype(np.float64) for d in DIRECTIONS}
        self.measured = {d: np.zeros(len(self.levels_rad), dtype=int) for d in DIRECTIONS}

    def learn(self, direction: str, level_index: int, measured_deg: float) -> None:
        """Move the level's estimate toward a measured cycle; its neighbours get a share of the correction."""
        error = measured_deg - self.rates[direction][level_index]
        spread = np.exp(-np.abs(self.levels_rad - self.levels_rad[level_index]) / NEIGHBOUR_SPREAD_RAD)
        spread[level_index] = 1.0
        untouched = self.measured[direction] == 0
        weight = np.where(untouched, spread, 0.0)
        weight[level_index] = 1.0
        self.rates[direction] += self.learning_rate * error * weight
        self.measured[direction][level_index] += 1

    def choose(self, direction: str, wanted_deg: float, current_index: int | None) -> int:
        """The level whose estimated rate is nearest ``wanted_deg`` (the current one kept within a small margin)."""
        misses = np.abs(self.rates[direction] - wanted_deg)
        best = int(np.argmin(misses))
        if current_index is not None and misses[current_index] <= misses[best] + LEVEL_HYSTERESIS_DEG:
            return current_index
        return best

    def fastest_deg(self, direction: str, sign: int) -> tuple[int, float]:
        """The level turning fastest in the sense ``sign`` (+1 counter-clockwise) and its rate (deg per cycle)."""
        rates = self.rates[direction] * sign
        index = int(np.argmax(rates))
        return index, float(self.rates[direction][index])


class TravelModel:
    """Per direction and turn level, the angle (rad) from the body's yaw to where the robot travels, learned online.

    A rolling body that turns fast travels at an angle well away from square to its axis (the travel lags the
    turn), so each level has its own estimate; a measured level shares its correction with unmeasured ones.
    """

    def __init__(self, levels_rad, learning_rate: float, turning_map: TurningMap):
        self.levels_rad = np.asarray(levels_rad, dtype=np.float64)
        self.learning_rate = float(learning_rate)
        self.offset_rad = {d: np.full(len(self.levels_rad), square_rad(d)) for d in DIRECTIONS}
        self.travel_m = {d: turning_map[d].travel_at(self.levels_rad).astype(np.float64) for d in DIRECTIONS}
        self.measured = {d: np.zeros(len(self.levels_rad), dtype=int) for d in DIRECTIONS}

    def offset(self, direction: str, level_index: int | None) -> float:
        """The offset of a level (None: the mean over the levels)."""
        offsets = self.offset_rad[direction]
        if level_index is not None:
            return float(offsets[level_index])
        return math.atan2(float(np.mean(np.sin(offsets))), float(np.mean(np.cos(offsets))))

    def learn(self, direction: str, level_index: int, cycle: CycleMeasurement) -> None:
        """Take a cycle's travel direction into the estimate (ignored when the robot hardly moved)."""
        dx, dy = cycle.displacement_m
        if math.hypot(dx, dy) < MIN_CYCLE_TRAVEL_M:
            return
        measured = wrap_rad(math.atan2(dy, dx) - cycle.mean_yaw_rad)
        if abs(wrap_rad(measured - square_rad(direction))) > MAX_TRAVEL_SKEW_RAD:
            return
        error = wrap_rad(measured - self.offset_rad[direction][level_index])
        spread = np.exp(-np.abs(self.levels_rad - self.levels_rad[level_index]) / NEIGHBOUR_SPREAD_RAD)
        weight = np.where(self.measured[direction] == 0, spread, 0.0)
        weight[level_index] = 1.0
        offsets = self.offset_rad[direction] + self.learning_rate * error * weight
        self.offset_rad[direction] = (offsets + math.pi) % (2.0 * math.pi) - math.pi
        self.travel_m[direction] += self.learning_rate * (math.hypot(dx, dy) - self.travel_m[direction]) * weight
        self.measured[direction][level_index] += 1
