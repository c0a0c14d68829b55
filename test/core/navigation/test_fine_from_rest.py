"""The fine approach from rest: turns on the spot, moves along the body's axis, and the wait for the robot to rest.

Near the goal but off the line the robot creeps on, the resting robot turns on the spot toward the line (an inward
and an outward stroke of the cruise gait) or moves along its own axis onto it where the floor lets the serpentine
move the body (srs_ros.core.navigation.approach); a creep's stop ends its settling once the pose is seen at rest.
The stand-ins are standins.AmplitudeRoller and its variants; the creep itself: test_fine_approach.py.
"""

import math

import numpy as np
import pytest

from srs_ros.core.navigation import NavigationController, NavigationState, Pose2D, load_navigation_settings
from srs_ros.core.navigation.settings import STOP_PHASES

from .standins import AREA, FRAME_S, GOALS, MAP, AmplitudeRoller, AxisRoller, drive, drive_to, run


def test_a_goal_near_the_resting_robot_and_near_its_axis_is_turned_to_on_the_spot_not_driven_round():
    """At rest 7 cm from the goal, 61 deg off the creeping line, where the serpentine does not move the stand-in: the
    goal is nearer than 2 x the tolerance, so it turns on the spot toward the line, whatever the turn. Beyond 60 deg
    it was left to the cruise gait, which switched direction every half cycle for a minute 4-7 cm from the goal,
    spinning the body round, and never stopped (the stall timer ended it)."""
    controller, roller, _ = run(None, (0.2, 0.5))
    assert controller.state is NavigationState.REACHED, controller.progress(0.0).message
    assert math.dist((0.2, 0.5), (roller.x, roller.y)) <= 0.05


def pivot_strokes(stops_learned=()):
    """The directions of the turn on the spot a resting robot plays toward a goal behind it and off its line."""
    settings = load_navigation_settings({}, turning_map=MAP)
    controller, roller = NavigationController(settings, AREA), AmplitudeRoller()
    for direction, rest_m in stops_learned:  # stops seen before: the robot rested rest_m ahead at every phase
        for phase in range(len(STOP_PHASES)):
            controller.stops.learn(direction, phase, 0.0, np.array([rest_m, 0.0]))
    controller.set_goal(0.10, -0.25, now_s=0.0)  # behind the inward travel (+y), 22 deg off the line
    strokes, now = [], 0.0
    while now < 10.0:
        controller.update_gait_phase(roller.phase)
        controller.update_pose(roller.pose(now))
        command = controller.tick(now)
        if command.moving and "on the spot" in command.reason and (not strokes or strokes[-1] != command.direction):
            strokes.append(command.direction)
        if strokes and not command.moving:
            break
        roller.step(command, now)
        now += FRAME_S
    return controller, strokes


def test_the_turn_on_the_spot_ends_with_the_direction_that_rolls_on_least_after_a_stop():
    """Outward rolling at 4 bar 1 Hz rests within about 5 cm of its stop, inward 14-27 cm ahead (the physics): the
    stroke before the stop is the steadier one, not the one toward the goal, so the turn leaves the robot where it
    was. What the controller learned of the stops decides it (the goal lies behind, on outward rolling's side)."""
    controller, strokes = pivot_strokes([("outward_rolling", 0.03), ("inward_rolling", 0.20)])  # as the physics
    assert controller.stops.steadiest_direction() == "outward_rolling"
    assert strokes == ["inward_rolling", "outward_rolling"]
    controller, strokes = pivot_strokes([("outward_rolling", 0.25), ("inward_rolling", 0.01)])
    assert controller.stops.steadiest_direction() == "inward_rolling"
    assert strokes == ["outward_rolling", "inward_rolling"]


class KickedRoller(AmplitudeRoller):
    """A 4 bar stroke started from rest kicks the body round, inward rolling counter-clockwise and outward rolling
    clockwise, by more than a turn on the spot's cycles turn it (on the calibrated physics one stroke from rest
    turned the body -24 deg inward and +28 deg outward, both ways more than its cycles:
    docs/studies/navigation.md, "The turn on the spot that turned the wrong way")."""

    KICK_DEG = 15.0

    def _roll(self, command):
        if command.amplitude_bar > 2.5:  # its cycles turn it a quarter as fast as AmplitudeRoller's
            self.scale, self.bias_deg = 0.175, 1.5
        super()._roll(command)

    def step(self, command, now_s):
        if command.moving and command.amplitude_bar > 2.5 and not getattr(self, "_was_moving", False):
            self.yaw += math.radians(self.KICK_DEG if command.direction == "inward_rolling" else -self.KICK_DEG)
        self._was_moving = command.moving
        super().step(command, now_s)


