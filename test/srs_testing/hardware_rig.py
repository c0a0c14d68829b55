"""The hardware node as a separate process, as its tests drive it: a shared node per group, and its topics.

``hardware(params)`` (a pytest fixture; test/nodes/conftest.py provides it and ``shared_nodes``) prepares the shared
hardware_node process of a group from a known state: unconfigured, e-stop released, :data:`BASELINE` and then
``params`` set as `ros2 param set` would (they take effect at configure); ``own_process=True`` starts a process
of the test's own. :class:`Rig` is the client's view of it: the setpoint publisher and the output topics.
"""

import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from srs_ros.core.robot import default_robot
from srs_ros.ros.interfaces import (
    ACTUATOR_STATE_TOPIC,
    COMMAND_VOLTAGE_TOPIC,
    COMMANDED_PRESSURE_TOPIC,
    DIAGNOSTICS_TOPIC,
    SETPOINT_TOPIC,
    diagnostic_values,
    setpoint_qos,
)
from srs_testing.ros import ros_args

NODE = "/hardware_node"
NAMES = list(default_robot().joint_names)
LENGTHS_M = np.array([0.0, 0.01, 0.02, 0.025, 0.03, 0.04, 0.05, 0.065, -0.01])
PRESSURES_BAR = np.array([0.0, 1.0, 2.0, 2.5, 3.0, 4.0, 4.0, 4.0, 0.0])  # P = 100 l in [0, 4] bar
ZEROS = np.zeros(9)
#: What a test on a shared node starts from (set while it is unconfigured, before the test's own values): the
#: mock rig's own timeout and command rate, the paper's map, no compensation, and no ramp (the ramp has its own
#: tests: test_output_ramps_up_from_zero_at_activation_and_after_an_estop_reset and the shipped params file).
BASELINE = {"rig_file": "", "backend": "", "setpoint_timeout_s": 0.0, "command_rate_hz": 0.0, "ramp_time_s": 0.0,
            "pressure_map": "paper", "calibration_file": "", "lag_compensation": False,
            "compensation_delay_s": 0.0, "compensation_time_constant_s": 0.0}


def setpoint(lengths_m, names=NAMES) -> JointState:
    return JointState(name=list(names), position=[float(v) for v in lengths_m])


class Rig:
    """The test client's view of a running hardware node: its setpoint publisher and output topics."""

    def __init__(self, client, env=None):
        self.client, self.env = client, env
        self.publisher = client.node.create_publisher(JointState, SETPOINT_TOPIC, setpoint_qos())
        self.pressure = client.subscribe(Float64MultiArray, COMMANDED_PRESSURE_TOPIC)
        self.voltage = client.subscribe(Float64MultiArray, COMMAND_VOLTAGE_TOPIC)
        self.state = client.subscribe(JointState, ACTUATOR_STATE_TOPIC)
        self.diagnostics = client.subscribe(DiagnosticArray, DIAGNOSTICS_TOPIC)
        self.last_publish_s = 0.0

    def clear(self) -> None:
        """Forget what was received (a new test begins on a shared node)."""
        for received in (self.pressure, self.voltage, self.state, self.diagnostics):
            received.clear()

    def start(self, transitions=("configure", "activate")) -> None:
        self.client.spin_until(lambda: self.client.lifecycle_state(NODE) == "unconfigured", what="hardware_node up")
        for transition in transitions:
            assert self.client.change_state(NODE, transition), transition

    def stream(self, messages, until=None, timeout_s: float = 10.0, what: str = "condition", period_s=0.01):
        """Publish ``messages`` in turn every ``period_s`` while spinning, for ``timeout_s`` or until ``until()``."""
        messages = messages if isinstance(messages, list) else [messages]
        end, sent, next_s = time.monotonic() + timeout_s, 0, 0.0
        while time.monotonic() < end:
            if until is not None and until():
                return
            if time.monotonic() >= next_s:
                message = messages[sent % len(messages)]
                self.publisher.publish(message() if callable(message) else message)
                self.last_publish_s = time.monotonic()
                sent, next_s = sent + 1, self.last_publish_s + period_s
            self.client.executor.spin_once(timeout_sec=0.005)
        if until is not None:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")

    def commanded(self, expected_bar) -> bool:
        return bool(self.pressure) and np.allclose(self.pressure[-1].data, expected_bar, atol=1e-9)

    def diagnostic(self, key=None):
        if not self.diagnostics:
            return None
        status = self.diagnostics[-1].status[0]
        return status if key is None else diagnostic_values(status).get(key)

    def counted(self, key: str) -> int:
        """How much the diagnostics counter ``key`` grew during this test (since its first diagnostics message)."""
        values = [int(v) for v in ({kv.key: kv.value for kv in m.status[0].values}.get(key)
                                   for m in self.diagnostics) if v is not None]
        return values[-1] - values[0] if values else 0

    def wait_vented(self, what: str) -> None:
        self.client.spin_until(lambda: self.commanded(ZEROS), what=what)


