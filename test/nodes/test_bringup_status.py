"""The main job's status line on the sim rig follows what camera_tracker reports about the robot's view.

In-process: srs_bringup's StatusMonitor on the test client's context (its gait player, trajectory server and
hardware node are stand-ins with the attributes the line reads), fed over DDS with poses and with
/diagnostics statuses built by camera_tracker's own code from :class:`ViewWatch` reports.
"""

import re
from types import SimpleNamespace

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped

from srs_ros.core.vision.tracking import TrackResult
from srs_ros.core.vision.view import ViewWatch
from srs_ros.nodes.bringup import SpeedMeter, StatusMonitor
from srs_ros.nodes.camera_tracker import tracking_status
from srs_ros.ros.interfaces import GROUND_TRUTH_TOPIC, POSE_TOPIC, seconds_to_stamp

TRACKER = ("camera_tracker: marker tracking", "/image_raw")
OTHER_ROBOT = ("camera_tracker: marker tracking", "/snake2/image_raw")


def stand_ins():
    """Gait player, trajectory server and hardware node as the status line reads them."""
    values = {"gait": "inward_rolling", "amplitude_bar": 4.0, "frequency_hz": 1.0}
    server = SimpleNamespace(get_parameter=lambda name: SimpleNamespace(value=values[name]))
    player = SimpleNamespace(playback=SimpleNamespace(state=SimpleNamespace(value="running"), cycles_done=3.25,
                                                      reverse=False, frequency_hz=1.0,
                                                      target_frequency_hz=1.0))
    hardware = SimpleNamespace(status=SimpleNamespace(reason=SimpleNamespace(value="commanding")))
    return player, server, hardware


def pose(t_s, x_m):
    msg = PoseStamped()
    msg.header.stamp, msg.header.frame_id = seconds_to_stamp(t_s), "floor"
    msg.pose.position.x = x_m
    return msg


def reports():
    """camera_tracker's statuses: tracking, out of view (last seen at (1.25, -0.5) 1.0 s before), camera silent."""
    watch = ViewWatch(lost_after_s=0.5, image_timeout_s=1.0, start_s=0.0, source="/image_raw")
    watch.frame(1.0, TrackResult(1.0, np.array([1.25, -0.5, 0.0]), None, message="tracked"))
    tracking = watch.status(1.0)
    watch.frame(1.1, TrackResult(1.1, None, None, message="not seen: head, tail"))
    out, silent = watch.status(2.0), watch.status(3.0)
    return {name: (lambda who, view=view: tracking_status(view, *who, {"frames": 40}))
            for name, view in (("tracking", tracking), ("out", out), ("silent", silent))}


def test_status_line_says_robot_out_of_the_cameras_view_and_shows_no_tracked_speed_then(ros_client):
    monitor = StatusMonitor(*stand_ins(), period_s=3600.0, simulated=True, tracker_status=TRACKER,
                            context=ros_client.context)
    ros_client.executor.add_node(monitor)
    node = ros_client.node
    tracked, truth = node.create_publisher(PoseStamped, POSE_TOPIC, 10), node.create_publisher(PoseStamped,
                                                                                                GROUND_TRUTH_TOPIC, 10)
    diagnostics = node.create_publisher(DiagnosticArray, "/diagnostics", 10)
    status = reports()
    lines = []

    def line_with(*parts, sending=()):
        def shown():
            for publisher, msg in sending() if callable(sending) else sending:
                publisher.publish(msg)
            lines.append(monitor.status_line())
            return all(part in lines[-1] for part in parts)
        return shown

    try:
        # Tracking: the camera's speed beside the ground truth (5 and 6 cm along x per second of stamps).
        stamps_s = iter(range(1000))

        def poses():
            t_s = next(stamps_s)
            return [(tracked, pose(t_s, 0.05 * t_s)), (truth, pose(t_s, 0.06 * t_s))]

        ros_client.spin_until(line_with("travel speed tracked  5.0 truth  6.0 cm/s", sending=poses), 10.0,
                              "both speeds on the line")
        assert "inward_rolling 4 bar 1 Hz | running cycle    3.25" in lines[-1]

        # Out of view: said with the last seen position, its age growing; the tracked speed is not current.
        out = DiagnosticArray(status=[status["out"](TRACKER)])
        ros_client.spin_until(line_with("| robot out of the camera's view: last seen ", sending=[(diagnostics, out)]),
                              10.0, "out of view on the status line")
        assert "| travel speed tracked   -- truth  6.0 cm/s | robot out of the camera's view: last seen " in lines[-1]
        said = re.search(r"last seen ([0-9.]+) s ago at x 1\.250 y -0\.500 m \(floor\)$", lines[-1])
        assert said and float(said.group(1)) >= 1.0, lines[-1]  # the tracker's age, plus the time since

        # Back in view; another robot's tracker reporting out of view (later in the same array) is not ours.
        back = DiagnosticArray(status=[status["tracking"](TRACKER), status["out"](OTHER_ROBOT)])
        ros_client.spin_until(line_with("travel speed tracked  5.0 truth", sending=[(diagnostics, back)]), 10.0,
                              "the tracked speed back, the other robot's report ignored")
        assert "out of the camera's view" not in lines[-1]

        # The camera silent: said too, and no tracked speed.
        silent = DiagnosticArray(status=[status["silent"](TRACKER)])
        ros_client.spin_until(line_with("tracked   -- truth", "camera silent: no images for ",
                                        sending=[(diagnostics, silent)]), 10.0, "camera silent on the status line")
        assert re.search(r"; robot last seen [0-9.]+ s ago at x 1\.250 y -0\.500 m \(floor\)$", lines[-1])
    finally:
        ros_client.executor.remove_node(monitor)
        monitor.destroy_node()