def test_a_turn_on_the_spot_seen_to_turn_the_wrong_way_is_not_used_that_way_again():
    """At rest 0.3 m from a goal 15 deg off its creeping line (no moves along the axis: the turn on the spot is
    tested). The turn on the spot the map chooses starts with the
    stroke whose kick turns the body away from the line, more than its cycles turn it toward it: the controller
    measures each turn on the spot from rest to rest, and once the first is seen to turn the wrong way it tries the
    strokes in the other order, which turn the right way, and reaches the goal. By the map alone (before) it played
    the same strokes again, turned the wrong way again and failed the goal after a minute without progress."""
    settings = load_navigation_settings({"axis_move_max_cycles": 0}, turning_map=MAP)
    controller, roller = NavigationController(settings, AREA), KickedRoller()
    goal = (0.3 * math.sin(math.radians(-15.0)), 0.3 * math.cos(math.radians(15.0)))  # 15 deg off the +y line
    controller.set_goal(*goal, now_s=0.0)
    starts, now = [], 0.0  # per turn on the spot: the sense asked, the body's yaw as it starts
    while now < 120.0 and (controller.state.active or roller.moving_or_settling(now)):
        controller.update_gait_phase(roller.phase)
        controller.update_pose(roller.pose(now))
        command = controller.tick(now)
        if controller.fine.pivot_sense and len(starts) < controller.fine.pivots:
            starts.append((controller.fine.pivot_sense, roller.yaw))
        roller.step(command, now)
        now += FRAME_S
    yaws = [yaw for _, yaw in starts] + [roller.yaw]  # creeping in between hardly turns the body
    turned = [(sense, math.degrees(after - before)) for (sense, before), after in zip(starts, yaws[1:])]
    wrong = [turn for sense, turn in turned if turn * sense < 0.0]
    assert turned and turned[0][1] * turned[0][0] < 0.0, turned  # the map's choice turned the body the wrong way
    assert len(wrong) == 1, turned  # ... once
    assert controller.state is NavigationState.REACHED, (controller.progress(now).message, turned)
    assert math.dist(goal, (roller.x, roller.y)) <= settings.goal_tolerance_m


#: At rest at the start (yaw 0: inward rolling travels +y), 25 cm along the creeping line and 12 cm off it,
#: along the body's axis: too far off the line to creep to.
OFF_THE_LINE = (0.12, 0.25)


def test_a_goal_off_the_line_is_reached_by_moving_along_the_axis_where_the_floor_lets_the_body():
    settings = load_navigation_settings({}, turning_map=MAP)
    controller, roller = NavigationController(settings, AREA), AxisRoller(axis_step_m=0.04)
    played, _ = drive_to(controller, roller, OFF_THE_LINE)
    assert controller.state is NavigationState.REACHED, controller.progress(0.0).message
    assert math.dist(OFF_THE_LINE, (roller.x, roller.y)) <= settings.goal_tolerance_m
    assert {c.direction for c in played if c.along_axis} == {"serpentine_forward"}  # toward the head: +x
    assert all(c.along_axis for c in played if c.amplitude_bar > settings.fine_amplitude_bar)  # no rolling stroke
    assert controller.fine.pivots >= 1 and controller.shuffle.step_m == pytest.approx(0.04, abs=0.005)


def test_without_moves_along_the_axis_the_same_goal_takes_turns_on_the_spot():
    settings = load_navigation_settings({"axis_move_max_cycles": 0}, turning_map=MAP)
    controller, roller = NavigationController(settings, AREA), AxisRoller(axis_step_m=0.04)
    played, _ = drive_to(controller, roller, OFF_THE_LINE)
    assert not any(c.along_axis for c in played)
    assert controller.fine.pivots >= 1  # turns on the spot: 4 bar rolling strokes from rest


def test_on_a_floor_where_the_serpentine_does_not_move_the_body_it_is_tried_once_then_left():
    settings = load_navigation_settings({}, turning_map=MAP)
    controller, roller = NavigationController(settings, AREA), AxisRoller(axis_step_m=0.0)
    played, end = drive_to(controller, roller, OFF_THE_LINE)
    assert controller.state is NavigationState.REACHED, controller.progress(end).message
    assert any(c.along_axis for c in played) and not controller.shuffle.useful  # tried, seen not to move it
    start = np.array([roller.x, roller.y])
    played, end = drive_to(controller, roller, tuple(start + [0.12, 0.25]), start_s=end + 1.0)
    assert not any(c.along_axis for c in played)  # the next goal off the line: straight to a turn on the spot


