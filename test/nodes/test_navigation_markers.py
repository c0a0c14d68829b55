"""navigation_markers: what the navigator draws for RViz, built in-process from its progress (no DDS here).

Over DDS, the navigator's markers on the simulated robot: test_navigator.py.
"""

import math

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from visualization_msgs.msg import Marker

from srs_ros.core.navigation import NavigationState
from srs_ros.core.navigation.commands import NavigationProgress
from srs_ros.ros.navigation_markers import STATE_RGBA, Track, navigation_markers

STAMP = Time(sec=12, nanosec=5)


def progress(state: NavigationState, goal=(0.4, -0.2), distance_m=0.42) -> NavigationProgress:
    return NavigationProgress(state, goal, 0, 1, distance_m, 0.1, "inward_rolling", 0.0, 3.0, "test")


def by_namespace(markers) -> dict[str, Marker]:
    return {m.ns: m for m in markers.markers}


def test_the_goal_is_a_disc_of_the_tolerance_with_the_state_over_it_and_the_way_ahead_from_the_robot():
    goals_ahead = [(0.4, -0.2), (0.8, 0.1)]
    trail = [(0.0, 0.0), (0.05, -0.01), (0.1, -0.03)]
    markers = by_namespace(navigation_markers(progress(NavigationState.DRIVING), goals_ahead, (0.1, -0.03), trail,
                                              0.05, STAMP))
    assert set(markers) == {"goal", "status", "path ahead", "track"}
    assert all(m.header.frame_id == "floor" and m.header.stamp == STAMP and m.action == Marker.ADD
               for m in markers.values())
    disc = markers["goal"]
    assert disc.type == Marker.CYLINDER
    assert (disc.pose.position.x, disc.pose.position.y) == pytest.approx((0.4, -0.2))
    assert disc.scale.x == disc.scale.y == pytest.approx(0.10)  # the 5 cm tolerance all round
    assert markers["status"].type == Marker.TEXT_VIEW_FACING and markers["status"].text == "driving: 42.0 cm to go"
    ahead = [(p.x, p.y, p.z) for p in markers["path ahead"].points]
    assert np.allclose(ahead, [(0.1, -0.03, 0.0), (0.4, -0.2, 0.0), (0.8, 0.1, 0.0)])  # robot, then the waypoints
    assert np.allclose([(p.x, p.y) for p in markers["track"].points], trail)


def test_the_discs_colour_tells_driving_reached_and_failed_apart_and_nothing_is_ahead_once_reached():
    colours = {}
    for state in (NavigationState.DRIVING, NavigationState.REACHED, NavigationState.FAILED, NavigationState.CANCELLED):
        markers = by_namespace(navigation_markers(progress(state, distance_m=0.03), [], (0.39, -0.2), [], 0.05, STAMP))
        c = markers["goal"].color
        colours[state] = (c.r, c.g, c.b)
        assert markers["path ahead"].action == Marker.DELETE  # no goal ahead: no line from the robot
        assert markers["status"].text == f"{state.value}: 3.0 cm " + ("to go" if state.active else "from the goal")
    assert len(set(colours.values())) == 4, colours
    assert colours[NavigationState.REACHED] == pytest.approx(STATE_RGBA[NavigationState.REACHED][:3])
    assert colours[NavigationState.REACHED][1] > 0.5 and colours[NavigationState.FAILED][0] > 0.5  # green, red


def test_before_any_goal_every_marker_is_deleted_and_an_unknown_distance_shows_the_state_alone():
    markers = navigation_markers(progress(NavigationState.IDLE, goal=None, distance_m=math.nan), [], None, [], 0.05,
                                 STAMP)
    assert [m.action for m in markers.markers] == [Marker.DELETEALL]
    markers = by_namespace(navigation_markers(progress(NavigationState.POSE_LOST, distance_m=math.nan), [(0.4, -0.2)],
                                              None, [], 0.05, STAMP))
    assert markers["status"].text == "pose_lost"
    assert markers["path ahead"].action == Marker.DELETE  # the robot's place unknown: one point, nothing to draw
    assert markers["track"].action == Marker.DELETE


def test_the_track_keeps_a_point_a_step_thins_itself_and_restarts_from_the_last_place():
    track = Track(step_m=0.01, max_points=8)
    for i in range(40):  # 5 mm apart: every other one is a step
        track.add(0.005 * i, 0.0)
    assert len(track.points) <= 8 and track.points[0] == (0.0, 0.0)
    assert np.all(np.diff(np.array(track.points)[:, 0]) >= 0.01 - 1e-12)  # in order, a step or more apart
    assert track.last == track.points[-1] and track.last[0] >= 0.18  # still reaches the newest place
    track.restart()
    assert track.points == [track.last]
    track.add(track.last[0] + 0.004, 0.0)  # under a step: not kept
    assert len(track.points) == 1