def test_with_the_navigator_the_status_line_shows_its_state_goal_distance_to_go_and_heading_error(ros_client):
    from std_msgs.msg import String

    from srs_ros.core.navigation import NavigationProgress, NavigationState
    from srs_ros.nodes.navigator import progress_fields
    from srs_ros.ros.interfaces import NAVIGATION_PROGRESS_TOPIC, latched_qos, progress_message

    monitor = StatusMonitor(*stand_ins(), period_s=3600.0, simulated=True, context=ros_client.context,
                            navigating=True)
    ros_client.executor.add_node(monitor)
    publisher = ros_client.node.create_publisher(String, NAVIGATION_PROGRESS_TOPIC, latched_qos())

    def progress(state, goal_index=0, distance_m=0.314, heading_rad=0.21, message="", **extra):
        fields = progress_fields(NavigationProgress(state, (0.4, -0.4), goal_index, 400, distance_m, heading_rad,
                                                    "inward_rolling", 0.2, 12.0, message),
                                 **{"refused": "", "gait_error": "", "loop": True, "waypoint_index": goal_index % 4,
                                    "waypoint_count": 4, "round": goal_index // 4 + 1, **extra})
        return progress_message(fields)

    def shown(msg, part):
        def check():
            publisher.publish(msg)
            return part in monitor.status_line()
        return check

    try:
        assert "nav: no progress from the navigator yet" in monitor.status_line()
        assert "inward_rolling 4 bar 1 Hz | running" in monitor.status_line()
        playback = monitor._player.playback
        playback.reverse, playback.frequency_hz, playback.target_frequency_hz = True, 0.4, -0.25  # to the creep
        assert "outward_rolling 4 bar 0.4 Hz, reversing (then 0.25 Hz) | running" in monitor.status_line()
        playback.frequency_hz = -0.25  # the creep, backward: the gait as played, not as served
        assert "outward_rolling 4 bar 0.25 Hz | running" in monitor.status_line()
        ros_client.spin_until(shown(progress(NavigationState.DRIVING, goal_index=5), "| nav driving"), 10.0,
                              "the navigator's progress on the line")
        line = monitor.status_line()
        assert ("| nav driving to (0.400, -0.400) m [waypoint 2 of 4, round 2]: 0.31 m to go, heading error 12 deg, "
                "inward_rolling turn +0.20 rad | travel speed over 5 s tracked   -- truth   -- cm/s" in line), line
        lost = progress(NavigationState.POSE_LOST, distance_m=float("nan"), message="no pose from the camera for 1.2 s",
                        refused="goal (3.000, 0.000) m is 1.57 m outside the camera's calibrated floor area")
        ros_client.spin_until(shown(lost, "nav pose_lost"), 10.0, "pose lost on the line")
        line = monitor.status_line()
        assert "nav pose_lost to (0.400, -0.400) m [waypoint 1 of 4, round 1]: -- m to go (no pose from the camera " \
               "for 1.2 s) | goal refused: goal (3.000, 0.000) m is 1.57 m outside" in line, line
    finally:
        ros_client.executor.remove_node(monitor)
        monitor.destroy_node()


def test_a_patrols_speed_is_over_the_last_seconds_where_the_open_loop_speed_is_since_the_start():
    """A patrol comes back where it began: since the start its speed falls to 0, over 5 s it stays the speed."""
    since_start, recent = SpeedMeter(), SpeedMeter(window_s=5.0)
    assert recent.take() == "  --"
    for t_s in np.arange(0.0, 20.01, 0.1):  # 10 s out along x at 8 cm/s, 10 s back
        x_m = 0.08 * t_s if t_s <= 10.0 else 0.08 * (20.0 - t_s)
        for meter in (since_start, recent):
            meter.add(pose(t_s, x_m))
    assert since_start.take() == " 0.0"
    assert recent.take() == " 8.0"
