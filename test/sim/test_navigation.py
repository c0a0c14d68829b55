"""The navigator's controller on the simulated robot (MuJoCo), offline: refusal, cancel, replacement, lost pose.

Whether it reaches random goals is the slow test at the end and benchmarks/bench_navigation.py.
"""


import math

import numpy as np
import pytest

from srs_ros.core.errors import InvalidInputError
from srs_ros.core.navigation import NavigationState
from srs_ros.sim.config import load_sim_config
from srs_ros.sim.navigation import GaitDriver, run_navigation


def test_a_goal_outside_the_view_is_refused_without_moving():
    result = run_navigation([(3.0, 0.0)])
    (outcome,) = result.outcomes
    assert outcome.state is NavigationState.IDLE and outcome.message.startswith("refused: goal (3.000, 0.000) m")
    assert "outside the camera's calibrated floor area" in outcome.message and len(result.rows) == 0


def test_a_replaced_goal_is_driven_to_and_a_cancel_stops_and_vents():
    seen = {}

    def events(now_s, controller):
        if "replaced" not in seen and now_s >= 1.5:
            seen["replaced"] = controller.set_goal(-0.4, 0.3, now_s).accepted
        if "cancelled" not in seen and now_s >= 4.0:
            controller.cancel(now_s, "cancelled by the test")
            seen["cancelled"] = now_s

    result = run_navigation([(0.3, 0.6)], events=events, goal_timeout_s=20.0)
    (outcome,) = result.outcomes
    assert seen["replaced"] and outcome.state is NavigationState.CANCELLED
    assert outcome.message == "cancelled by the test"
    columns = result.rows
    after = columns[columns[:, 0] >= seen["cancelled"] + 0.1]
    assert np.all(after[:, 11] == 0.0)                    # no gait commanded after the cancel
    assert outcome.time_s < seen["cancelled"] + 3.0       # the ramp-out ends within the ramp time and a bit


def test_a_path_in_rounds_is_given_to_the_controller_as_the_navigator_patrols_it():
    seen = []
    result = run_navigation([(0.3, 0.0), (0.3, 0.3)], as_path=True, rounds=3, goal_timeout_s=0.1,
                            events=lambda now_s, nav: seen.append((nav.goals, nav.waypoint(), nav.progress(now_s))))
    goals, where, progress = seen[1]
    assert len(goals) == 6 and where == (0, 2, 1) and "waypoint 1 of 2 (round 1)" in progress.message
    assert len(result.outcomes) == 1 and "gave up after 0.6 s" in result.outcomes[0].message  # 0.1 s a point
    with pytest.raises(InvalidInputError, match="rounds"):
        run_navigation([(0.3, 0.0)], as_path=True, rounds=0)


@pytest.mark.parametrize("kwargs, match", [
    ({"goals": (0.3, 0.0)}, r"goals: expected one or more \(x_m, y_m\) pairs"),  # a flat pair: a TypeError before
    ({"goals": [(0.3, 0.0)], "rounds": math.nan}, "rounds: expected a whole number"),  # a ValueError before
    ({"goals": [(0.3, 0.0)], "goal_timeout_s": math.nan}, "goal_timeout_s: expected simulated seconds > 0"),
    ({"goals": [(0.3, 0.0)], "goal_timeout_s": 0.0}, "goal_timeout_s: expected simulated seconds > 0"),
])
def test_bad_arguments_are_refused_as_such_before_the_world_is_built(kwargs, match):
    """A NaN goal timeout never gave a goal up, 0 cancelled it at the first frame (a helper's review)."""
    with pytest.raises(InvalidInputError, match=match):
        run_navigation(**kwargs)


def test_a_robot_the_camera_does_not_see_is_stopped_with_the_reason():
    config = load_sim_config().replace("start", x_m=2.2)   # beyond the simulated camera's view (x up to 1.43 m)
    result = run_navigation([(0.5, 0.0)], config=config, camera=True, goal_timeout_s=10.0)
    (outcome,) = result.outcomes
    assert outcome.state is NavigationState.POSE_LOST
    assert "no pose from the camera for 1." in outcome.message
    assert 1.0 < outcome.time_s < 3.5
    assert np.all(np.isnan(result.rows[:, 4]))            # the tracker never gave a pose


