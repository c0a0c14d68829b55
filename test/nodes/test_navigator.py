"""The navigator on the simulated robot, every node a process of its own over DDS, the pose from pixels.

sim_world (MuJoCo, its overhead camera) -> camera_tracker (colour bands) -> robot_pose -> navigator, which
drives trajectory_server and gait_player -> hardware_node (sim rig) -> sim_world. One process set for the
whole module (:class:`srs_testing.navigation.NavigationSystem`); the tests run in order, each from the robot
at rest at its start pose. The ground truth is read by the test only; the navigator never sees it.

The camera runs at sim_world's 30 fps, its images through a large shared-memory segment
(:data:`srs_testing.navigation.LARGE_SHM_PROFILE`). On a loaded 2-core machine a process still stalls now and
then, so the driving tests give the navigator ``pose_timeout_s`` 3 s; the lost-pose test puts the default 1 s
back. The goals are the first and third of ``random_goals`` (seed 20, as the offline test's). Reaching a goal
within tolerance is measured by benchmarks/bench_navigation_ros.py (issue 20's figure, not reached yet).
"""

from __future__ import annotations

import math
import os
import re
import signal
import time

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped
from srs_testing.navigation import NavigationSystem

from srs_ros.ros.interfaces import POSE_TOPIC

pytestmark = pytest.mark.slow

TOLERANCE_M = 0.05  # the navigator's default goal_tolerance_m
#: The tracked point against the simulator's reference point (test_sim_world: median < 5 mm while rolling) and
#: what the robot may still settle after the navigator's check.
MARGIN_M = 0.015
LOADED_POSE_TIMEOUT_S = 3.0


@pytest.fixture(scope="module")
def robot(ros_sessions):
    system = NavigationSystem(ros_sessions("srs_test_navigator"), {"pose_timeout_s": LOADED_POSE_TIMEOUT_S})
    assert system.state()["state"] == "idle" and system.vented()
    return system


# Reaching a goal within the 5 cm tolerance is issue 20's acceptance figure, not reached yet on the physics
# (3 of 4 goals over DDS with the fine approach): it is measured by benchmarks/bench_navigation_ros.py, not
# asserted here.


def test_a_new_goal_replaces_the_current_one_mid_way(robot):
    start = robot.at_rest_at_start()
    first, second = start + [-0.458, 0.040], start + [-0.581, -0.281]
    robot.goal(*first)
    robot.wait_state({"driving"}, 10.0, "driving to the first goal")
    robot.wait(lambda: np.linalg.norm(robot.xy(robot.tracked) - start) > 0.10, 60.0,
               "the robot on its way to the first goal")
    at_second = robot.xy(robot.tracked)
    robot.goal(*second)
    robot.wait(lambda: robot.state()["goal_xy_m"] == pytest.approx(list(second)), 5.0, "the second goal taken over")
    taken = robot.state()
    assert taken["state"] in ("driving", "stopping") and taken["goal_count"] == 1, taken
    robot.wait(lambda: robot.state()["distance_to_go_m"] < taken["distance_to_go_m"] - 0.05, 60.0,
               "the robot closing on the second goal")
    # What RViz shows (navigation_markers): the tolerance disc on the second goal, the track driven toward it.
    robot.wait(lambda: robot.marker("goal") is not None and math.dist(
        (robot.marker("goal").pose.position.x, robot.marker("goal").pose.position.y), second) < 1e-6, 5.0,
        "the goal's disc on navigation_markers at the second goal")
    assert robot.marker("goal").header.frame_id == "floor" and robot.marker("goal").scale.x == pytest.approx(
        2 * TOLERANCE_M)

    def track():
        return np.array([(p.x, p.y) for p in robot.marker("track").points]).reshape(-1, 2)

    robot.wait(lambda: len(track()) >= 3 and np.linalg.norm(track()[-1] - track()[0]) > 0.03, 10.0,
               "a track of 3 cm or more since the second goal on navigation_markers")
    # It starts where the robot was when the second goal came (not at the first goal's start, 10 cm or more back) ...
    assert np.linalg.norm(track()[0] - at_second) < np.linalg.norm(track()[0] - start), (track()[0], at_second, start)
    # ... and ends where the camera sees the robot (the markers come at 2 Hz and may be late on a busy machine).
    robot.wait(lambda: np.linalg.norm(track()[-1] - robot.xy(robot.tracked)) < 0.05, 10.0,
               "the track's end at the robot's tracked place")
    assert robot.client.trigger("/navigator/cancel").success
    robot.wait(robot.vented, 5.0, "the vent after the cancel")


class ZeroRun:
    """How long every command received has been 0 bar on every muscle (s), from the first of the current run."""

    def __init__(self, pressures: list):
        self.pressures, self.seen, self.since_s = pressures, 0, None

    def lasted_s(self) -> float:
        new, self.seen = self.pressures[self.seen:], len(self.pressures)
        if any(max(m.data) > 0.0 for m in new):
            self.since_s = None
        elif new and self.since_s is None:
            self.since_s = time.monotonic()
        return 0.0 if self.since_s is None else time.monotonic() - self.since_s


