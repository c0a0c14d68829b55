"""Hostile trajectories against gait_player (and the hardware node behind it), each as its own process.

Hypothesis draws a valid cycle (random amplitude, phase, sample count, frequency, joint order) and then
breaks it, or not, with mutations a careless or hostile sender would make: NaN/inf/huge/negative
lengths, ragged points, missing/unknown/repeated names, too few or too many points, times that go back,
stall, start late, are unequally spaced, or give a period outside 0.01..5 Hz, junk velocities. The
player must answer every message with exactly one log line (taken, or refused with the reason), keep
playing the previous cycle after a refusal, follow a valid one after the cross-fade, and never send a
setpoint outside [0, 0.065] m; the backend (mock ``record_file``) never sees a command outside [0, 4]
bar or non-finite.
"""

import math
import random
import re
import time

import numpy as np
import pytest
from builtin_interfaces.msg import Duration
from hypothesis import HealthCheck, Phase, example, given, settings
from hypothesis import strategies as st
from sensor_msgs.msg import JointState
from srs_testing import JOINT_NAMES, BackendRecord, recorded_rig, rolling_cycle, ros_args, trajectory
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from srs_ros.core.gait.interpolation import PeriodicTrajectory
from srs_ros.ros.interfaces import SETPOINT_TOPIC, TRAJECTORY_TOPIC, latched_qos, setpoint_qos

NAMES = JOINT_NAMES
MAX_EXTENSION_M = 0.065
MAX_POINTS = 2049
SETTINGS = settings(max_examples=12, deadline=None, database=None, phases=[Phase.explicit, Phase.generate],
                    suppress_health_check=list(HealthCheck), report_multiple_bugs=False)
ANSWER = re.compile(r"ignored the trajectory|trajectory (?:loaded|taking over)")


#: mutation -> True when it must make the player refuse the message.
MUTATIONS = {
    "nonfinite": True, "too_long": True, "negative": True, "ragged": True, "missing_name": True,
    "unknown_name": True, "duplicate_name": True, "too_few": True, "too_many": True, "backwards": True,
    "late_start": True, "unequal": True, "too_slow": True, "too_fast": True, "negative_time": True,
    "junk_velocities": False, "empty_velocities": False, "huge_header": False,
}


def hostile_trajectory(mutations: list[str], seed: int):
    """(message, mutations applied, the valid cycle it came from (samples in NAMES order, frequency)).

    A valid cycle (random amplitude, phase, sample count, frequency and joint order from ``seed``) with
    ``mutations`` applied in turn; the point count is changed last, so the others find their points.
    """
    rng = random.Random(seed)
    count = rng.randint(8, 64)
    samples = rolling_cycle(count, shift=rng.random(), amplitude_m=rng.uniform(0.005, MAX_EXTENSION_M))
    frequency_hz = rng.uniform(0.2, 3.0)
    order = rng.sample(range(9), 9)
    msg = trajectory(samples[:, order], frequency_hz, names=[NAMES[i] for i in order])
    ordered = sorted(mutations, key=lambda m: m in ("too_few", "too_many"))
    applied = [m for m in ordered if mutate(msg, m, rng)]
    return msg, applied, (samples, frequency_hz)


def _too_many(msg: JointTrajectory, rng: random.Random) -> bool:
    """More points than allowed, small ones, so the byte bound passes and the count bound must refuse."""
    msg.points = [JointTrajectoryPoint(positions=[0.01] * 9, time_from_start=Duration(nanosec=k * 1000))
                  for k in range(rng.randint(MAX_POINTS + 1, MAX_POINTS + 60))]
    return True


