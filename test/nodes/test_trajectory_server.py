"""trajectory_server as a separate process: regenerate, latch, report fit quality, refuse bad requests."""

import time

import numpy as np
import pytest
from sensor_msgs.msg import JointState
from srs_testing import ros_args
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory

from srs_ros.core.gait.interpolation import PeriodicTrajectory
from srs_ros.core.robot import config_dir
from srs_ros.ros.interfaces import SETPOINT_TOPIC, TRAJECTORY_TOPIC, latched_qos, setpoint_qos, stamp_to_seconds

NAMES = [f"m{i}_pma{j}" for i in (1, 2, 3) for j in (1, 2, 3)]


def seconds(duration):
    return stamp_to_seconds(duration)


def latest_trajectory(client) -> JointTrajectory:
    """What a late ``ros2 topic echo --qos-durability transient_local`` prints: the latched message."""
    received = client.subscribe(JointTrajectory, TRAJECTORY_TOPIC, latched_qos())
    client.spin_until(lambda: received, 10.0, "the latched trajectory")
    return received[-1]


def test_regenerate_latches_one_period_and_failures_keep_the_last_good_one(launch_node, ros_client):
    proc = launch_node("trajectory_server", [
        "--ros-args", "--params-file", str(config_dir() / "trajectory_server.yaml"), "-p", "generate_on_start:=false",
        "-p", "samples:=16", "-p", "frequency_hz:=0.5", "-p", "amplitude_bar:=3.0"])
    good = ros_client.trigger("trajectory_server/regenerate", timeout_s=60.0)
    assert good.success, good.message
    assert "inward_rolling at 3 bar, 0.5 Hz" in good.message and "fit error mean" in good.message
    assert "poor samples none" in good.message

    msg = latest_trajectory(ros_client)  # subscribed after the publication
    assert list(msg.joint_names) == NAMES and len(msg.points) == 17
    times = np.array([seconds(p.time_from_start) for p in msg.points])
    assert times[0] == 0.0 and abs(times[-1] - 2.0) < 1e-6 and np.allclose(np.diff(times), 2.0 / 16)
    lengths = np.array([p.positions for p in msg.points])
    assert np.allclose(lengths[0], lengths[-1]) and lengths.min() >= -1e-9 and lengths.max() <= 0.065 + 1e-9
    assert lengths.max() > 0.02  # 3 bar = about 0.03 m at 100 bar/m
    assert msg.header.stamp.sec > 0

    # The same request again (the navigator switching back to a turn level) is published from the cache.
    assert all(r.successful for r in ros_client.set_parameters("trajectory_server", {"amplitude_bar": 2.0}))
    other = ros_client.trigger("trajectory_server/regenerate", timeout_s=60.0)
    assert other.success and "at 2 bar" in other.message and "fitted in" in other.message, other.message
    assert all(r.successful for r in ros_client.set_parameters("trajectory_server", {"amplitude_bar": 3.0}))
    again = ros_client.trigger("trajectory_server/regenerate", timeout_s=60.0)
    assert again.success and "at 3 bar" in again.message and "kept from before" in again.message, again.message
    assert np.allclose([p.positions for p in latest_trajectory(ros_client).points], lengths)

    # A refused fit (poor samples with reject_poor_fit): success=false with the reason, the old one stays.
    assert all(r.successful for r in ros_client.set_parameters(
        "trajectory_server", {"gait": "serpentine", "serpentine.poor_fit_mm": 0.1, "samples": 8,
                              "reject_poor_fit": True}))
    bad = ros_client.trigger("trajectory_server/regenerate", timeout_s=60.0)
    assert not bad.success and "poor samples [" in bad.message and "reject_poor_fit" in bad.message, bad.message
    assert "inward_rolling at 3 bar, 0.5 Hz) stays published" in bad.message
    kept = latest_trajectory(ros_client)
    assert np.allclose([p.positions for p in kept.points], lengths)

    # Bad values never get in: each is refused with what is allowed.
    for values, words in (({"gait": "crawl"}, "serpentine"), ({"amplitude_bar": 5.0}, "amplitude_bar"),
                          ({"amplitude_bar": 0.0}, "amplitude_bar is 0.0; expected a number in (0, 4] (bar)"),
                          ({"samples": 4}, "samples"),
                          ({"serpentine.body_wavelengths": 9.0}, "body_wavelengths")):
        result = ros_client.set_parameters("trajectory_server", values)[0]
        assert not result.successful and words in result.reason, (values, result.reason)
    assert ros_client.get_parameters("trajectory_server", ["gait"]) == {"gait": "serpentine"}
    assert proc.alive(), proc.output()


