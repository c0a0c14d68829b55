"""Simulated robots in namespaces and on simulated time, each a whole srs_bringup process over real DDS.

``__ns`` applies to every node a process creates (as launch_ros's ``namespace`` does), the sim backend's bus
node included; with ``use_sim_time`` sim_world publishes ``/clock`` (as Gazebo does) and the loop follows it.
"""

import time

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped
from rosgraph_msgs.msg import Clock

from srs_ros.ros.interfaces import stamp_to_seconds

#: Absolute by ROS convention, shared by every robot of a domain.
GLOBAL_TOPICS = ("/rosout", "/parameter_events", "/diagnostics")
LIGHT = ["--samples", "16"]  # a quick start-up fit


def moved_m(poses, last: int = 0) -> float:
    """Travel (m) between the first and last of the poses after index ``last``."""
    window = poses[last:]
    if len(window) < 2:
        return 0.0
    a, b = window[0].pose.position, window[-1].pose.position
    return float(np.hypot(b.x - a.x, b.y - a.y))


def settled(poses, window_s: float = 1.0, tolerance_m: float = 0.001) -> bool:
    """Whether the poses of the last ``window_s`` (by their stamps) lie within ``tolerance_m`` of the newest."""
    if not poses:
        return False
    newest_s = stamp_to_seconds(poses[-1].header.stamp)
    window = [p for p in poses if stamp_to_seconds(p.header.stamp) >= newest_s - window_s]
    if newest_s - stamp_to_seconds(window[0].header.stamp) < 0.9 * window_s:
        return False
    b = poses[-1].pose.position
    return all(np.hypot(p.pose.position.x - b.x, p.pose.position.y - b.y) < tolerance_m for p in window)


@pytest.mark.quiet
@pytest.mark.slow(seconds=10)
def test_two_namespaced_robots_move_independently_and_nothing_of_them_is_on_the_root_namespace(
        launch_node, ros_client):
    for name, gait in (("snake1", "inward_rolling"), ("snake2", "outward_rolling")):
        launch_node("srs_bringup", [*LIGHT, "--gait", gait, "--ros-args", "-r", f"__ns:=/{name}",
                                    "-p", "camera_rate_hz:=0.0"])
    truth = {name: ros_client.subscribe(PoseStamped, f"/{name}/sim/ground_truth_pose") for name in ("snake1", "snake2")}
    ros_client.spin_until(lambda: all(moved_m(poses) > 0.03 for poses in truth.values()), 90.0,
                          "both simulated robots rolling")

    assert ros_client.trigger("/snake2/gait_player/stop").success  # one robot stops, the other rolls on
    # The 1 s ramp-out, the setpoint timeout and the muscles venting, in world time: a world slowed by a busy
    # machine takes longer than 2.5 s of wall time (3 cm of roll-on seen then), so wait for it to settle.
    ros_client.spin_until(lambda: settled(truth["snake2"]), 20.0, "snake2 at rest after its stop")
    marks = {name: len(poses) for name, poses in truth.items()}
    # snake1 rolls 5 cm (2-4 s alone), waited for in its own world's time: two worlds beside the suite's other
    # workers ran at a tenth of real time, and a fixed 3 s of wall time saw 2 cm (two full runs, stop 60).
    started_s = time.monotonic()
    ros_client.spin_until(lambda: moved_m(truth["snake1"], marks["snake1"]) > 0.05
                          and time.monotonic() - started_s >= 3.0, 60.0, "snake1 rolling on, 3 s at least")
    still_m, rolling_m = moved_m(truth["snake2"], marks["snake2"]), moved_m(truth["snake1"], marks["snake1"])
    print(f"after /snake2/gait_player/stop, {time.monotonic() - started_s:.1f} s: snake1 moved {rolling_m * 100:.1f} "
          f"cm, snake2 {still_m * 100:.2f} cm")
    assert still_m < 0.005

    client = ros_client.node.get_name()
    nodes = [(ns, name) for name, ns in ros_client.node.get_node_names_and_namespaces() if name != client]
    assert nodes and {ns for ns, _ in nodes} == {"/snake1", "/snake2"}, nodes
    assert ("/snake1", "sim_backend_bus") in nodes and ("/snake2", "sim_backend_bus") in nodes
    topics = [t for t, _ in ros_client.node.get_topic_names_and_types()]
    assert [t for t in topics if not t.startswith(("/snake1/", "/snake2/")) and t not in GLOBAL_TOPICS] == []
    services = [s for s, _ in ros_client.node.get_service_names_and_types() if not s.startswith(f"/{client}/")]
    assert services and [s for s in services if not s.startswith(("/snake1/", "/snake2/"))] == []


@pytest.mark.slow(seconds=4)
def test_with_use_sim_time_sim_world_publishes_clock_and_the_loop_follows_it(launch_node, ros_client):
    launch_node("srs_bringup", [*LIGHT, "--ros-args", "-p", "use_sim_time:=true", "-p", "camera_rate_hz:=0.0"])
    clock = ros_client.subscribe(Clock, "/clock")
    truth = ros_client.subscribe(PoseStamped, "sim/ground_truth_pose")

    def clock_s():
        return np.array([stamp_to_seconds(m.clock) for m in clock])

    ros_client.spin_until(lambda: moved_m(truth) > 0.05 and len(clock) > 2 and np.ptp(clock_s()) > 2.0, 90.0,
                          "the robot rolling and /clock advancing 2 s")
    seconds = clock_s()
    assert np.all(np.diff(seconds) >= 0.0) and len(seconds) > 100  # every control period (10 ms of world time)
    # Every node's ROS clock is the world's: the ground truth is stamped in simulated seconds, not the epoch.
    stamp_s = stamp_to_seconds(truth[-1].header.stamp)
    assert abs(stamp_s - seconds[-1]) < 1.0, (stamp_s, seconds[-1])
