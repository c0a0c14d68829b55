"""The hardware node built in the test's own process on the mock rig, its callbacks called one after another.

Where the order of callbacks is the point (a setpoint queued behind a fault, a disarm between two
ticks), calling them directly is exact and fast; what reaches the backend is read from its record file.
"""

import time
import types

import numpy as np
import pytest
import rclpy
from rclpy.context import Context
from rclpy.lifecycle import TransitionCallbackReturn
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from srs_testing import BackendRecord, recorded_rig
from std_srvs.srv import Trigger

from srs_ros.core.actuation.safety import OutputReason
from srs_ros.core.errors import HardwareError
from srs_ros.core.robot import default_robot
from srs_ros.nodes.hardware_node import HardwareNode, release_and_report
from srs_ros.ros.interfaces import diagnostic_values

NAMES = list(default_robot().joint_names)
COMMAND_BAR = np.full(9, 2.0)  # P = 100 l for 0.02 m


def setpoint(length_m: float = 0.02) -> JointState:
    return JointState(name=NAMES, position=[length_m] * 9)


class Driven:
    """A HardwareNode driven by hand: setpoints and command ticks in turn, at about 200 Hz."""

    def __init__(self, node: HardwareNode, record: BackendRecord):
        self.node, self.record = node, record
        self.diagnostics: list = []
        node.diagnostics_publisher = types.SimpleNamespace(publish=self.diagnostics.append)

    def start(self) -> None:
        self.node.trigger_configure()
        self.node.trigger_activate()
        assert self.node.lifecycle_label() == "active"

    def step(self, count: int = 1) -> list[np.ndarray]:
        """``count`` times a fresh setpoint then a command tick; what the backend was written at each tick."""
        written = []
        for _ in range(count):
            self.node._on_setpoint(setpoint())
            self.node._on_command_tick()
            written.append(self.record.last())
            time.sleep(0.005)  # the command rate's pace (the gate ramps on the monotonic clock)
        return written

    def trigger(self, service: str) -> Trigger.Response:
        """Call the callback the node registered for its Trigger service ``~/<service>``."""
        callback = next(s.callback for s in self.node.services if s.srv_name.endswith(f"/{service}"))
        return callback(Trigger.Request(), Trigger.Response())

    def diagnostic(self, key: str) -> str:
        self.node._publish_diagnostics()
        return diagnostic_values(self.diagnostics[-1].status[0])[key]


@pytest.fixture
def hardware(ros_domain, tmp_path):
    context = Context()
    rclpy.init(context=context, domain_id=ros_domain)
    rig, record = recorded_rig(tmp_path)
    made = []

    def _make(**params) -> Driven:
        overrides = [Parameter(k, value=v) for k, v in {"rig_file": str(rig), **params}.items()]
        made.append(HardwareNode(context=context, parameter_overrides=overrides))
        return Driven(made[-1], BackendRecord(record))

    yield _make
    for node in made:
        node.release_hardware()
        node.destroy_node()
    rclpy.shutdown(context=context)


def test_a_setpoint_queued_across_a_backend_fault_is_dropped_quietly_and_counted(hardware):
    rig = hardware(ramp_time_s=0.0)
    rig.start()
    assert np.allclose(rig.step()[-1], COMMAND_BAR)
    rig.node._on_backend_fault(HardwareError("bus gone (injected)"))  # vent, ErrorProcessing, released
    assert rig.node.lifecycle_label() == "unconfigured" and rig.node.shaper is None
    rig.node._on_setpoint(setpoint())  # the callback that was already queued runs now
    assert rig.node.status.rejected_setpoints == 0  # no "unexpected error, please report"
    assert rig.diagnostic("setpoints_while_unconfigured") == "1"
    assert "bus gone" in rig.node.status.last_error  # the fault stays the reported error
    assert not rig.record.last().any()  # vented at the fault, nothing written since


def test_disarm_holds_0_bar_on_a_rig_that_needs_no_arm_until_arm_ramps_it_back(hardware):
    rig = hardware(ramp_time_s=0.1)
    rig.start()
    assert not rig.node.gate.requires_arm  # the mock rig, like the sim rig
    assert any(np.allclose(p, COMMAND_BAR) for p in rig.step(60))
    response = rig.trigger("disarm")
    assert response.success and response.message == "disarmed: venting to 0 bar until ~/arm."
    assert not any(p.any() for p in rig.step(60))  # fresh setpoints for 0.3 s and more: 0 bar at every tick
    assert rig.node.status.reason is OutputReason.NOT_ARMED
    assert rig.diagnostic("output") == OutputReason.NOT_ARMED.value
    assert rig.trigger("disarm").message == "was not armed: output stays at 0 bar until ~/arm."
    response = rig.trigger("arm")
    assert response.success and "ramping up from 0 bar over 0.1 s" in response.message
    peaks = [float(p.max()) for p in rig.step(60)]
    assert peaks[0] < 1.0 and peaks[-1] == pytest.approx(2.0)  # back with the usual ramp, not a step
    assert np.all(np.diff(peaks) >= -1e-9)