def test_the_offline_driver_plays_outward_as_the_inward_cycle_backward():
    from srs_ros.core.navigation import GaitCommand
    from srs_ros.core.robot import default_robot

    driver = GaitDriver(default_robot())
    driver.apply(GaitCommand("outward_rolling", 0.2, 4.0, 1.0))
    pressures = [driver.pressures_bar(0.005) for _ in range(400)]
    assert driver.playback.reverse and driver.playback.frequency_hz == pytest.approx(-1.0)
    assert max(float(p.max()) for p in pressures) <= 4.0 + 1e-9
    driver.apply(GaitCommand(None, 0.0, 4.0, 1.0))
    for _ in range(400):
        last = driver.pressures_bar(0.005)
    assert np.all(last == 0.0)


@pytest.mark.slow(seconds=4)
def test_on_the_anisotropic_floor_a_goal_off_the_line_is_reached_by_a_move_along_the_axis():
    """At rest, a goal 14 cm off the creeping line along the body's axis: the serpentine moves the body onto the line
    (the floor's friction lets it, 3-4 cm per cycle), then it creeps to the goal (after 17.2 s). Real MuJoCo, about
    3 s alone.

    The goal is given the DDS runs' 120 s. The goal 12 cm off, this test's until stop 57, was reached after 19.6 s
    when the move was added (2214054), 32.9 s with the 1.5 bar creep (180778e) and 58.9 s since the creep's stop ends
    once the robot is seen at rest (7719566; the creep then judged on and off its line by turns): each rule was kept
    for the benchmark's sets of goals, not for this one, and its 60 s left the test a second from failing."""
    from srs_ros.sim.config import with_friction
    from srs_ros.sim.navigation import COLUMNS, DIRECTION_CODES

    result = run_navigation([(-0.14, 0.25)], config=with_friction(load_sim_config(), "anisotropic"),
                            goal_timeout_s=120.0)
    (outcome,) = result.outcomes
    assert outcome.reached and outcome.final_error_m <= 0.05, outcome.summary()
    played = set(result.rows[:, COLUMNS.index("direction")].tolist())
    assert played & {DIRECTION_CODES["serpentine_forward"], DIRECTION_CODES["serpentine_backward"]}, played


@pytest.mark.slow(seconds=8)
def test_on_a_body_that_rolls_to_the_other_sides_the_navigator_swaps_its_ends_and_drives_to_the_goal():
    """config/sim_held_spin.yaml rolls inward to the right of its tail -> head heading, the model's robot to the left
    (docs/simulation.md, "A held spin"): a fresh controller learns it from the camera within a few cycles, takes the
    head for the tail and comes within 10 cm of the goal (without the swap it ends 2.9 m away;
    docs/studies/navigation.md "A robot that rolls to the other sides": on this physics the end game leaves some goals
    4-24 cm off). Real MuJoCo."""
    from srs_ros.core.navigation import load_navigation_settings
    from srs_ros.core.robot import config_dir

    settings = load_navigation_settings({"turning_map_file": str(config_dir() / "turning_map_held_spin.yaml")})
    goal, seen = np.array([0.828, 0.202]), []
    result = run_navigation([tuple(goal)], config=load_sim_config(config_dir() / "sim_held_spin.yaml"),
                            settings=settings, goal_timeout_s=60.0, on_frame=lambda state, image, nav: seen.append(
                                (nav.sides.swapped, float(np.linalg.norm(state.reference_xy_m - goal)), state.time_s)))
    (outcome,) = result.outcomes
    swapped_s = [time_s for flag, _, time_s in seen if flag]
    assert not seen[0][0] and swapped_s and swapped_s[0] < 15.0, outcome.summary()
    assert min(distance for _, distance, _ in seen) < 0.10 and outcome.final_error_m < 0.25, outcome.summary()
