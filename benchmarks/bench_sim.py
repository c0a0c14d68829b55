"""Simulated robot: real-time factor offline, render cost, CPU share of a real-time loop, speed/fidelity vs segments.

1. Offline real-time factor of 15 s of inward rolling (4 bar, 1 Hz) at the default resolution (target >= 10x
   on one core; the gait's fit is done before timing).
2. Per-frame cost of the overhead camera at 640x480.
3. CPU share of a real-time loop, as a node would run it: commands at the rig's command rate, the world
   stepped to the wall clock, a state + a rendered frame at 30 fps (target <= 30 % of a core).
4. Speed and fidelity against the segment count (3, 5, 8 per module): real-time factor, the chords'
   distance to the kinematic arc at the largest bend of the run, the traveling velocity and turning.

Run: python benchmarks/bench_sim.py [--quick] [--sim-config FILE]   (pinned to one core; FILE e.g.
config/sim_held_spin.yaml, default config/sim.yaml)
"""

import argparse
import math
import os
import time
import warnings

import cv2
import numpy as np

from srs_ros.core.gait.trajectory import generate_cycle
from srs_ros.core.kinematics import backbone_points
from srs_ros.core.rig import load_rig
from srs_ros.sim.camera import OverheadCamera
from srs_ros.sim.config import load_sim_config
from srs_ros.sim.experiment import command_pressures_bar, run_experiment
from srs_ros.sim.world import SimWorld

GAIT, AMPLITUDE_BAR, FREQUENCY_HZ, RUN_S = "inward_rolling", 4.0, 1.0, 15.0


def offline_factor(config, cycle, repeats):
    """Median wall and CPU real-time factors of the 15 s run, and the last result."""
    walls, cpus, result = [], [], None
    for _ in range(repeats):
        cpu = time.process_time()
        result = run_experiment(GAIT, AMPLITUDE_BAR, FREQUENCY_HZ, RUN_S, config, cycle=cycle)
        cpus.append(RUN_S / (time.process_time() - cpu))
        walls.append(result.realtime_factor)
    return float(np.median(walls)), float(np.median(cpus)), result


def render_cost(config, cycle, frames):
    """Median ms per rendered 640x480 frame, over the states of a rolling run."""
    states = []
    run_experiment(GAIT, AMPLITUDE_BAR, FREQUENCY_HZ, frames / 30.0, config, cycle=cycle, on_frame=states.append)
    camera = OverheadCamera(config)
    camera.render(states[0].nodes_m)
    costs = []
    for state in states:
        start = time.perf_counter()
        camera.render(state.nodes_m)
        costs.append(time.perf_counter() - start)
    return 1000.0 * float(np.median(costs)), camera.size_px


def realtime_loop_share(config, cycle, duration_s):
    """CPU share of one core used by a loop that keeps the world at wall-clock time and renders at 30 fps."""
    world, camera = SimWorld(config), OverheadCamera(config)
    command_period = 1.0 / load_rig().command_rate_hz
    frame_period = 1.0 / 30.0
    next_command = next_frame = 0.0
    frames = 0
    start_wall, start_cpu = time.perf_counter(), time.process_time()
    while True:
        now = time.perf_counter() - start_wall
        if now >= duration_s:
            break
        world.advance_to(now)
        if now >= next_command:
            world.command_pressures(command_pressures_bar(cycle, np.array([world.time_s]))[0])
            next_command += command_period
        if now >= next_frame:
            camera.render(world.state().nodes_m)
            frames += 1
            next_frame += frame_period
        time.sleep(max(0.0, min(next_command, next_frame) - (time.perf_counter() - start_wall)))
    wall = time.perf_counter() - start_wall
    return (time.process_time() - start_cpu) / wall, frames / wall


def chord_error_mm(config, result_lengths):
    """Largest distance (mm) between the kinematic backbone and the chord polyline at the same xi."""
    world = SimWorld(config)
    worst = 0.0
    for lengths in result_lengths:
        nodes = world.shape.nodes(lengths)
        xi = world.robot.backbone_xi
        exact = backbone_points(lengths, xi, world.robot)
        chords = np.stack([np.interp(xi, world.layout.node_xi, nodes[:, i]) for i in range(3)], axis=-1)
        worst = max(worst, float(np.linalg.norm(exact - chords, axis=1).max()))
    return 1000.0 * worst


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats, shorter real-time loop")
    parser.add_argument("--sim-config", help="simulation config YAML (default config/sim.yaml)")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    cv2.setNumThreads(1)
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
    config = load_sim_config(args.sim_config)
    cycle = generate_cycle(GAIT, AMPLITUDE_BAR, FREQUENCY_HZ, 64)
    print(f"{config.source}: {GAIT} {AMPLITUDE_BAR:g} bar {FREQUENCY_HZ:g} Hz, {RUN_S:g} s; time step "
          f"{1000 * config.physics.time_step_s:g} ms, control period {1000 * config.physics.control_period_s:g} ms, "
          f"{config.body.segments_per_module} segments per module; one core")

    wall, cpu, result = offline_factor(config, cycle, 1 if args.quick else 3)
    v = result.velocity
    print(f"1. offline: real-time factor {wall:.1f}x wall clock, {cpu:.1f}x CPU time (target >= 10x); "
          f"v_x / v_y {v.vx_cm_s:+.2f} / {v.vy_cm_s:+.2f} cm/s, "
          f"bend up to {math.degrees(result.peak_body_bend_rad):.0f} deg")

    ms, size = render_cost(config, cycle, 90 if args.quick else 300)
    print(f"2. render: {ms:.2f} ms per {size[0]}x{size[1]} frame (median)")

    share, fps = realtime_loop_share(config, cycle, 5.0 if args.quick else 15.0)
    print(f"3. real-time loop (step to the wall clock, commands at {load_rig().command_rate_hz:g} Hz, state + render "
          f"at 30 fps): {100 * share:.1f} % of a core at {fps:.1f} fps (target <= 30 %)")

    print("4. segments per module: speed and fidelity (15 s run each)")
    print("   n | real-time factor | chord error at the largest bend | v_x / v_y (cm/s) | net | turning per cycle")
    lengths = []
    probe = SimWorld(config)
    for t in np.arange(0.0, 3.0, 0.05):
        probe.advance_to(t)
        probe.command_pressures(command_pressures_bar(cycle, np.array([probe.time_s]))[0])
        lengths.append(probe.state().length_m)
    for n in (3, 5, 8):
        variant = config.replace("body", segments_per_module=n)
        wall, cpu, result = offline_factor(variant, cycle, 1)
        track = result.track
        per_cycle = track[::int(round(30 / FREQUENCY_HZ))]
        turning = math.degrees(float(np.mean(np.diff(np.unwrap(per_cycle[:, 3])))))
        v = result.velocity
        print(f"   {n} | {wall:5.1f}x wall, {cpu:5.1f}x CPU | {chord_error_mm(variant, lengths):5.1f} mm | "
              f"{v.vx_cm_s:+6.2f} / {v.vy_cm_s:+6.2f} | {v.speed_cm_s:5.2f} | {turning:+5.1f} deg")


if __name__ == "__main__":
    main()
