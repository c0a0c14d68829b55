"""Moves along the body's axis from rest: the straight serpentine, learned per floor, for the fine approach.

A rolling robot creeps to a goal near it along the line square to its body. A goal off that line by a few
centimetres was only reachable by a turn on the spot (two 4 bar rolling strokes), which on an anisotropic floor
moves the resting body 15-30 cm as much as it turns it (docs/navigation.md). On such a floor the serpentine moves
the body along its own axis instead: from rest, 4 bar 1 Hz, 10.6-12.7 cm forward in two cycles whichever way the
body lay (measured: ``python benchmarks/bench_serpentine_turn.py --physics anisotropic --c 0 --cycles 2``), and
backward when played backward. Moving along the axis is moving across the creeping line, so it puts the goal on
the line without turning the body round. On an isotropic floor the serpentine hardly moves the body (the paper's
Table I: under 1 cm/s), so :class:`AxisShuffle` learns the step per cycle from every move (rest to rest, along
the body's axis before it) and stops offering the move once the step is below :data:`SHUFFLE_MIN_STEP_M`: the
floor is not told, it is seen. (A first move of one cycle only, a cheaper probe for isotropic floors, reached 58
of 70 goals on the anisotropic floor against 66, seeds 1-7: not kept; single cycles from rest moved the body
0.6-3.6 cm there, a noisy measure of the step.)
"""

from __future__ import annotations

import math

from srs_ros.core.navigation.commands import AXIS_DIRECTIONS
from srs_ros.core.navigation.motion import Pose2D

#: First guess of the step along the body's axis per cycle of the serpentine played forward (m, positive toward
#: the body's yaw): 4 bar 1 Hz from rest on the anisotropic floor, 10.6-12.7 cm in two cycles with the ramps
#: (bench_serpentine_turn.py above); 3.7 cm per cycle seen in the navigator's own moves. Taken whole at the
#: first move, then learned.
SHUFFLE_STEP_GUESS_M = 0.04
#: A learned step smaller than this (m per cycle) is no step: the move is not offered again on this floor.
SHUFFLE_MIN_STEP_M = 0.015
#: A goal farther off the creeping line than this (m) is left to the turn on the spot or the cruise gait.
SHUFFLE_MAX_M = 0.25


class AxisShuffle:
    """Whether a move along the body's axis is worth playing, how many cycles, and what one cycle moves."""

    def __init__(self, learning_rate: float):
        self.learning_rate = float(learning_rate)
        self.step_m = SHUFFLE_STEP_GUESS_M  # per cycle of the serpentine played forward, along the body's yaw
        self.moves = 0  # moves measured
        self._from: tuple[Pose2D, float, int] | None = None  # (the resting pose, its body yaw, signed cycles)

    @property
    def useful(self) -> bool:
        """False once the floor was seen not to let the serpentine move the body."""
        return abs(self.step_m) >= SHUFFLE_MIN_STEP_M

    def plan(self, move_m: float, max_cycles: int) -> tuple[str, int] | None:
        """The direction and cycles (at most ``max_cycles``) that move the body ``move_m`` along its yaw (m).

        None when not worth it: ``max_cycles`` 0 (switched off), a floor seen not to let the body move, a move
        longer than :data:`SHUFFLE_MAX_M`.
        """
        if max_cycles <= 0 or not self.useful or abs(move_m) > SHUFFLE_MAX_M:
            return None
        cycles = max(1, min(int(max_cycles), round(abs(move_m) / abs(self.step_m))))
        forward = (move_m > 0.0) == (self.step_m > 0.0)
        return AXIS_DIRECTIONS[0] if forward else AXIS_DIRECTIONS[1], cycles

    def start(self, pose: Pose2D, body_yaw_rad: float, direction: str, cycles: int) -> None:
        """A move starts from rest at ``pose``: measured when the body rests again (:meth:`learn`)."""
        self._from = (pose, float(body_yaw_rad), cycles if direction == AXIS_DIRECTIONS[0] else -cycles)

    def learn(self, pose: Pose2D) -> None:
        """The body rests after a move: take its step per cycle (along the yaw it had before) into the estimate."""
        if self._from is None:
            return
        start, yaw, signed_cycles = self._from
        self._from = None
        moved = (pose.x_m - start.x_m) * math.cos(yaw) + (pose.y_m - start.y_m) * math.sin(yaw)
        step = moved / signed_cycles  # a cycle played backward steps as one forward, the other way
        rate = 1.0 if self.moves == 0 else self.learning_rate
        self.step_m += rate * (step - self.step_m)
        self.moves += 1

    def forget_move(self) -> None:
        """A move interrupted (a new goal, a cancel): nothing to learn from where the body rests next."""
        self._from = None