class LogSince:
    """A node process as one test sees it: its output since the test began."""

    def __init__(self, proc):
        self.proc, self.offset = proc, len(proc.output())

    def output(self) -> str:
        return self.proc.output()[self.offset:]

    def alive(self) -> bool:
        return self.proc.alive()


class SharedNode:
    """One hardware_node process that tests drive in turn, each from a known state (:meth:`prepare`)."""

    def __init__(self, session):
        self.session, self.proc = session, None
        self.rig = Rig(session.client, session.env)

    def prepare(self, params: dict) -> tuple[LogSince, Rig]:
        """Unconfigured, e-stop released, BASELINE and then ``params`` set; a dead or stuck node is replaced."""
        if self.proc is None or not self.proc.alive() or not self._unconfigured():
            self._restart()
        client = self.session.client
        assert client.trigger(f"{NODE}/reset").success  # an e-stop a test left latched is released
        results = client.set_parameters(NODE, {**BASELINE, **params})
        assert all(r.successful for r in results), [r.reason for r in results]
        client.spin_for(0.1)  # what the node published before is still on its way: not this test's
        self.rig.clear()
        return LogSince(self.proc), self.rig

    def _unconfigured(self) -> bool:
        client = self.session.client
        try:
            state = client.lifecycle_state(NODE)
            if state == "active":
                assert client.change_state(NODE, "deactivate")
                state = "inactive"
            if state == "inactive":
                assert client.change_state(NODE, "cleanup")
            client.spin_until(lambda: client.lifecycle_state(NODE) == "unconfigured", 10.0, "unconfigured")
        except AssertionError:
            return False
        return True

    def _restart(self) -> None:
        if self.proc is not None:
            self.proc.stop()
        self.proc = self.session.launch("hardware_node", ros_args({}))
        self.rig.start(transitions=())


@pytest.fixture(scope="module")
def shared_nodes(ros_sessions):
    """The module's shared hardware_node processes by group (each on its own domain), started on first use."""
    nodes: dict[str, SharedNode] = {}

    def _get(group: str) -> SharedNode:
        if group not in nodes:
            nodes[group] = SharedNode(ros_sessions(f"srs_test_client_{group}"))
        return nodes[group]

    return _get


@pytest.fixture
def hardware(shared_nodes, request):
    """``hardware(params)``: the shared node of ``group`` prepared with ``params`` (taken at configure);
    ``own_process=True`` starts a process of its own with ``params`` at start-up (and ``extra_args``)."""
    def _start(params=None, extra_args=(), own_process=False, group="paper_map"):
        if not own_process:
            return shared_nodes(group).prepare(params or {})
        launch_node, client = request.getfixturevalue("launch_node"), request.getfixturevalue("ros_client")
        proc = launch_node("hardware_node", [*ros_args(params or {}), *extra_args])
        return proc, Rig(client, request.getfixturevalue("ros_env"))

    return _start
