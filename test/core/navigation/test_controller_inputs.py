"""The navigation controller's inputs that a user gets wrong: too many waypoints, poses it cannot use."""

from srs_ros.core.navigation import NavigationController, NavigationState
from srs_ros.core.navigation import controller as controller_module

from .standins import AREA, Roller, drive, settings


def test_a_path_of_too_many_waypoints_or_none_is_refused_at_once_and_the_goal_kept():
    """20000 waypoints (a patrol sent in a loop) blocked the navigator's callbacks for 1.5 s: refused by their count,
    before each is checked against the view."""
    controller = NavigationController(settings(), AREA)
    controller.set_goal(0.3, 0.3, 0.0)
    for count in (controller_module.MAX_WAYPOINTS + 1, 20000, 0):
        decision = controller.set_path([(0.2, 0.2)] * count, 0.5)
        assert not decision.accepted and decision.reason.startswith(f"a path of {count} waypoints; expected 1 to ")
        assert ("split a longer route" in decision.reason) == (count > 0), decision.reason
        assert controller.goal == (0.3, 0.3) and controller.state is NavigationState.DRIVING
    assert controller.set_path([(0.2, 0.2)] * controller_module.MAX_WAYPOINTS, 0.6).accepted


def test_a_pose_lost_after_ignored_poses_says_why_they_were_ignored():
    """Poses in a wrong frame or NaN ended as "out of view or tracker silent"; only the log named the cause. An
    ignored pose long before a loss is not its cause (a review of the change)."""
    controller, roller = NavigationController(settings(), AREA), Roller()
    controller.set_goal(0.0, 0.7, 0.0)
    drive(controller, roller, 2.9, lost_after_s=2.0)
    controller.pose_ignored("pose: x_m is nan; expected a finite number.", 2.5)
    controller.tick(3.05)
    message = controller.progress(3.05).message
    assert "poses came but were ignored: pose: x_m is nan; expected a finite number; send a new goal" in message
    assert "out of" not in message
    controller.set_goal(0.0, 0.7, 3.1)  # a good pose clears the cause: a later loss is the plain one
    controller.pose_ignored("robot_pose in frame 'camera'; expected 'floor'", 3.15)
    controller.update_pose(roller.pose(3.2))
    controller.tick(4.3)
    assert "the robot may be out of the camera's view" in controller.progress(4.3).message
    controller.set_goal(0.0, 0.7, 4.4)  # one ignored pose, then a real loss long after it
    controller.pose_ignored("robot_pose in frame 'camera'; expected 'floor'", 4.5)
    controller.update_pose(roller.pose(4.6))
    controller.tick(60.0)
    assert "the robot may be out of the camera's view" in controller.progress(60.0).message


def test_ignored_poses_that_come_just_after_a_loss_are_named_by_it():
    """A node's timer may run before the ignored poses that a stall queued behind it: the loss, said first as "out of
    view", names them once they are taken (the DDS test's loss missed them 1 run in 32)."""
    controller, roller = NavigationController(settings(), AREA), Roller()
    controller.set_goal(0.0, 0.7, 0.0)
    drive(controller, roller, 2.9, lost_after_s=2.0)
    controller.tick(3.05)
    assert "the robot may be out of the camera's view" in controller.progress(3.05).message
    controller.pose_ignored("robot_pose in frame 'camera'; expected 'floor'.", 3.06)
    message = controller.progress(3.07).message
    assert controller.state is NavigationState.POSE_LOST
    assert message.startswith("no pose from the camera for ") and "out of" not in message, message
    assert "stopped; poses came but were ignored: robot_pose in frame 'camera'; expected 'floor'; send a new" in message