class DriftingRoller(AmplitudeRoller):
    """AmplitudeRoller that, after each creep, drifts on ``drift_m_s`` (m/s) along its travel for 2 s after resting."""

    def __init__(self, drift_m_s: float):
        super().__init__()
        self.drift_m_s = drift_m_s

    def pose(self, now_s):
        pose = super().pose(now_s)
        if self.rest is None or now_s < self.rest[0] or not hasattr(self, "_heading"):
            return pose
        drift_m = self.drift_m_s * min(now_s - self.rest[0], 2.0)
        return Pose2D(pose.x_m + drift_m * math.cos(self._heading), pose.y_m + drift_m * math.sin(self._heading),
                      pose.yaw_rad, now_s)


#: The kinematic stand-in's jump to its resting point comes this long after its stop (s; Roller.step).
LANDING_S = 0.8


def stop_waits(roller, goal, until_s=120.0):
    """Each stop as ``(creep, s from the robot's last motion until the controller leaves STOPPING)``, in order."""
    controller = NavigationController(load_navigation_settings({}, turning_map=MAP), AREA)
    controller.set_goal(*goal, now_s=0.0)
    waits, stopping = [], []  # stopping: the creep flag of the stop under way

    def each_frame(now):
        if controller.state is NavigationState.STOPPING and not stopping and roller._moving is not None:
            stopping.append(roller._moving.creep)  # the stand-in keeps the last moving command until it stops
        elif controller.state is not NavigationState.STOPPING and stopping:
            motion_ended_s = roller.rest[0] if roller.rest is not None else now  # the stand-in's jump to its rest
            waits.append((stopping.pop(), now - motion_ended_s))

    drive(controller, roller, until_s, each_frame=each_frame)
    return controller, waits


def test_a_creep_stop_ends_its_settling_once_the_robot_is_seen_at_rest_and_a_cruise_stop_waits_settle_s():
    settle_s = load_navigation_settings({}, turning_map=MAP).settle_s
    for goal in GOALS:
        controller, waits = stop_waits(AmplitudeRoller(), goal)
        assert controller.state is NavigationState.REACHED, (goal, controller.progress(0.0).message)
        creeps = [wait for creep, wait in waits if creep]
        cruises = [wait for creep, wait in waits if not creep]
        assert creeps and cruises, waits
        # The stand-in lands LANDING_S after its stop and is seen at rest over the 0.3 s window 0.3 s later, at
        # 1.1 s: 0.4 s before settle_s (1.5 s), which a cruise stop still waits (both counted from the landing).
        assert all(wait < settle_s - LANDING_S - 0.2 for wait in creeps), waits
        assert all(wait >= settle_s - LANDING_S - FRAME_S for wait in cruises), waits


def test_a_creep_stop_still_drifting_waits_the_whole_settle_s():
    settle_s = load_navigation_settings({}, turning_map=MAP).settle_s
    _, waits = stop_waits(DriftingRoller(drift_m_s=0.01), GOALS[0])  # 3 mm per 0.3 s: over the 2 mm of "at rest"
    creeps = [wait for creep, wait in waits if creep]
    assert creeps and all(wait >= settle_s - LANDING_S - FRAME_S for wait in creeps), waits


@pytest.mark.parametrize("offset_m", [0.0, 0.02, 0.045])
def test_a_goal_given_within_the_tolerance_of_the_resting_robot_is_reached_where_it_lies(offset_m):
    """It crept to a goal 0-2 cm from the resting robot, moving it off the goal (a helper's review)."""
    settings = load_navigation_settings({}, turning_map=MAP)
    controller, roller = NavigationController(settings, AREA), AmplitudeRoller()
    controller.set_goal(roller.x + offset_m, roller.y, now_s=0.0)
    now, moved = 0.0, False
    while now < 3.0 and controller.state.active:
        controller.update_gait_phase(roller.phase)
        controller.update_pose(roller.pose(now))
        moved |= controller.tick(now).moving
        now += FRAME_S
    assert controller.state is NavigationState.REACHED and not moved, controller.progress(now).message
    assert "where the robot already lay" in controller.progress(now).message