def test_the_exit_line_says_when_no_backend_was_open(hardware, capsys):
    rig = hardware()
    assert release_and_report(rig.node, "hardware_node") is True
    assert capsys.readouterr().out.strip() == "hardware_node: stopped; no backend was open, nothing to vent"
    rig.start()
    assert release_and_report(rig.node, "hardware_node") is True
    assert capsys.readouterr().out.strip() == "hardware_node: stopped; every valve vented to 0 bar"


def test_without_autostart_the_node_says_it_waits_for_configure(hardware, capfd):
    hardware()
    assert ("unconfigured, nothing sent: waiting for `ros2 lifecycle set /hardware_node configure` (then activate), "
            "or start with autostart:=true") in capfd.readouterr().err
    hardware(autostart=True)
    assert "waiting for `ros2 lifecycle set" not in capfd.readouterr().err


def test_a_node_frozen_between_deciding_and_writing_sends_0_bar_then_ramps(hardware):
    rig = hardware(ramp_time_s=0.1, setpoint_timeout_s=0.2)
    rig.start()
    assert np.allclose(rig.step(40)[-1], COMMAND_BAR)
    decide = rig.node.gate.decide

    def decide_then_freeze(now_s, holding=""):
        decided = decide(now_s, holding)
        time.sleep(0.3)  # SIGSTOP between the decision and the write: a real board has vented meanwhile
        return decided

    rig.node.gate.decide = decide_then_freeze
    stalls = rig.node.gate.stalls
    rig.node._on_setpoint(setpoint())
    rig.node._on_command_tick()
    assert not rig.record.last().any()  # not the command decided 0.3 s ago
    assert rig.node.gate.stalls == stalls + 1 and rig.node.status.reason is OutputReason.STALE
    rig.node.gate.decide = decide
    peaks = [float(p.max()) for p in rig.step(40)]
    assert peaks[0] < 1.0 and max(peaks) == pytest.approx(2.0)  # back with the ramp, not a step


def test_the_simulators_automatic_recovery_leaves_a_real_rig_set_since_the_fault_to_the_operator(hardware, tmp_path,
                                                                                                 ros_domain):
    """After a sim rig's fault the operator set rig_file to a CAN rig; a second later the recovery timer configured
    and activated it by itself, bus open, saying 'holding 0 bar until the simulated robot answers' (a helper's
    review). A real rig waits for the operator."""
    sim = tmp_path / "sim_fast.yaml"
    sim.write_text("rig:\n  name: sim_fast\n  backend: sim\n  command_rate_hz: 100.0\n  setpoint_timeout_s: 0.2\n"
                   "  backend_options:\n    startup_timeout_s: 0.3\n")
    can_rig = tmp_path / "can_virtual.yaml"
    can_rig.write_text("rig:\n  name: can_virtual\n  backend: can\n  command_rate_hz: 100.0\n  setpoint_timeout_s: "
                       "0.2\n  backend_options:\n    interface: virtual\n    channel: recovery_review\n"
                       "    readback: false\n")
    rclpy.init(domain_id=ros_domain)  # the sim backend's bus node lives in the default context
    try:
        driven = hardware(rig_file=str(sim))
        node = driven.node
        driven.start()
        time.sleep(0.4)
        node._on_command_tick()  # no sim_world answered within startup_timeout_s: a backend fault
        assert node.lifecycle_label() == "unconfigured" and node._recovery_timer is not None
        assert node.set_parameters([Parameter("rig_file", value=str(can_rig))])[0].successful
        node._try_recovery()  # what the recovery timer does RECOVERY_PERIOD_S later
        assert node.lifecycle_label() == "unconfigured" and node.backend is None and node._recovery_timer is None
    finally:
        rclpy.try_shutdown()


def test_the_simulators_automatic_recovery_never_activates_a_rig_the_operator_configured_by_hand(hardware, tmp_path,
                                                                                                ros_domain):
    """The operator configured a CAN rig by hand (not activated) after a sim rig's fault; the recovery timer then
    activated it, logging 'holding 0 bar until the simulated robot answers' (a helper's review)."""
    sim = tmp_path / "sim_fast.yaml"
    sim.write_text("rig:\n  name: sim_fast\n  backend: sim\n  command_rate_hz: 100.0\n  setpoint_timeout_s: 0.2\n"
                   "  backend_options:\n    startup_timeout_s: 0.3\n")
    can_rig = tmp_path / "can_virtual.yaml"
    can_rig.write_text("rig:\n  name: can_virtual\n  backend: can\n  command_rate_hz: 100.0\n  setpoint_timeout_s: "
                       "0.2\n  backend_options:\n    interface: virtual\n    channel: recovery_by_hand\n"
                       "    readback: false\n")
    rclpy.init(domain_id=ros_domain)
    try:
        driven = hardware(rig_file=str(sim))
        node = driven.node
        driven.start()
        time.sleep(0.4)
        node._on_command_tick()  # no sim_world answered: a backend fault, active before it
        assert node.lifecycle_label() == "unconfigured" and node.status.reactivate
        assert node.set_parameters([Parameter("rig_file", value=str(can_rig))])[0].successful
        assert node.trigger_configure() == TransitionCallbackReturn.SUCCESS  # the operator, by hand
        node._try_recovery()
        assert node.lifecycle_label() == "inactive" and node._recovery_timer is None
    finally:
        rclpy.try_shutdown()
