"""The operator's services on the hardware node (arm, disarm, reset, e-stop), decided and worded without ROS.

Each function acts on the :class:`~srs_ros.core.actuation.safety.CommandGate` and returns an
:class:`Answer`: the service's success and message, and what to warn about in the log. The node
copies it into the ``std_srvs/Trigger`` response (the e-stop's vent is the node's, so :func:`estop_message`
only words its outcome).

Example::

    gate = CommandGate(joint_count=9, setpoint_timeout_s=0.2, requires_arm=True, active=True)
    arm(gate, "can").message  # 'ARMED by the operator: the can rig now commands fresh setpoints, ...'
"""

from __future__ import annotations

from dataclasses import dataclass

from srs_ros.core.actuation.safety import VENT_FAILED, CommandGate


@dataclass(frozen=True)
class Answer:
    """A service's answer: success, the message for the caller, and a warning for the log ('' = none)."""

    success: bool
    message: str
    warning: str = ""


#: How ``~/arm`` answers on a rig with real regulators (a client that asked no go can tell it was one after all).
REAL_ARM_PREFIX = "ARMED by the operator"


def arm(gate: CommandGate, backend: str) -> Answer:
    """The operator's go for the ``backend`` rig (refused while e-stopped or inactive, with what to do)."""
    had_go = gate.has_go
    refusal = gate.arm()
    if refusal:
        return Answer(False, f"not armed: {refusal}.")
    if not gate.requires_arm:
        return Answer(True, f"armed (the {backend} rig is simulated and needs no arm)." if had_go else
                      f"armed again after ~/disarm: the simulated {backend} rig commands fresh setpoints, ramping up "
                      f"from 0 bar over {gate.ramp_time_s:g} s.")
    message = (f"{REAL_ARM_PREFIX}: the {backend} rig now commands fresh setpoints, ramping up from 0 bar over "
               f"{gate.ramp_time_s:g} s; ~/emergency_stop or ~/disarm vents.")
    return Answer(True, message, warning=message)


def disarm(gate: CommandGate) -> Answer:
    """Withdraw the operator's go on any rig: 0 bar until :func:`arm`."""
    if gate.disarm():
        message = "disarmed: venting to 0 bar until ~/arm."
        return Answer(True, message, warning=message)
    return Answer(True, "was not armed: output stays at 0 bar until ~/arm.")


def reset(gate: CommandGate) -> Answer:
    """Release the e-stop latch; output resumes with the next fresh setpoint (after a new arm where needed)."""
    was_latched = gate.reset_estop()
    then = "call ~/arm, then output ramps up with" if not gate.has_go else "output ramps up with"
    if not was_latched:
        return Answer(True, "e-stop was not latched; nothing to reset.")
    return Answer(True, f"e-stop released; {then} the next fresh setpoint.",
                  warning=f"e-stop released: {then} the next fresh setpoint")


def estop_message(gate: CommandGate, had_backend: bool, fault: str = "") -> str:
    """The e-stop's answer once the node has vented: ``fault`` is the backend fault if the vent failed ('' if not)."""
    message = ("e-stop latched: every valve vented to 0 bar" if had_backend and not fault
               else "e-stop latched (no backend open, nothing to vent)" if not fault
               else f"e-stop latched; {VENT_FAILED}; node went to the error state: {fault}")
    return message + "; call ~/reset to release" + (", then ~/arm." if not gate.has_go else ".")
