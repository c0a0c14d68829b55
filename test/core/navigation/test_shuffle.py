"""Moves along the body's axis (srs_ros.core.navigation.shuffle): planned from the step learned rest to rest."""

import math

import pytest

from srs_ros.core.navigation.commands import AXIS_DIRECTIONS, AXIS_GAIT, GAIT, GaitCommand
from srs_ros.core.navigation.motion import Pose2D
from srs_ros.core.navigation.shuffle import (
    SHUFFLE_MAX_M,
    SHUFFLE_MIN_STEP_M,
    SHUFFLE_STEP_GUESS_M,
    AxisShuffle,
)

FORWARD, BACKWARD = AXIS_DIRECTIONS


def test_the_serpentine_commands_name_their_gait_its_straight_c_and_which_way_it_plays():
    forward, backward = GaitCommand(FORWARD, 0.3, 4.0, 1.0), GaitCommand(BACKWARD, 0.3, 4.0, 1.0)
    assert forward.gait == backward.gait == AXIS_GAIT == "serpentine"
    assert forward.gait_parameters == {"c_rad_per_unit": 0.0}  # straight, whatever turn level came with it
    assert not forward.reverse and backward.reverse and forward.along_axis and backward.along_axis
    assert forward.cycle_key == backward.cycle_key == ("serpentine", 4.0, 0.0)  # a reversal needs no new cycle
    rolling = GaitCommand("outward_rolling", 0.2, 4.0, 1.0)
    assert rolling.gait == GAIT and rolling.gait_parameters == {"turn_phase_rad": 0.2} and rolling.reverse
    assert not rolling.along_axis and rolling.cycle_key == (GAIT, 4.0, 0.2)


def test_a_move_is_planned_in_whole_cycles_of_the_learned_step_and_not_beyond_its_reach():
    shuffle = AxisShuffle(learning_rate=0.5)
    assert shuffle.step_m == SHUFFLE_STEP_GUESS_M
    assert shuffle.plan(0.085, max_cycles=3) == (FORWARD, 2)  # 0.085 / 0.04: two cycles forward
    assert shuffle.plan(-0.03, max_cycles=3) == (BACKWARD, 1)
    assert shuffle.plan(0.005, max_cycles=3) == (FORWARD, 1)  # never zero cycles
    assert shuffle.plan(0.2, max_cycles=3) == (FORWARD, 3)  # at most max_cycles
    assert shuffle.plan(0.2, max_cycles=0) is None  # switched off
    assert shuffle.plan(SHUFFLE_MAX_M + 0.01, max_cycles=3) is None  # left to the turn on the spot


def test_the_step_is_learned_from_rest_to_rest_along_the_yaw_before_the_move():
    shuffle = AxisShuffle(learning_rate=0.5)
    yaw = math.radians(30.0)
    start = Pose2D(1.0, 2.0, yaw, 0.0)
    shuffle.start(start, yaw, BACKWARD, 2)
    # two cycles backward moved the body 6 cm back along its yaw and 10 cm sideways (the across part is not the step)
    along, side = -0.06, 0.10
    shuffle.learn(Pose2D(1.0 + along * math.cos(yaw) - side * math.sin(yaw),
                         2.0 + along * math.sin(yaw) + side * math.cos(yaw), yaw, 5.0))
    assert shuffle.step_m == pytest.approx(0.03)  # the first move taken whole: 3 cm per cycle forward
    shuffle.learn(Pose2D(5.0, 5.0, 0.0, 9.0))  # no move under way: nothing learned
    assert shuffle.step_m == pytest.approx(0.03)
    shuffle.start(start, yaw, FORWARD, 1)
    shuffle.learn(Pose2D(1.0 + 0.05 * math.cos(yaw), 2.0 + 0.05 * math.sin(yaw), yaw, 12.0))
    assert shuffle.step_m == pytest.approx(0.04)  # then at the learning rate
    shuffle.start(start, yaw, FORWARD, 1)
    shuffle.forget_move()  # a new goal mid-move: where the body rests next is not this move's step
    shuffle.learn(Pose2D(3.0, 3.0, yaw, 20.0))
    assert shuffle.step_m == pytest.approx(0.04)


def test_a_floor_where_the_serpentine_does_not_move_the_body_gets_no_more_moves():
    shuffle = AxisShuffle(learning_rate=0.5)
    start = Pose2D(0.0, 0.0, 0.0, 0.0)
    shuffle.start(start, 0.0, FORWARD, 3)
    shuffle.learn(Pose2D(0.02, 0.15, 0.4, 6.0))  # 2 cm in three cycles (it turned and slid across instead)
    assert shuffle.step_m < SHUFFLE_MIN_STEP_M and not shuffle.useful
    assert shuffle.plan(0.05, max_cycles=3) is None


def test_a_floor_that_moves_the_body_tail_first_plays_the_serpentine_the_other_way():
    shuffle = AxisShuffle(learning_rate=0.5)
    shuffle.start(Pose2D(0.0, 0.0, 0.0, 0.0), 0.0, FORWARD, 2)
    shuffle.learn(Pose2D(-0.08, 0.0, 0.0, 5.0))  # forward moved it back 4 cm per cycle
    assert shuffle.step_m == pytest.approx(-0.04)
    assert shuffle.plan(0.08, max_cycles=3) == (BACKWARD, 2)
    assert shuffle.plan(-0.04, max_cycles=3) == (FORWARD, 1)
