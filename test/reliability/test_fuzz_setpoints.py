"""Hostile setpoints against hardware_node as a process, observed where it matters: at the backend.

Hypothesis draws JointState messages as a careless or hostile sender would make them (names missing,
unknown, repeated, shuffled; NaN, inf, huge, negative, ragged positions; stamps absent, stale, from
the future, out of any range). Between two good setpoints G each one H is sent alone, and the mock
backend's ``record_file`` (every command the backend is given, written by the node's own process)
must show: nothing outside [0, 4] bar or non-finite, ever; a refused H leaves G on the valves; an
acceptable H is commanded as P = 100 l clamped to [0, 4] bar. The node stays alive, and every refusal
is counted on /diagnostics and said in the log.

The oracle is written here from the interface contract (README, docs/safety.md), not from srs_ros.
"""

import math
import random
import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from hypothesis import HealthCheck, Phase, example, given, settings
from hypothesis import strategies as st
from sensor_msgs.msg import JointState
from srs_testing import BackendRecord, recorded_rig, ros_args

from srs_ros.ros.interfaces import DIAGNOSTICS_TOPIC, SETPOINT_TOPIC, setpoint_qos

NAMES = [f"m{module}_pma{muscle}" for module in (1, 2, 3) for muscle in (1, 2, 3)]
TIMEOUT_S = 0.2
MAX_BAR = 4.0
GOOD_M = np.array([0.005, 0.01, 0.015, 0.02, 0.025, 0.03, 0.035, 0.012, 0.018])  # 0.5 .. 3.5 bar
HOSTILE_FLOATS = [math.nan, math.inf, -math.inf, 1.8e306, 1e308, -1e308, np.finfo(float).max, 5e-324, -0.01,
                  0.0, 0.04, 0.065, 1e-12, -0.0]
SETTINGS = settings(max_examples=30, deadline=None, database=None, phases=[Phase.explicit, Phase.generate],
                    suppress_health_check=list(HealthCheck), report_multiple_bugs=False)


def pressures_bar(names, lengths_m) -> np.ndarray:
    """What the README promises for a valid setpoint: P = 100 l per named actuator, clamped to [0, 4] bar."""
    ordered = np.empty(9)
    for name, length in zip(names, lengths_m):
        ordered[NAMES.index(name)] = length
    return np.clip(100.0 * np.clip(ordered, -1.0, 1.0), 0.0, MAX_BAR)


DEFECTS = ["none", "missing", "extra", "unknown", "duplicate", "empty", "text", "many", "nonfinite", "count",
           "stale", "far_past", "one_ns"]


def finite_length(rng: random.Random) -> float:
    """A finite length (m) as a careless sender makes it: in the stroke, huge, negative, denormal."""
    kind = rng.randrange(3)
    if kind == 0:
        return rng.uniform(0.0, 0.065)
    if kind == 1:
        return rng.choice([x for x in HOSTILE_FLOATS if math.isfinite(x)])
    return rng.choice([-1.0, 1.0]) * 10.0 ** rng.uniform(-320, 308)


def hostile_setpoint(defects: list[str], seed: int):
    """(names, positions, stamp kind, velocity, frame_id): every actuator named once with a finite length
    (possibly far outside the stroke) and a usable stamp, then ``defects`` applied in turn."""
    rng = random.Random(seed)
    names = rng.sample(NAMES, 9)
    positions = [finite_length(rng) for _ in names]
    stamp = rng.choice(["unstamped", "fresh", "future", "far_future", "nanosec_overflow"])
    for defect in defects:
        if defect == "missing":
            keep = rng.randint(0, 8)
            names, positions = names[:keep], positions[:keep]
        elif defect == "extra":
            extra = [rng.choice(NAMES + ["m4_pma1", ""]) for _ in range(rng.randint(1, 3))]
            names, positions = names + extra, positions + [0.01] * len(extra)
        elif defect == "unknown" and names:
            names[rng.randrange(len(names))] = rng.choice(["m4_pma1", "M1_PMA1", "m1_pma1 ", "", "m1_pma0"])
        elif defect == "duplicate" and names:
            names[rng.randrange(len(names))] = names[rng.randrange(len(names))]
        elif defect == "empty":
            names, positions = [], []
        elif defect == "text":
            names = ["".join(chr(rng.randint(1, 0x2FF)) for _ in range(rng.randint(0, 12))) for _ in positions]
        elif defect == "many":
            copies = rng.randint(2, 50)
            names, positions = names * copies, positions * copies
        elif defect == "nonfinite" and positions:
            positions[rng.randrange(len(positions))] = rng.choice([math.nan, math.inf, -math.inf])
        elif defect == "count":
            size = rng.choice([n for n in range(21) if n != len(names)])
            positions = [finite_length(rng) for _ in range(size)]
        elif defect in ("stale", "far_past", "one_ns"):
            stamp = defect
    velocity = [rng.choice([math.nan, math.inf, 1e308, 0.1]) for _ in range(rng.randint(0, 12))]
    frame_id = "".join(chr(rng.randint(1, 0x2FF)) for _ in range(rng.randint(0, 30)))
    return names, positions, stamp, velocity, frame_id


def with_every_single_defect(test):
    """Each defect alone, as an explicit example run every time; hypothesis adds random pairs."""
    for k, defect in enumerate(DEFECTS):
        test = example(hostile_setpoint([defect], seed=k))(test)
    return test


HOSTILE_SETPOINTS = st.builds(hostile_setpoint, st.lists(st.sampled_from(DEFECTS), min_size=1, max_size=2),
                              st.integers(0, 2**32))


