"""The hardware node with a rig's own calibration (srs_identify's file), as a separate process.

Its tests share one node process of the group ``calibrated_map`` (srs_testing.hardware_rig): each muscle
commanded by its own characteristic, and the lag compensation switched live or refused with the reason.
"""

import numpy as np
import pytest
from sensor_msgs.msg import JointState
from srs_testing.hardware_rig import NAMES, NODE, setpoint

from srs_ros.core.actuation.muscle_calibration import calibration_from_values, save_calibration
from srs_ros.core.robot import default_robot

SIM_MUSCLE = {"deadzone_bar": 1.0, "extension_per_bar_m": 0.065 / 3.0, "saturation_bar": 4.0,
              "transport_delay_s": 0.03, "pressure_time_constant_s": 0.08}
ODD_MUSCLE = {"deadzone_bar": 1.4, "extension_per_bar_m": 0.015, "saturation_bar": 3.5,
              "transport_delay_s": 0.03, "pressure_time_constant_s": 0.08}


def calibration_file(tmp_path, dynamics=True):
    """The mock muscles' calibration (m2_pma1 calibrated as another muscle); with or without the dynamics."""
    entries = {name: dict(SIM_MUSCLE) for name in NAMES}
    entries["m2_pma1"] = dict(ODD_MUSCLE)
    if not dynamics:
        entries = {name: {k: v for k, v in e.items() if k.endswith("_bar") or k.endswith("_m")}
                   for name, e in entries.items()}
    path = tmp_path / "calibration.yaml"
    save_calibration(calibration_from_values(entries, default_robot()), path)
    return str(path)


def test_a_calibrated_map_commands_each_muscle_by_its_own_characteristic(hardware, tmp_path):
    proc, rig = hardware({"ramp_time_s": 0.0, "pressure_map": "calibrated",
                          "calibration_file": calibration_file(tmp_path)}, group="calibrated_map")
    rig.start()
    lengths = np.array([0.0, 0.01, 0.0325, 0.021, 0.05, 0.065, 0.02, 0.03, 0.04])
    gain = SIM_MUSCLE["extension_per_bar_m"]
    expected = np.r_[0.0, 1.0 + 0.01 / gain, 2.5, 1.4 + 0.021 / 0.015, 1.0 + 0.05 / gain, 4.0,
                     1.0 + np.array([0.02, 0.03, 0.04]) / gain]
    rig.stream(setpoint(lengths), until=lambda: rig.commanded(expected), what="each muscle's inverted characteristic")
    # The mock muscles are the calibrated ones (but m2_pma1): their measured lengths meet the setpoints.
    default = [0, 1, 2, 4, 5, 6, 7, 8]
    rig.stream(setpoint(lengths), until=lambda: rig.state and np.allclose(
        np.array(rig.state[-1].position)[default], lengths[default], atol=2e-4), what="lengths on actuator_state")
    rig.stream(setpoint(lengths), until=lambda: rig.diagnostic("pressure_map") == "calibrated",
               what="the map on /diagnostics")
    assert rig.counted("limited_setpoints") == 0  # 50 mm and 65 mm are within the calibrated stroke

    beyond = lengths.copy()
    beyond[3] = 0.04  # beyond m2_pma1's saturation (31.5 mm at 3.5 bar)
    rig.stream(setpoint(beyond), until=lambda: rig.counted("limited_setpoints") > 0,
               what="a setpoint beyond the calibrated stroke, limited and counted")
    assert rig.commanded(np.r_[expected[:3], 3.5, expected[4:]])
    # said too (the warning is throttled to one per 5 s: after another test's on this node it comes a moment later)
    rig.stream(setpoint(beyond), until=lambda: "limited by the clamp: ['m2_pma1'] ask [0.04] m" in proc.output(),
               timeout_s=8.0, what="the clamp's warning")
    assert "calibrated map" in proc.output()