def test_cancel_stops_the_gait_and_vents(robot):
    """Here a patrol (loop_path): it names the waypoint and the round, and a cancel ends it for good."""
    start = robot.at_rest_at_start()
    robot.set_navigator(loop_path=True)
    try:
        robot.path([start + [0.0, 0.6], start + [0.3, 0.6]])
        robot.wait_state({"driving"}, 10.0, "driving")
    finally:
        robot.set_navigator(loop_path=False)  # read when a path arrives: this patrol goes on
    assert "driving to waypoint 1 of 2 (round 1)" in robot.navigator.output()
    robot.wait(lambda: robot.commanding(2.0), 10.0, "the gait commanded")
    response = robot.client.trigger("/navigator/cancel")
    cancelled_s = time.monotonic()
    assert response.success and "cancelled" in response.message
    assert robot.wait_state({"cancelled"}, 2.0, "state cancelled")["message"] == "cancelled by ~/cancel"
    # Vented for good: 0 bar on every muscle for longer than the ramp-out (1 s). One 0 bar command is not enough:
    # on a busy machine a 0 bar command came mid-ramp (0.72 s after the cancel) and the ramp went on after it (most
    # likely the hardware node venting setpoints that a stall made stale; not traced).
    zeros = ZeroRun(robot.pressures)
    robot.wait(lambda: zeros.lasted_s() >= 1.2, 6.0, "every muscle vented for 1.2 s after the cancel")
    vent_s = zeros.since_s - cancelled_s
    print(f"cancel to every muscle vented for good: {vent_s:.2f} s (gait_player ramps out over ramp_time_s, 1 s)")
    assert vent_s < 3.5
    count = len(robot.pressures)
    robot.client.spin_for(1.5)
    assert all(max(m.data) == 0.0 for m in robot.pressures[count:])  # stays stopped: no restart by itself
    assert robot.state()["state"] == "cancelled"


def test_a_goal_outside_the_cameras_view_is_refused_with_the_reason_and_nothing_moves(robot):
    robot.at_rest_at_start()
    before = robot.state()["state"]
    robot.goal(3.0, 0.0)
    robot.wait(lambda: robot.state()["refused"], 5.0, "the refusal on navigation_progress")
    refused = robot.state()
    assert "goal (3.000, 0.000) m is" in refused["refused"], refused
    assert "outside the camera's calibrated floor area" in refused["refused"], refused
    assert refused["state"] == before and not refused["gait_playing"]
    robot.path([(0.1, 0.1), (0.2, -2.5)])
    robot.wait(lambda: robot.state()["refused"].startswith("waypoint 2 of 2"), 5.0, "the path refused, naming it")
    robot.goal(math.nan, 0.1)
    robot.wait(lambda: "not a finite floor position" in robot.state()["refused"], 5.0, "a NaN goal refused")
    robot.goal(0.1, 0.1, frame_id="map")
    robot.wait(lambda: "frame 'map'" in robot.state()["refused"], 5.0, "a goal in another frame refused")
    # ... and the status says so, not the NaN goal's refusal before it (a helper's review)
    assert "goal refused: the goal is in frame 'map'" in robot.state()["message"], robot.state()
    robot.client.spin_for(1.0)
    assert all(max(m.data) == 0.0 for m in robot.pressures[-20:])
    assert "refused" in robot.navigator.output()


@pytest.fixture
def default_pose_timeout(robot):
    """The default ``pose_timeout_s`` (1 s) for one test, the loaded one back after it: left at 1 s, a stall of the
    loaded machine lost the pose in the next test before its gait was commanded (a full suite run, stop 59)."""
    robot.set_navigator(pose_timeout_s=1.0)
    yield
    robot.set_navigator(pose_timeout_s=LOADED_POSE_TIMEOUT_S)