def make_message(case, now_ns: int) -> tuple[JointState, int]:
    """The JointState for a drawn case and its stamp in ns (0 = unstamped)."""
    names, positions, stamp, velocity, frame_id = case
    msg = JointState(name=list(names), position=[float(v) for v in positions], velocity=velocity)
    msg.header.frame_id = frame_id
    sec, nanosec = {
        "unstamped": (0, 0),
        "fresh": divmod(now_ns - 20_000_000, 10**9),
        "stale": divmod(now_ns - 1_000_000_000, 10**9),
        "future": divmod(now_ns + 2_000_000_000, 10**9),
        "far_future": (2**31 - 1, 999_999_999),
        "far_past": (-2**31, 0),
        "nanosec_overflow": (now_ns // 10**9 + 1, 2**32 - 1),  # nanosec beyond 1e9: 5.3 s in the future
        "one_ns": (0, 1),  # stamped 1 ns after the epoch: decades old
    }[stamp]
    msg.header.stamp.sec, msg.header.stamp.nanosec = int(sec), int(nanosec)
    return msg, sec * 10**9 + nanosec


def expected_command(msg: JointState, stamp_ns: int, now_ns: int) -> np.ndarray | None:
    """The pressures (bar) a valid setpoint must become, or None for one that must be refused."""
    if sorted(msg.name) != NAMES or len(msg.position) != 9 or not np.all(np.isfinite(msg.position)):
        return None
    if stamp_ns != 0 and (now_ns - stamp_ns) * 1e-9 > TIMEOUT_S:
        return None  # stale on arrival
    return pressures_bar(msg.name, msg.position)


def good(now_ns: int) -> JointState:
    msg = JointState(name=NAMES[::-1], position=GOOD_M[::-1].tolist())
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(now_ns, 10**9)
    return msg


@pytest.mark.slow(seconds=5)
def test_hostile_setpoints_never_reach_the_backend_and_the_last_good_command_goes_on(launch_node, ros_client,
                                                                                    tmp_path):
    rig, record_path = recorded_rig(tmp_path)
    proc = launch_node("hardware_node", ros_args({"rig_file": str(rig), "autostart": True, "ramp_time_s": 0.0,
                                                  "setpoint_timeout_s": TIMEOUT_S}))
    client = ros_client
    publisher = client.node.create_publisher(JointState, SETPOINT_TOPIC, setpoint_qos())
    diagnostics = client.subscribe(DiagnosticArray, DIAGNOSTICS_TOPIC)
    record = BackendRecord(record_path)
    clock = client.node.get_clock()
    good_bar = pressures_bar(NAMES, GOOD_M)

    def publish_good_until(predicate, what: str, timeout_s: float = 10.0) -> None:
        """Publish fresh G (at least twice, so the command is fresh) until ``predicate()``."""
        end, sent = time.monotonic() + timeout_s, 0
        while sent < 2 or not predicate():
            assert time.monotonic() < end, f"timed out waiting for {what}\n{proc.output()[-2000:]}"
            publisher.publish(good(clock.now().nanoseconds))
            sent += 1
            client.spin_for(0.005)

    publish_good_until(lambda: record.commanding(good_bar), "the good command at the backend", 20.0)
    refused = []

    @SETTINGS
    @given(HOSTILE_SETPOINTS)
    @with_every_single_defect
    def one_hostile_setpoint(case):
        publish_good_until(lambda: record.commanding(good_bar), "the good command before the hostile one")
        start = len(record)
        now_ns = clock.now().nanoseconds
        msg, stamp_ns = make_message(case, now_ns)
        expected = expected_command(msg, stamp_ns, now_ns)
        for _ in range(3):  # best effort: three copies, 10 ms apart, and nothing else meanwhile
            publisher.publish(msg)
            client.spin_for(0.01)
        client.spin_for(0.04)  # 70 ms without G: well inside G's 0.2 s timeout
        during = record.update().pressures_bar[start:].copy()
        publish_good_until(lambda: record.commanding(good_bar), "the good command after the hostile one")
        after = record.pressures_bar[start:]
        assert proc.alive(), proc.output()[-3000:]
        assert np.all(np.isfinite(after)) and after.min() >= 0.0 and after.max() <= MAX_BAR, after
        if expected is None:
            refused.append(case)
            # G goes on, untouched (or, if this machine stalled the node past G's timeout, the vent: 0 bar)
            assert any(np.allclose(row, good_bar) for row in during), (msg, during)
            assert all(np.allclose(row, good_bar) or not row.any() for row in during), (msg, during)
        else:
            assert any(np.allclose(row, expected) for row in during), (msg, expected, during)
            assert all(np.allclose(row, good_bar) or np.allclose(row, expected) or not row.any() for row in after), (
                msg, after)

    one_hostile_setpoint()
    assert refused, "no drawn setpoint had to be refused: the strategy is broken"

    def counted():
        values = {kv.key: kv.value for a in diagnostics[-1:] for kv in a.status[0].values}
        return int(values.get("rejected_setpoints", 0)) >= len(refused)

    client.spin_until(counted, 5.0, f"/diagnostics counting at least {len(refused)} rejected setpoints")
    assert "rejected setpoint, not sent" in proc.output() and "Traceback" not in proc.output()
    assert client.trigger("/hardware_node/emergency_stop").success  # still answering services
    client.spin_until(record.vented, 5.0, "the e-stop vent at the backend")
