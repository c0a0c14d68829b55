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
import time

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from sensor_msgs.msg import JointState
from srs_testing import BackendRecord, recorded_rig, ros_args

from srs_ros.nodes.common import DIAGNOSTICS_TOPIC, SETPOINT_TOPIC, setpoint_qos

NAMES = [f"m{module}_pma{muscle}" for module in (1, 2, 3) for muscle in (1, 2, 3)]
TIMEOUT_S = 0.2
MAX_BAR = 4.0
GOOD_M = np.array([0.005, 0.01, 0.015, 0.02, 0.025, 0.03, 0.035, 0.012, 0.018])  # 0.5 .. 3.5 bar
HOSTILE_FLOATS = [math.nan, math.inf, -math.inf, 1.8e306, 1e308, -1e308, np.finfo(float).max, 5e-324, -0.01,
                  0.0, 0.04, 0.065, 1e-12, -0.0]
SETTINGS = settings(max_examples=40, deadline=None, database=None, phases=[Phase.explicit, Phase.generate],
                    suppress_health_check=list(HealthCheck), report_multiple_bugs=False)


def pressures_bar(names, lengths_m) -> np.ndarray:
    """What the README promises for a valid setpoint: P = 100 l per named actuator, clamped to [0, 4] bar."""
    ordered = np.empty(9)
    for name, length in zip(names, lengths_m):
        ordered[NAMES.index(name)] = length
    return np.clip(100.0 * np.clip(ordered, -1.0, 1.0), 0.0, MAX_BAR)


@st.composite
def hostile_setpoints(draw):
    """(names, positions, stamp kind, stamp (sec, nanosec) relative pieces, velocity, frame_id)."""
    kind = draw(st.sampled_from(["shuffled", "missing", "extra", "unknown", "duplicate", "empty", "text", "many"]))
    names = draw(st.permutations(NAMES))
    if kind == "missing":
        names = names[:draw(st.integers(0, 8))]
    elif kind == "extra":
        names = names + draw(st.lists(st.sampled_from(NAMES + ["m4_pma1", ""]), min_size=1, max_size=3))
    elif kind == "unknown":
        names[draw(st.integers(0, 8))] = draw(st.sampled_from(["m4_pma1", "M1_PMA1", "m1_pma1 ", "", "m1_pma0"]))
    elif kind == "duplicate":
        names[draw(st.integers(0, 8))] = names[draw(st.integers(0, 8))]
    elif kind == "empty":
        names = []
    elif kind == "text":
        names = draw(st.lists(st.text(max_size=12), max_size=12))
    elif kind == "many":
        names = names * draw(st.integers(2, 1000))
    value = st.one_of(st.sampled_from(HOSTILE_FLOATS), st.floats(), st.floats(0.0, 0.065))
    count = draw(st.one_of(st.just(len(names)), st.integers(0, 20)))
    positions = draw(st.lists(value, min_size=count, max_size=count))
    stamp = draw(st.sampled_from(["unstamped", "fresh", "stale", "future", "far_future", "far_past", "nanosec_overflow",
                                  "one_ns"]))
    velocity = draw(st.lists(st.floats(), max_size=12))
    frame_id = draw(st.text(max_size=30))
    return names, positions, stamp, velocity, frame_id


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
        end = time.monotonic() + timeout_s
        while not predicate():
            assert time.monotonic() < end, f"timed out waiting for {what}\n{proc.output()[-2000:]}"
            publisher.publish(good(clock.now().nanoseconds))
            client.executor.spin_once(timeout_sec=0.005)

    publish_good_until(lambda: record.commanding(good_bar), "the good command at the backend", 20.0)
    refused = []

    @SETTINGS
    @given(hostile_setpoints())
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
        during = record.pressures_bar[start:].copy()
        publish_good_until(lambda: record.commanding(good_bar), "the good command after the hostile one")
        after = record.pressures_bar[start:]
        assert proc.alive(), proc.output()[-3000:]
        assert np.all(np.isfinite(after)) and after.min() >= 0.0 and after.max() <= MAX_BAR, after
        if expected is None:
            refused.append(case)
            assert all(np.allclose(row, good_bar) for row in during), (msg, during)  # G goes on, untouched
        else:
            assert any(np.allclose(row, expected) for row in during), (msg, expected, during)
            assert all(np.allclose(row, good_bar) or np.allclose(row, expected) for row in after), (msg, after)

    one_hostile_setpoint()
    assert refused, "no drawn setpoint had to be refused: the strategy is broken"

    def counted():
        values = {kv.key: kv.value for a in diagnostics[-1:] for kv in a.status[0].values}
        return int(values.get("rejected_setpoints", 0)) >= len(refused)

    client.spin_until(counted, 5.0, f"/diagnostics counting at least {len(refused)} rejected setpoints")
    assert "rejected setpoint, not sent" in proc.output() and "Traceback" not in proc.output()
    assert client.trigger("/hardware_node/emergency_stop").success  # still answering services
    client.spin_until(record.vented, 5.0, "the e-stop vent at the backend")