def test_a_silent_tracker_is_a_lost_pose_the_gait_stops_and_vents_and_waits_for_a_new_goal(robot,
                                                                                             default_pose_timeout):
    # Poses in another frame (a second tracker misconfigured, say) come on: the loss names them (before, only the
    # log did, and the progress said "out of view or tracker silent").
    wrong_frame = robot.client.node.create_publisher(PoseStamped, POSE_TOPIC, 10)
    start = robot.at_rest_at_start()
    goal = start + [0.0, 0.6]
    robot.goal(*goal)
    robot.wait_state({"driving"}, 10.0, "driving")
    robot.wait(lambda: robot.commanding(2.0), 10.0, "the gait commanded")
    sent_s = [0.0]

    def send_a_wrong_frame_pose() -> None:
        pose = PoseStamped()
        pose.header.frame_id, pose.pose.orientation.w = "camera", 1.0
        wrong_frame.publish(pose)
        sent_s.append(time.monotonic())

    def sending(predicate, goals: bool = False):
        """``predicate`` while the wrong-frame poses go on every 0.25 s (and the goal, as `ros2 topic pub -r 4
        goal_pose ...`, which once hid the loss)."""
        def check() -> bool:
            if time.monotonic() - sent_s[-1] >= 0.25:
                if goals:
                    robot.goal(*goal)
                send_a_wrong_frame_pose()
            return predicate()
        return check

    # The navigator has them before the tracker hangs (discovering the new publisher takes up to 1.5 s, and a pose
    # published before it is lost: the loss came first, 1 in 5 runs alone).
    ignored = robot.navigator.output().count("robot_pose ignored")
    robot.wait(sending(lambda: robot.navigator.output().count("robot_pose ignored") > ignored), 10.0,
               "the navigator's log: a pose in frame 'camera' ignored")
    os.killpg(robot.tracker.process.pid, signal.SIGSTOP)  # the tracker hangs: no pose any more
    stopped_s = time.monotonic()
    named = "poses came but were ignored: robot_pose in frame 'camera'; expected 'floor'"
    try:
        robot.wait(sending(lambda: robot.state()["state"] == "pose_lost", goals=True), 5.0,
                   "state pose_lost while the goal is sent again")
        lost = robot.state()
        lost_s = time.monotonic() - stopped_s
        robot.wait(sending(robot.vented), 5.0, "every muscle vented after the pose was lost")
        vent_s = time.monotonic() - stopped_s
        # The goal sent last may reach the navigator just after the loss (3 ms after it, 2 runs in 8 alone): a new
        # goal, which waits for a pose and drives once the robot is tracked again. With the tracker still silent it is
        # lost again within pose_timeout_s, so the robot rests lost before the tracker comes back. The loss names
        # the ignored poses: at once, or once those a stall queued behind the navigator's timer are taken (its first
        # progress said "out of view" 1 run in 32 alone; the controller now names them after the loss too).
        drained_s = time.monotonic() + 0.5
        robot.wait(sending(lambda: time.monotonic() > drained_s and robot.state()["state"] == "pose_lost"
                           and robot.vented() and named in robot.state()["message"]), 5.0,
                   "pose_lost naming the poses in frame 'camera', vented, with the tracker still silent")
    finally:
        os.killpg(robot.tracker.process.pid, signal.SIGCONT)
    print(f"tracker stopped -> pose_lost after {lost_s:.2f} s, vented after {vent_s:.2f} s")
    # pose_timeout_s 1 s, counted from the last pose's camera frame (on a loaded machine the tracker's last pose
    # may be older than the SIGSTOP: the bound that matters is the upper one)
    silent = re.search(r"no pose from the camera for ([0-9.]+) s", lost["message"])
    assert silent and float(silent.group(1)) >= 1.0, lost["message"]
    assert lost_s < 2.5
    # gait_player answered the stop: the navigator's state says so on its next publication (a loaded machine
    # delays it past the vent, seen once in a full suite run); a gait that went on playing fails here
    robot.wait(lambda: not robot.state()["gait_playing"], 3.0, "the navigator's state: the gait no longer playing")
    count = len(robot.tracked)
    robot.wait(lambda: len(robot.tracked) > count + 10, 10.0, "the tracker back")
    robot.client.spin_for(1.0)
    assert robot.state()["state"] == "pose_lost" and robot.vented(), robot.logs()  # no restart without a new goal
    assert math.isfinite(robot.state()["pose_age_s"]) and robot.state()["pose_age_s"] < 1.5


def test_a_dead_navigator_lets_the_gait_ramp_out_by_itself(robot):
    """The dead man's handle (gait_keepalive_s 2 s): the last test of the module, it kills the navigator."""
    # the lost-pose test before it put its default 1 s back for itself only
    assert robot.client.get_parameters("navigator", ["pose_timeout_s"])["pose_timeout_s"] == LOADED_POSE_TIMEOUT_S
    start = robot.at_rest_at_start()
    robot.goal(*(start + [0.0, 0.6]))
    robot.wait_state({"driving"}, 10.0, "driving")
    robot.wait(lambda: robot.commanding(2.0), 10.0, "the gait commanded")
    robot.client.spin_for(1.0)  # past the ramp-in
    robot.navigator.kill()  # SIGKILL: no goodbye, no ~/stop
    killed_s = time.monotonic()
    while True:  # vented, and 0 bar for a second after: a hold at 0 bar while sim_world stalls is not the vent
        robot.wait(robot.vented, killed_s + 10.0 - time.monotonic(), "every muscle vented with the navigator dead")
        vent_s, count = time.monotonic() - killed_s, len(robot.pressures)
        robot.client.spin_for(1.0)
        if all(max(m.data) == 0.0 for m in robot.pressures[count:]):
            break
    print(f"navigator SIGKILLed while driving: every muscle vented after {vent_s:.2f} s "
          "(gait_keepalive_s 2 s, then gait_player's 1 s ramp-out)")
    assert vent_s < 4.5  # keepalive_s 2 s + the ramp-out 1 s + margin (the last renewal was up to 0.5 s before)
