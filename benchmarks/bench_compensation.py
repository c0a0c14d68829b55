"""Benchmark of the per-muscle map and the lag compensation on the simulated robot (in-process SimWorld).

1. Identify the simulated rig's muscles with the core of ``srs_identify`` (steps with a vent after each,
   all muscles together, run on an in-process :class:`~srs_ros.sim.world.SimWorld` stepped as the rig's
   clock: the world of ``config/sim.yaml``, whose muscles lag and delay as the sim rig's do).
2. Static error: every muscle held at 10 .. 60 mm through each map; |setpoint - actual length| settled.
3. Inward rolling at 4 bar (the paper's planning amplitude: lengths peak at 40 mm) at 0.5 and 1 Hz,
   through the hardware node's core command path at the rig's command rate (GaitPlayback with its
   velocities -> SetpointShaper (map, compensation, the one clamp) -> CommandGate -> the world):
   RMS of (setpoint length - the muscle's actual length) at the same instants, over all nine muscles,
   after the ramp-in and one cycle; the share of setpoints whose lead the clamp cut; and the travelled
   speed of the tracked reference point (paper Table I style), map paper vs calibrated, compensation
   off vs on.

The muscles' lengths follow the muscle model alone, so the length figures do not depend on the body's
contacts; the speed does.

Run: python benchmarks/bench_compensation.py [--cycles 4] [--rate-hz 200]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from srs_ros.core.actuation.compensation import LineDynamics, SetpointShaper
from srs_ros.core.actuation.identification import Measurement, identify, run_plan, step_plan
from srs_ros.core.actuation.muscle_calibration import CalibratedPressureMap, PaperPressureMap, calibration_from_values
from srs_ros.core.actuation.safety import CommandGate
from srs_ros.core.gait.playback import DEFAULT_RAMP_TIME_S, GaitPlayback
from srs_ros.core.gait.trajectory import generate_cycle
from srs_ros.core.rig import load_rig
from srs_ros.core.robot import config_dir, default_robot
from srs_ros.core.vision.tracking import traveling_velocity
from srs_ros.sim.config import load_sim_config
from srs_ros.sim.world import SimWorld

LEVELS_BAR = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0)
STATIC_LENGTHS_M = (0.01, 0.02, 0.03, 0.04, 0.05, 0.06)


class SimWorldIO:
    """An in-process SimWorld as identification's RigIO: waiting steps the physics."""

    def __init__(self, world: SimWorld):
        self.world = world

    def now_s(self) -> float:
        return self.world.time_s

    def wait_until(self, time_s: float) -> None:
        self.world.advance_to(time_s)

    def write_pressures(self, pressure_bar):
        return self.world.command_pressures(pressure_bar)

    def measure(self) -> Measurement:
        state = self.world.state()
        return Measurement(state.time_s, state.pressure_bar, state.length_m)


def identify_sim(robot, config, rate_hz):
    world = SimWorld(config, robot)
    joints = list(range(robot.joint_count))
    plan = step_plan(robot.joint_count, rate_hz, LEVELS_BAR, 1.0, 0.5, [joints])
    found = identify(robot, joints, run_plan(SimWorldIO(world), plan), plan)
    return calibration_from_values(found.values, robot, source="identified in-process")


def static_error_m(robot, config, pressure_map):
    world = SimWorld(config, robot)
    errors = []
    for length_m in STATIC_LENGTHS_M:
        setpoint = np.full(robot.joint_count, length_m)
        world.command_pressures(pressure_map.pressures_bar(setpoint))
        world.step(1.0)
        errors.append(setpoint - world.state().length_m)
    return np.abs(np.array(errors))