@pytest.mark.slow(seconds=6)
def test_a_second_regenerate_during_a_fit_is_answered_busy(launch_node, ros_client):
    # Every sample of this request is poor, so each goes through the fitter's slow global retry.
    launch_node("trajectory_server", ros_args({"generate_on_start": False, "samples": 64, "gait": "serpentine",
                                               "serpentine.poor_fit_mm": 0.1}))
    # The client keeps every response of the burst below: with rclpy's default depth of 10, a client stalled by a
    # busy machine loses the oldest ones (a call waiting for ever on the client's side, not the server's).
    client = ros_client.client(Trigger, "trajectory_server/regenerate", depth=100)
    ros_client.spin_until(client.service_is_ready, 10.0, "trajectory_server/regenerate")
    first = client.call_async(Trigger.Request())
    ros_client.spin_for(0.2)
    sent = time.monotonic()
    second = client.call_async(Trigger.Request())
    ros_client.spin_until(second.done, 10.0, "the busy answer")
    answered_s = time.monotonic() - sent
    assert not second.result().success and "busy" in second.result().message
    assert not first.done(), "the first fit finished too fast to test the busy path"
    # A burst beyond the service's default queue depth (10): every call is answered, none waits forever.
    burst = [client.call_async(Trigger.Request()) for _ in range(30)]
    ros_client.spin_until(lambda: all(f.done() for f in burst), 20.0, "an answer to each of 30 calls")
    assert all("busy" in f.result().message for f in burst)
    assert not first.done(), "the first fit finished too fast to test the burst"
    # Parameter services keep answering during the fit.
    assert ros_client.get_parameters("trajectory_server", ["samples"]) == {"samples": 64}
    ros_client.spin_until(first.done, 120.0, "the first fit")
    assert answered_s < 9.0  # answered, not queued behind the fit (which takes far longer)


def test_gait_player_streams_what_the_server_latched(launch_node, ros_client):
    launch_node("trajectory_server", ros_args({"samples": 16}))  # generate_on_start: default true
    launch_node("gait_player", ros_args({"autostart": True, "ramp_time_s": 0.2}))
    setpoints = ros_client.subscribe(JointState, SETPOINT_TOPIC, setpoint_qos(depth=1000))
    trajectory = latest_trajectory(ros_client)
    ros_client.spin_until(lambda: len(setpoints) > 200, 60.0, "setpoints from the latched trajectory")
    cycle = PeriodicTrajectory(np.array([p.positions for p in trajectory.points[:-1]]))
    # The player never commands a negative length (a spline undershoot near a kink is clipped to 0).
    shapes = np.maximum(cycle.values(np.linspace(0.0, 1.0, 2000, endpoint=False)), 0.0)
    distance_m = [np.min(np.max(np.abs(shapes - m.position), axis=1)) for m in setpoints[-20:]]
    assert max(distance_m) < 0.001  # every setpoint lies on the served cycle (ramp-in over)


def test_the_start_up_fit_runs_once_however_late_its_callback_cancels_its_timer(ros_domain, monkeypatch):
    """The 0 s start-up timer sat in the reentrant group of the 3-thread executor: another thread took it again
    before the first callback cancelled it, and rcl refused the cancelled timer ("failed to call timer: timer is
    canceled"): the node died at start, once in a full suite run. Here the callback is slow to cancel."""
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import MultiThreadedExecutor

    from srs_ros.nodes.trajectory_server import TrajectoryServer

    context = Context()
    rclpy.init(context=context, domain_id=ros_domain)
    calls = []
    try:
        server = TrajectoryServer(context=context)
        cancel_late = server._on_startup

        def slow_start() -> None:
            calls.append(time.monotonic())
            time.sleep(0.3)  # a stall before the cancel, as a busy machine makes one
            cancel_late()

        monkeypatch.setattr(server._startup_timer, "callback", slow_start)
        executor = MultiThreadedExecutor(num_threads=3, context=context)
        executor.add_node(server)
        end = time.monotonic() + 6.0
        while time.monotonic() < end and not server._last_good:
            executor.spin_once(timeout_sec=0.05)  # raised the RCLError before
        executor.shutdown(timeout_sec=5.0)
        server.destroy_node()
    finally:
        rclpy.shutdown(context=context)
    assert len(calls) == 1 and server._last_good
