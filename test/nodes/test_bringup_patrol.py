"""srs_bringup's patrol (the main job): sent once the navigator listens and the robot is tracked, sent again
(from the waypoint it was driving to) after a stop for a lost pose once the robot is tracked again, never after
a cancel. In-process: the Patrol
node on the test client's context, the navigator's side played by the client over DDS."""

import time

import pytest
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Path
from std_msgs.msg import String

from srs_ros.nodes.bringup import SIM_PATROL_XY_M
from srs_ros.nodes.bringup_nodes import Patrol
from srs_ros.ros.interfaces import GOAL_PATH_TOPIC, NAVIGATION_PROGRESS_TOPIC, POSE_TOPIC, latched_qos, progress_message


@pytest.mark.slow(seconds=10)
def test_the_patrol_waits_for_a_tracked_robot_and_resumes_after_a_lost_pose_but_not_after_a_cancel(ros_client):
    patrol = Patrol(SIM_PATROL_XY_M, context=ros_client.context)
    patrol.RESUME_AFTER_S = 0.5
    ros_client.executor.add_node(patrol)
    node = ros_client.node
    paths = ros_client.subscribe(Path, GOAL_PATH_TOPIC)  # the navigator's subscription
    poses = node.create_publisher(PoseStamped, POSE_TOPIC, 10)
    progress = node.create_publisher(String, NAVIGATION_PROGRESS_TOPIC, latched_qos())

    def tracked_for(seconds, state=None, waypoint_index=2):
        """Poses for ``seconds``, and the navigator's ``state`` (at the path's ``waypoint_index``) until a (new)
        path comes: then it drives (from that path's first waypoint)."""
        end, count = time.monotonic() + seconds, len(paths)
        while time.monotonic() < end:
            poses.publish(PoseStamped())
            if state:
                stopped = len(paths) == count
                progress.publish(progress_message({"state": state if stopped else "driving", "loop": True,
                                                   "waypoint_index": waypoint_index if stopped else 0,
                                                   "waypoint_count": 4}))
            ros_client.spin_for(0.05)

    try:
        ros_client.spin_for(1.0)
        assert not paths and patrol.sent == 0  # the navigator listens, but no pose yet
        tracked_for(0.5)
        ros_client.spin_until(lambda: paths, 5.0, "the patrol path")
        assert [(p.pose.position.x, p.pose.position.y) for p in paths[-1].poses] == list(SIM_PATROL_XY_M)
        assert paths[-1].header.frame_id == "floor"
        tracked_for(1.0, "driving")
        assert len(paths) == 1
        ros_client.spin_for(1.0)  # the robot out of view: no poses; the navigator says pose_lost
        progress.publish(progress_message({"state": "pose_lost"}))
        ros_client.spin_for(1.0)
        assert len(paths) == 1  # not while untracked
        tracked_for(2.0, "pose_lost")
        assert len(paths) == 2, "the patrol sent again, once"
        resumed = [(p.pose.position.x, p.pose.position.y) for p in paths[-1].poses]
        assert resumed == list(SIM_PATROL_XY_M[2:] + SIM_PATROL_XY_M[:2])  # on from the waypoint it was driving to
        tracked_for(2.0, "failed", waypoint_index=1)  # the resent path's second: the patrol's fourth
        assert len(paths) == 3 and [(p.pose.position.x, p.pose.position.y) for p in paths[-1].poses] == list(
            SIM_PATROL_XY_M[3:] + SIM_PATROL_XY_M[:3])
        tracked_for(1.5, "cancelled")
        assert len(paths) == 3 and patrol.sent == 3  # an operator's cancel stays
    finally:
        ros_client.executor.remove_node(patrol)
        patrol.destroy_node()
