"""Which side of the body the rolling gaits travel to, learned from the camera (srs_ros.core.navigation.motion).

The model's robot rolls inward to the left of its tail -> head heading. A robot wired as its mirror image (each
module's muscles relabelled as a mirror relabels them), or one whose body holds its spin (config/sim_held_spin.yaml),
rolls inward to the right; the controller then takes its head for its tail (docs/navigation.md, "Which side the gaits
roll to").
"""

import math

import numpy as np
import pytest

from srs_ros.core.navigation import NavigationController, NavigationState, load_navigation_settings
from srs_ros.core.navigation.commands import GaitCommand
from srs_ros.core.navigation.motion import SIDE_VOTES, CycleMeasurement, TravelSides

from .standins import AREA, MAP, AxisRoller, Roller, drive, drive_to, settings
from .test_edge_guard import LaggingRoller


def cycle(travel_rad: float, yaw_rad: float = 0.3, metres: float = 0.09) -> CycleMeasurement:
    """A cycle that travelled ``metres`` at ``travel_rad`` from the body's yaw."""
    heading = yaw_rad + travel_rad
    return CycleMeasurement(0.0, metres * np.array([math.cos(heading), math.sin(heading)]), yaw_rad)


def test_cycles_in_a_row_on_the_other_side_swap_the_ends_and_a_single_flop_does_not():
    sides = TravelSides()
    assert (sides.swapped, sides.inward_side, sides.yaw_offset_rad) == (False, "left", 0.0)
    for _ in range(SIDE_VOTES - 1):  # inward rolling to the right of the yaw: the other side
        assert not sides.observe("inward_rolling", cycle(-math.pi / 2))
    assert not sides.observe("inward_rolling", cycle(math.pi / 2 - 0.3))  # the model's side again: the count restarts
    assert not sides.observe("outward_rolling", cycle(math.pi / 2, metres=0.01))  # too short to count
    for _ in range(SIDE_VOTES - 1):
        assert not sides.observe("outward_rolling", cycle(math.pi / 2 + 0.5))  # outward to the left: the other side
    assert not sides.observe("inward_rolling", cycle(0.0))  # along the axis (a flop): neither side, the count restarts
    for _ in range(SIDE_VOTES - 1):
        assert not sides.observe("inward_rolling", cycle(-math.pi / 2))
    assert sides.observe("inward_rolling", cycle(-math.pi / 2))
    assert (sides.swapped, sides.inward_side, sides.yaw_offset_rad) == (True, "right", math.pi)
    assert not sides.observe("serpentine_forward", cycle(math.pi))  # a move along the axis says nothing


def test_the_serpentine_plays_the_other_way_in_time_once_the_ends_are_swapped():
    forward = GaitCommand("serpentine_forward", 0.0, 4.0, 0.5)
    backward = GaitCommand("serpentine_backward", 0.0, 4.0, 0.5)
    assert (forward.reverse, backward.reverse) == (False, True)
    assert (GaitCommand("serpentine_forward", 0.0, 4.0, 0.5, ends_swapped=True).reverse,
            GaitCommand("serpentine_backward", 0.0, 4.0, 0.5, ends_swapped=True).reverse) == (True, False)
    assert GaitCommand("outward_rolling", 0.0, 4.0, 1.0, ends_swapped=True).reverse  # rolling: unchanged


def test_a_robot_that_rolls_to_the_other_sides_reaches_goals_in_every_direction():
    """Without the swap this robot heads away from its goals (test_edge_guard.py drives it to the view's edge)."""
    for goal in [(0.0, 0.6), (0.5, 0.5), (-0.6, 0.3), (-0.3, -0.6)]:
        controller, roller, said = NavigationController(settings(), AREA), Roller(travel_sign=-1.0), set()
        controller.set_goal(*goal, now_s=0.0)
        end = drive(controller, roller, 120.0,
                    each_frame=lambda now, c=controller, s=said: s.add(c.progress(now).message))
        assert controller.state is NavigationState.REACHED, controller.progress(end).message
        assert math.dist(goal, (roller.x, roller.y)) <= 0.05
        assert controller.sides.swapped and controller.progress(end).values()["inward_side"] == "right"
        assert any("inward rolling travels to the right of the camera's tail -> head heading" in m for m in said)


@pytest.mark.parametrize("goal", [(-0.6, 0.3), (0.45, 0.0), (0.0, 0.72)])
@pytest.mark.parametrize("roller_type", [Roller, LaggingRoller])
def test_a_robot_of_the_models_sides_never_swaps_its_ends(goal, roller_type):
    """Where a false swap is likeliest: a reversal that lags (the body goes on the old way for a while), a goal along
    the axis (a three-point turn: backing away while turning) and one near the view's edge (the edge guard)."""
    controller, roller, swapped = NavigationController(settings(), AREA), roller_type(), []
    controller.set_goal(*goal, now_s=0.0)
    drive(controller, roller, 120.0, each_frame=lambda now: swapped.append(controller.sides.swapped))
    assert controller.state is NavigationState.REACHED, controller.progress(0.0).message
    assert not any(swapped)


def test_with_the_ends_swapped_a_move_along_the_axis_still_goes_toward_the_goal():
    """After a cruise that swapped the ends, a goal 12 cm along the body (toward its real head) and 25 cm along the
    creeping line is reached by the serpentine played forward: the controller's 'backward', its ends swapped."""
    settings_ = load_navigation_settings({}, turning_map=MAP)
    controller, roller = NavigationController(settings_, AREA), AxisRoller(axis_step_m=0.04)
    roller.travel_sign = -1.0
    _, end = drive_to(controller, roller, (0.0, 0.6))
    assert controller.state is NavigationState.REACHED and controller.sides.swapped
    head = np.array([math.cos(roller.yaw), math.sin(roller.yaw)])
    creep = np.array([math.sin(roller.yaw), -math.cos(roller.yaw)])  # inward rolling: to the right of the yaw
    goal = tuple(np.array([roller.x, roller.y]) + 0.12 * head + 0.25 * creep)
    played, end = drive_to(controller, roller, goal, start_s=end + 1.0)
    assert controller.state is NavigationState.REACHED, controller.progress(end).message
    axis = [c for c in played if c.along_axis]
    assert axis and {(c.direction, c.reverse) for c in axis} == {("serpentine_backward", False)}
