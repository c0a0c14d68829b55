"""The operator's services on the hardware node: what arm, disarm, reset and the e-stop do and say."""

import numpy as np

from srs_ros.core.actuation.operator import arm, disarm, estop_message, reset
from srs_ros.core.actuation.safety import CommandGate, OutputReason


def real_rig_gate(**state) -> CommandGate:
    return CommandGate(joint_count=9, setpoint_timeout_s=0.2, ramp_time_s=1.0, requires_arm=True, **state)


def test_a_real_rig_is_armed_only_when_active_and_not_e_stopped_and_the_arm_is_logged_loudly():
    gate = real_rig_gate()
    answer = arm(gate, "can")
    assert not answer.success and answer.message == ("not armed: not active: configure and activate the hardware "
                                                     "node first, then ~/arm.")
    gate.set_active(True)
    gate.latch_estop()
    assert arm(gate, "can").message == "not armed: e-stop latched: call ~/reset first, then ~/arm."
    gate.reset_estop()
    answer = arm(gate, "can")
    assert answer.success and answer.warning == answer.message
    assert answer.message.startswith("ARMED by the operator: the can rig now commands fresh setpoints, ramping up "
                                     "from 0 bar over 1 s")


def test_a_simulated_rig_needs_no_arm_but_disarm_holds_it_until_arm():
    gate = CommandGate(joint_count=9, setpoint_timeout_s=0.2, ramp_time_s=0.5, active=True)
    assert arm(gate, "sim").message == "armed (the sim rig is simulated and needs no arm)."
    answer = disarm(gate)
    assert answer.message == "disarmed: venting to 0 bar until ~/arm." and answer.warning == answer.message
    gate.accept(np.full(9, 2.0), now_s=1.0)
    assert gate.decide(1.0)[1] is OutputReason.NOT_ARMED
    again = disarm(gate)
    assert again.message == "was not armed: output stays at 0 bar until ~/arm." and not again.warning
    assert arm(gate, "sim").message.startswith("armed again after ~/disarm: the simulated sim rig commands fresh "
                                               "setpoints, ramping up from 0 bar over 0.5 s")


def test_reset_releases_the_latch_and_says_what_comes_next():
    gate = real_rig_gate(active=True)
    assert reset(gate).message == "e-stop was not latched; nothing to reset."
    gate.latch_estop()
    answer = reset(gate)
    assert answer.success and not gate.estop_latched
    assert answer.message == "e-stop released; call ~/arm, then output ramps up with the next fresh setpoint."
    assert answer.warning == "e-stop released: call ~/arm, then output ramps up with the next fresh setpoint"


def test_the_estop_answer_says_whether_anything_was_vented_and_a_failed_vent_loudly():
    gate = CommandGate(joint_count=9, setpoint_timeout_s=0.2)
    assert estop_message(gate, had_backend=True) == ("e-stop latched: every valve vented to 0 bar; call ~/reset to "
                                                     "release.")
    assert estop_message(gate, had_backend=False).startswith("e-stop latched (no backend open, nothing to vent)")
    failed = estop_message(real_rig_gate(), had_backend=True, fault="HardwareError: bus gone")
    assert failed == ("e-stop latched; VENT FAILED: shut off the air supply now; node went to the error state: "
                      "HardwareError: bus gone; call ~/reset to release, then ~/arm.")