@pytest.mark.slow(seconds=3)
def test_lag_compensation_switches_live_leads_and_never_leaves_the_clamp(hardware, tmp_path):
    proc, rig = hardware({"ramp_time_s": 0.0, "pressure_map": "calibrated",
                          "calibration_file": calibration_file(tmp_path)}, group="calibrated_map")
    rig.start()
    gain, odd = SIM_MUSCLE["extension_per_bar_m"], ODD_MUSCLE["extension_per_bar_m"]
    rising = JointState(name=NAMES, position=[0.02] * 9, velocity=[0.1] * 9)
    plain = np.full(9, 1.0 + 0.02 / gain)
    plain[3] = 1.4 + 0.02 / odd
    rig.stream(rising, until=lambda: rig.commanded(plain), what="the map alone while compensation is off")

    assert rig.client.set_parameters(NODE, {"lag_compensation": True})[0].successful
    led = np.full(9, 1.0 + (0.02 + 0.03 * 0.1) / gain + 0.08 * 0.1 / gain)
    led[3] = 1.4 + (0.02 + 0.003) / odd + 0.08 * 0.1 / odd
    rig.stream(rising, until=lambda: rig.commanded(np.minimum(led, [4, 4, 4, 3.5, 4, 4, 4, 4, 4])),
               what="commands leading the delay and inverting the lag")

    jump = JointState(name=NAMES, position=[0.06] * 9, velocity=[5.0] * 9)  # a lead far beyond 4 bar
    count = len(rig.pressure)
    rig.stream(jump, until=lambda: rig.counted("compensation_clamped") > 0, what="the cut lead counted on /diagnostics")
    assert rig.commanded([4, 4, 4, 3.5, 4, 4, 4, 4, 4]) and rig.diagnostic("lag_compensation") == "True"
    rig.stream(jump, until=lambda: "lag compensation: the lead asked for more than [0, 4] bar" in proc.output(),
               timeout_s=8.0, what="the cut lead said (throttled to one warning per 5 s)")
    assert max(max(m.data) for m in rig.pressure[count:]) <= 4.0

    bad = JointState(name=NAMES, position=[0.02] * 9, velocity=[float("nan")] + [0.1] * 8)
    ignored = int(rig.diagnostic("ignored_velocities"))
    rig.stream([bad, jump], until=lambda: int(rig.diagnostic("ignored_velocities")) > ignored
               and "setpoint velocities ignored" in proc.output(),
               what="a NaN velocity ignored, counted and said (the lengths are the command)")
    assert all(np.all(np.isfinite(m.data)) for m in rig.pressure[count:])

    assert rig.client.set_parameters(NODE, {"lag_compensation": False})[0].successful
    rig.stream(rising, until=lambda: rig.commanded(plain), what="the map alone again")


def test_lag_compensation_without_the_lines_dynamics_is_refused_with_the_reason(hardware, tmp_path):
    proc, rig = hardware({"ramp_time_s": 0.0, "pressure_map": "calibrated",
                          "calibration_file": calibration_file(tmp_path, dynamics=False)}, group="calibrated_map")
    rig.start()
    result = rig.client.set_parameters(NODE, {"lag_compensation": True})[0]
    assert not result.successful and "compensation_delay_s" in result.reason
    assert rig.client.change_state(NODE, "deactivate") and rig.client.change_state(NODE, "cleanup")
    results = rig.client.set_parameters(NODE, {"compensation_delay_s": 0.03, "compensation_time_constant_s": 0.08,
                                               "lag_compensation": True})  # the dynamics from parameters instead
    assert all(result.successful for result in results)
    rig.start(("configure", "activate"))
    rig.stream(setpoint(np.full(9, 0.02)), until=lambda: rig.diagnostic("lag_compensation") == "True",
               what="compensation on with the parameters' dynamics")
    assert not rig.client.set_parameters(NODE, {"pressure_map": "linear"})[0].successful
