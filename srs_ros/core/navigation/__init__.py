"""Closed-loop navigation by camera, without ROS: goals, the camera pose in, rolling-gait commands out.

``settings`` (the navigator's settings, one schema, and the identified turn map of config/turning_map.yaml),
``area`` (the camera's calibrated floor area where goals may lie), ``commands`` (the state, the gait command
for the nodes, the answer to a goal, the progress), ``motion`` (poses, and the turn rates and
travel directions learned online from them), ``controller`` (:class:`NavigationController`: goals, waypoints,
cancel, lost pose, progress; it chooses the rolling direction, the turn level and the frequency), ``stopping``
(where the robot rests after a stop), ``cruise_stop`` (when the controller stops the rolling gait near the goal
and what it learns as the robot rests), ``fine`` and ``approach`` (the fine approach near the goal: creeping just
above the deadzone along the line square to the body, turning on the spot toward it), ``shuffle`` (moves along
the body's axis onto that line, the straight serpentine, learned per floor), ``edge`` (the edge guard that keeps
the robot in the camera's view).
A ROS node wires it to topics (docs/navigation.md); ``srs_ros.sim.navigation`` runs it on the simulated robot.
"""

from srs_ros.core import lazy_exports

_EXPORTS = {
    "NavigationController": "controller", "NavigationState": "commands", "NavigationProgress": "commands",
    "GaitCommand": "commands", "GoalDecision": "commands", "GAIT": "commands",
    "Pose2D": "motion", "FloorArea": "area",
    "NavigationSettings": "settings", "load_navigation_settings": "settings", "TurningMap": "settings",
    "load_turning_map": "settings", "NAVIGATION_TABLE": "settings", "DIRECTIONS": "settings",
}
__all__ = sorted(_EXPORTS)
__getattr__ = lazy_exports(__name__, _EXPORTS)
