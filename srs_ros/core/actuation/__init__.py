"""From a setpoint to the air in the muscles, without ROS: the one clamp and every rule around it.

``pressure`` (length -> pressure -> regulator volts through the one [0, 4] bar clamp, paper Sec. IV-B),
``safety`` (what the hardware node may send: setpoint checks, staleness, arm, e-stop, ramps), the hardware
node's other ROS-free pieces (``settings``: its parameters as one schema table and what a configure makes of
them; ``timing``: its clocks checked at configure; ``intake``: one setpoint into the gate and what to say about
it; ``status``: its counters, faults, /diagnostics report and messages; ``operator``: what its services do and
say), ``muscle_model``
(simulated muscles behind regulators), ``muscle_calibration`` (each muscle's measured characteristic and the
maps built on it), ``compensation`` (leading the supply line's delay and lag), ``identification`` (measuring
a rig's muscles), ``paused_runs`` (such a run through the host's pauses: the parts a pause disturbed run
again). The pressure functions are this package's face: ``from srs_ros.core.actuation import
clamp_pressures_bar``.
"""

from srs_ros.core import lazy_exports

_PRESSURE = ("clamp_pressures_bar", "lengths_to_pressures_bar", "pressure_limit_bar", "pressure_limited_length_m",
             "pressures_to_lengths_m", "pressures_to_command_v", "command_v_to_pressures_bar",
             "pressure_amplitude_scale")
_EXPORTS = {**dict.fromkeys(_PRESSURE, "pressure"),
            "CommandGate": "safety", "OutputReason": "safety", "VENT_FAILED": "safety",
            "CommandTiming": "timing", "HARDWARE_SETTINGS": "settings", "Setpoint": "intake", "take_setpoint": "intake",
            "HardwareStatus": "status",
            "MuscleModel": "muscle_model", "MuscleParameters": "muscle_model",
            "PressureMap": "muscle_calibration", "MuscleCalibration": "muscle_calibration",
            "SetpointShaper": "compensation", "identify": "identification"}
__all__ = sorted(_EXPORTS)
__getattr__ = lazy_exports(__name__, _EXPORTS)
