"""What the navigator draws for RViz on ``navigation_markers``: the goal, the way ahead and the track driven.

:func:`navigation_markers` builds the MarkerArray from the controller's progress (docs/navigation.md,
"`navigation_markers`: what RViz shows"); :class:`Track` keeps the tracked places since the last goal came.
"""

from __future__ import annotations

import math

from visualization_msgs.msg import Marker, MarkerArray

from srs_ros.core.navigation import NavigationState
from srs_ros.ros.interfaces import floor_marker, line_strip_marker

#: Published at most this often (s), and at every state change.
MARKERS_PERIOD_S = 0.5
#: The track keeps a point every TRAIL_STEP_M of motion; past TRAIL_MAX_POINTS every other one is dropped.
TRAIL_STEP_M = 0.01
TRAIL_MAX_POINTS = 500
DRIVING_RGBA = (1.0, 0.65, 0.0, 0.6)
#: The goal's disc by state (RGBA): driving amber, reached green, failed or pose lost red, else (cancelled) grey.
STATE_RGBA = {NavigationState.DRIVING: DRIVING_RGBA, NavigationState.STOPPING: DRIVING_RGBA,
              NavigationState.REACHED: (0.1, 0.8, 0.2, 0.6), NavigationState.FAILED: (0.9, 0.1, 0.1, 0.6),
              NavigationState.POSE_LOST: (0.9, 0.1, 0.1, 0.6)}
IDLE_RGBA = (0.6, 0.6, 0.6, 0.5)
#: (namespace, id) of each marker.
GOAL, STATUS, PATH_AHEAD, TRACK = ("goal", 0), ("status", 1), ("path ahead", 2), ("track", 3)


class Track:
    """The tracked places (x, y) m since :meth:`restart`: a point every ``step_m``, thinned past ``max_points``."""

    def __init__(self, step_m: float = TRAIL_STEP_M, max_points: int = TRAIL_MAX_POINTS):
        self.step_m, self.max_points = step_m, max_points
        self.points: list[tuple[float, float]] = []

    def add(self, x_m: float, y_m: float) -> None:
        if self.points and math.dist(self.points[-1], (x_m, y_m)) < self.step_m:
            return
        self.points.append((float(x_m), float(y_m)))
        if len(self.points) > self.max_points:
            self.points = self.points[::2]

    def restart(self) -> None:
        """A new goal: the track starts again from the last place seen."""
        self.points = self.points[-1:]

    @property
    def last(self) -> tuple[float, float] | None:
        return self.points[-1] if self.points else None


def _line(key: tuple[str, int], points_m, width_m: float, rgba, stamp) -> Marker:
    """A line strip, or its DELETE when it has fewer than two points (nothing to draw)."""
    if len(points_m) < 2:
        return Marker(ns=key[0], id=key[1], action=Marker.DELETE)
    return line_strip_marker(key[1], key[0], points_m, width_m, rgba, stamp)


def navigation_markers(progress, goals_ahead, robot_xy_m, trail_xy_m, tolerance_m: float, stamp) -> MarkerArray:
    """What the navigator does, drawn for RViz.

    The goal's tolerance disc coloured by state with the state as text over it, the line from the robot through the
    waypoints ahead, and the track driven since the goal came; no goal yet: every marker deleted.
    """
    if progress.goal_xy_m is None:
        return MarkerArray(markers=[Marker(action=Marker.DELETEALL)])
    gx, gy = progress.goal_xy_m
    rgba = STATE_RGBA.get(progress.state, IDLE_RGBA)
    disc = floor_marker(GOAL[1], GOAL[0], Marker.CYLINDER, rgba, stamp, (2 * tolerance_m, 2 * tolerance_m, 0.004),
                        (gx, gy, 0.002))
    text = floor_marker(STATUS[1], STATUS[0], Marker.TEXT_VIEW_FACING, (1.0, 1.0, 1.0, 0.9), stamp, (0.0, 0.0, 0.05),
                        (gx, gy, 0.12))
    where = "to go" if progress.state.active else "from the goal"
    text.text = f"{progress.state.value}: {100 * progress.distance_to_go_m:.1f} cm {where}" \
        if math.isfinite(progress.distance_to_go_m) else progress.state.value
    ahead = ([robot_xy_m] if robot_xy_m is not None and goals_ahead else []) + list(goals_ahead)
    return MarkerArray(markers=[disc, text, _line(PATH_AHEAD, ahead, 0.006, DRIVING_RGBA[:3] + (0.8,), stamp),
                                _line(TRACK, trail_xy_m, 0.004, (0.2, 0.5, 1.0, 0.8), stamp)])