def mutate(msg: JointTrajectory, mutation: str, rng: random.Random) -> bool:
    """Apply one mutation; False where it does not apply to this message (e.g. a point already cut short)."""
    points = msg.points
    if not points:  # "too_few" cut every point: only a new point count applies (hypothesis found this)
        return mutation == "too_many" and _too_many(msg, rng)
    i, j = rng.randrange(len(points)), rng.randrange(9)
    if j >= min(len(msg.joint_names), len(points[i].positions)):
        return False
    if mutation == "nonfinite":
        points[i].positions[j] = rng.choice([math.nan, math.inf, -math.inf])
    elif mutation == "too_long":
        points[i].positions[j] = rng.choice([0.0651, 0.07, 1.8e306, 1e308, float(np.finfo(float).max)])
    elif mutation == "negative":
        points[i].positions[j] = rng.choice([-1e-3, -0.065, -1e308])
    elif mutation == "ragged":
        points[i].positions = points[i].positions[:rng.randint(0, 8)]
    elif mutation == "missing_name":
        msg.joint_names = msg.joint_names[:8]
    elif mutation == "unknown_name":
        msg.joint_names[j] = rng.choice(["m4_pma1", "", "M1_PMA1", "m1_pma1 "])
    elif mutation == "duplicate_name":
        msg.joint_names[j] = msg.joint_names[(j + 1) % len(msg.joint_names)]
    elif mutation == "too_few":
        msg.points = points[:rng.randint(0, 4)]
    elif mutation == "too_many":
        _too_many(msg, rng)
    elif mutation == "backwards":
        k = rng.randint(1, len(points) - 1)
        points[k].time_from_start = points[k - 1].time_from_start
    elif mutation == "late_start":
        shift_s = rng.randint(1, 100)
        for point in points:
            point.time_from_start.sec += shift_s
    elif mutation == "unequal":
        k = rng.randint(1, len(points) - 2)
        before, after = (p.time_from_start.sec * 10**9 + p.time_from_start.nanosec for p in (points[k - 1],
                                                                                               points[k + 1]))
        t_ns = before + (after - before) // rng.choice([5, 10])  # far off the middle
        points[k].time_from_start = Duration(sec=t_ns // 10**9, nanosec=t_ns % 10**9)
    elif mutation in ("too_slow", "too_fast"):
        step_ns = rng.choice([10**12, 2**31 * 10**9 // len(points)]) if mutation == "too_slow" else 1000
        for k, point in enumerate(points):
            t_ns = k * step_ns
            point.time_from_start = Duration(sec=min(t_ns // 10**9, 2**31 - 1), nanosec=t_ns % 10**9)
    elif mutation == "negative_time":
        points[0].time_from_start = Duration(sec=-rng.randint(1, 2**31), nanosec=0)
    elif mutation == "junk_velocities":
        for point in points:
            point.velocities = [rng.choice([math.nan, math.inf, 1e308, -1.0]) for _ in range(rng.randint(0, 12))]
            point.accelerations = [math.nan] * rng.randint(0, 9)
    elif mutation == "empty_velocities":
        for point in points:
            point.velocities, point.effort = [], []
    elif mutation == "huge_header":
        msg.header.frame_id = "x" * rng.randint(0, 100_000)
        msg.header.stamp.sec = -2**31
    return True


def with_every_single_mutation(test):
    """Each mutation alone, as an explicit example run every time; hypothesis adds random combinations."""
    for k, mutation in enumerate(sorted(MUTATIONS)):
        test = example(hostile_trajectory([mutation], seed=k))(test)
    return test


HOSTILE_TRAJECTORIES = st.builds(hostile_trajectory, st.lists(st.sampled_from(sorted(MUTATIONS)), min_size=1,
                                                               max_size=3, unique=True), st.integers(0, 2**32))


def on_cycle(received: list[JointState], samples: np.ndarray, tolerance_m: float = 1e-3) -> bool:
    """Every setpoint lies on the cycle (within ``tolerance_m``): the player plays this cycle, at full amplitude."""
    curve = np.clip(PeriodicTrajectory(samples).values(np.linspace(0.0, 1.0, 4000, endpoint=False)),
                    0.0, MAX_EXTENSION_M)
    return all(np.min(np.max(np.abs(curve - np.asarray(m.position)), axis=1)) < tolerance_m for m in received)


@pytest.mark.slow(seconds=10)
def test_hostile_trajectories_are_refused_or_played_and_nothing_unsafe_reaches_the_backend(launch_node, ros_client,
                                                                                            tmp_path):
    rig, record_path = recorded_rig(tmp_path)
    launch_node("hardware_node", ros_args({"rig_file": str(rig), "autostart": True}))
    player = launch_node("gait_player", ros_args({"autostart": True, "rate_hz": 200.0, "blend_time_s": 0.05,
                                                  "ramp_time_s": 0.2}))
    client = ros_client
    publisher = client.node.create_publisher(JointTrajectory, TRAJECTORY_TOPIC, latched_qos())
    setpoints = client.subscribe(JointState, SETPOINT_TOPIC, setpoint_qos(depth=1000))
    record = BackendRecord(record_path)
    good_samples = rolling_cycle()
    good = trajectory(good_samples, 1.0)

    def answers() -> int:
        return len(ANSWER.findall(player.output()))

    def send(msg) -> None:
        before = answers()
        publisher.publish(msg)
        client.spin_until(lambda: answers() > before, 10.0, "the player's answer to a trajectory")
        assert answers() == before + 1, player.output()[-3000:]  # one message, one answer

    def playing(samples, settle_s: float = 0.15) -> bool:
        client.spin_for(settle_s)  # the setpoints in flight
        start = len(setpoints)
        client.spin_until(lambda: len(setpoints) >= start + 20, 5.0, "20 more setpoints")
        return on_cycle(setpoints[start:], samples)

    def switches_to(samples, within_s: float = 5.0) -> None:
        """The player takes up ``samples``: 20 setpoints in a row on that cycle within ``within_s``. Waited for,
        not slept: the cross-fade (0.05 s of the player's time) ends later when the player stalls (0.2-0.4 s
        now and then on a busy machine; a fixed 0.15 s settle once caught the fade's middle)."""
        start = len(setpoints)
        client.spin_until(lambda: len(setpoints) >= start + 20 and on_cycle(setpoints[-20:], samples), within_s,
                          "20 setpoints in a row on the cycle just sent")

    send(good)
    client.spin_until(lambda: len(setpoints) > 100, 10.0, "the good cycle playing")
    assert playing(good_samples)
    refused = []

    @SETTINGS
    @given(HOSTILE_TRAJECTORIES)
    @with_every_single_mutation
    def one_hostile_trajectory(case):
        msg, applied, (samples, _) = case
        must_refuse = any(MUTATIONS[m] for m in applied)
        start = len(setpoints)
        send(msg)
        answer = ANSWER.findall(player.output())[-1]
        if must_refuse:
            refused.append(applied)
            assert answer == "ignored the trajectory", (applied, player.output()[-2000:])
            assert playing(good_samples), applied  # the previous cycle goes on
        else:
            assert answer != "ignored the trajectory", (applied, player.output()[-2000:])
            switches_to(samples)
            send(good)  # back to the reference cycle
            switches_to(good_samples)
        sent = np.array([m.position for m in setpoints[start:]])
        assert np.all(np.isfinite(sent)) and sent.min() >= 0.0 and sent.max() <= MAX_EXTENSION_M
        written = record.update().pressures_bar
        assert np.all(np.isfinite(written)) and written.min() >= 0.0 and written.max() <= 4.0
        assert player.alive(), player.output()[-3000:]

    time_start = time.monotonic()
    one_hostile_trajectory()
    assert refused, "no drawn trajectory had to be refused: the strategy is broken"
    assert "Traceback" not in player.output()
    assert len(record) > 200 * (time.monotonic() - time_start) * 0.5  # the hardware node kept commanding


def test_the_generator_cuts_every_point_and_then_adds_too_many():
    """Regression (hypothesis found it): ``too_few`` leaving no point, then ``too_many``, crashed the generator."""
    counts = {len(hostile_trajectory(["too_few", "too_many"], seed)[0].points) for seed in range(40)}
    assert min(counts) > MAX_POINTS