def rolling(robot, config, cycle, frequency_hz, shaper, rate_hz, cycles, timeout_s):
    """One run: (RMS length error m, share of cut setpoints, speed cm/s)."""
    world = SimWorld(config, robot)
    player = GaitPlayback(DEFAULT_RAMP_TIME_S, max_length_m=robot.max_extension_m)
    player.load(cycle.lengths_m, frequency_hz)
    player.start()
    gate = CommandGate(joint_count=robot.joint_count, setpoint_timeout_s=timeout_s)
    gate.set_active(True)
    settle_s = DEFAULT_RAMP_TIME_S + 1.0 / frequency_hz
    count = int(round((settle_s + cycles / frequency_hz) * rate_hz))
    errors, track = [], []
    for k in range(count):
        t = k / rate_hz
        world.advance_to(t)
        setpoint = player.step(1.0 / rate_hz if k else 0.0)
        gate.accept(shaper.pressures_bar(setpoint.positions_m, setpoint.velocities_m_per_s, t), t)
        command, _ = gate.decide(t)
        world.command_pressures(command, t)
        if t >= settle_s:
            state = world.state()
            errors.append(setpoint.positions_m - state.length_m)
            track.append((t, *state.pose))
    track = np.array(track)
    speed = traveling_velocity(track[:, 0], track[:, 1], track[:, 2]).speed_cm_s
    rms = float(np.sqrt(np.mean(np.square(errors))))
    return rms, shaper.compensation_clamped / count, speed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=4, help="measured cycles per run (after ramp-in + one)")
    parser.add_argument("--rate-hz", type=float, default=None, help="command rate (default: the sim rig's)")
    args = parser.parse_args()
    started = time.perf_counter()
    robot = default_robot()
    rig = load_rig(config_dir() / "rigs" / "sim.yaml", robot)
    rate_hz = args.rate_hz or rig.command_rate_hz
    config = load_sim_config(robot=robot)
    muscles = config.muscles
    stroke_m = robot.max_extension_m
    print(f"simulated rig: deadzone {muscles.deadzone_bar:g} bar, {muscles.max_extension_m * 1e3:g} mm at "
          f"{muscles.full_extension_pressure_bar:g} bar, delay {muscles.transport_delay_s * 1e3:g} ms, lag "
          f"{muscles.pressure_time_constant_s * 1e3:g} ms ({config.source}); commands at {rate_hz:g} Hz; "
          f"stroke {stroke_m * 1e3:g} mm")

    calibration = identify_sim(robot, config, rate_hz)
    mean = {key: float(np.mean(getattr(calibration, key))) for key in (
        "deadzone_bar", "extension_per_bar_m", "saturation_bar", "transport_delay_s", "pressure_time_constant_s")}
    print(f"identified (mean of 9 muscles): deadzone {mean['deadzone_bar']:.3f} bar, gain "
          f"{1e3 * mean['extension_per_bar_m']:.3f} mm/bar, saturation {mean['saturation_bar']:.2f} bar, delay "
          f"{1e3 * mean['transport_delay_s']:.1f} ms, tau {1e3 * mean['pressure_time_constant_s']:.1f} ms")
    maps = {"paper": PaperPressureMap(robot), "calibrated": CalibratedPressureMap(calibration, robot)}
    dynamics = LineDynamics.from_calibration(calibration)

    print(f"\nstatic error, every muscle held at {', '.join(f'{v * 1e3:g}' for v in STATIC_LENGTHS_M)} mm:")
    for name, pressure_map in maps.items():
        error = static_error_m(robot, config, pressure_map)
        print(f"  {name:10s} worst {error.max() * 1e3:5.1f} mm ({100 * error.max() / stroke_m:4.1f} % of the stroke), "
              f"mean {error.mean() * 1e3:5.1f} mm ({100 * error.mean() / stroke_m:4.1f} %)")

    print(f"\ninward rolling, 4 bar planning amplitude, {args.cycles} cycles measured after ramp-in + one:")
    header = (f"{'f Hz':>5} {'map':10} {'compensation':>12} {'RMS mm':>7} {'% stroke':>8} {'cut %':>6} "
              f"{'speed cm/s':>10}")
    print(header)
    print("-" * len(header))
    for frequency_hz in (0.5, 1.0):
        cycle = generate_cycle("inward_rolling", 4.0, frequency_hz, 64, robot)
        rms_by = {}
        for name, pressure_map in maps.items():
            for compensation in (False, True):
                shaper = SetpointShaper(pressure_map, dynamics, compensation)
                rms, cut, speed = rolling(robot, config, cycle, frequency_hz, shaper, rate_hz, args.cycles,
                                          rig.setpoint_timeout_s)
                rms_by[name, compensation] = rms
                print(f"{frequency_hz:5.1f} {name:10} {'on' if compensation else 'off':>12} {rms * 1e3:7.2f} "
                      f"{100 * rms / stroke_m:8.1f} {100 * cut:6.1f} {speed:10.2f}")
        print(f"      compensation divides the calibrated map's RMS error by "
              f"{rms_by['calibrated', False] / rms_by['calibrated', True]:.2f}; the calibrated map with compensation "
              f"vs the paper's without: {rms_by['paper', False] / rms_by['calibrated', True]:.2f}x smaller")
    print(f"\nwall time {time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main()
