"""What a change of turn level does to the rolling robot: its yaw's swing and where it travels, level by level.

The navigator steers the rolling gaits by their ``turn_phase_rad`` level, changing it as often as every half
cycle, and learns each level's turn rate from whole cycles measured by the camera (docs/navigation.md). This
measures, on the simulated robot through the gait player's logic (the cross-fade included), what the camera sees:

- **each level held** (``--steady-cycles`` from rest): its turn rate (deg per cycle, counter-clockwise positive),
  its travel (cm per cycle) and the angle from the body's yaw (the camera's tail -> head heading) to the direction
  it travels, over the cycles after the first two;
- **each change of level** (from every level to every other, held ``--hold-cycles`` first, switched as the gait
  player's phase passes each of ``--phases``; outward rolling plays the cycle backward): the first cycle the
  navigator measures (from half a cycle to a cycle and a half after the change) against the rate the new level
  turns at 3.5-5.5 cycles after the change, and the step of the travel heading beyond what the two rates turned
  (the travel heading over the cycle before the change against that over the cycle 3.5-4.5 cycles after it).

If the travel heading of each level sits at a fixed angle to the body's yaw, a change from level a to level b
steps it by offset(b) - offset(a); the summary fits one heading per level to the steps (least squares, level 0
fixed at 0) and gives what the fit leaves and how far a change and its reverse fail to cancel.

Run: python benchmarks/bench_level_change.py [--physics default calibrated anisotropic] [--directions inward_rolling
     outward_rolling] [--phases 0 0.5] [--workers 2]
"""

from __future__ import annotations

import argparse
import math
from concurrent.futures import ProcessPoolExecutor
from functools import cache

import numpy as np
from bench_fine_gait import config_for

from srs_ros.core.navigation.motion import wrap_rad
from srs_ros.core.navigation.settings import DIRECTIONS, load_navigation_settings
from srs_ros.core.rig import load_rig
from srs_ros.core.robot import default_robot
from srs_ros.experiments.turning import play_cycle, rolling_cycle

#: Cycles after a change before the travel heading is compared (the swing has passed by then).
AFTER_CYCLES = 4.0


@cache
def cruise_cycle(level_rad: float):
    """The navigator's rolling cycle at ``level_rad`` (its cruise amplitude and frequency), fitted once a process."""
    settings = load_navigation_settings()
    return rolling_cycle(settings.amplitude_bar, settings.cruise_frequency_hz, level_rad, default_robot())


def play(physics: str, direction: str, levels, switch_s: float, end_s: float) -> np.ndarray:
    """Rows (time_s, x_m, y_m, unwrapped yaw_rad), every command step, of the gait at ``levels[0]``, then
    ``levels[1]`` from ``switch_s`` (the player's cross-fade), as the navigator plays them (outward: backward)."""
    robot = default_robot()
    cycles = [cruise_cycle(float(level)) for level in levels]
    backward = (lambda t: True) if direction != DIRECTIONS[0] else None
    return play_cycle(cycles[0], end_s, config_for(physics, robot), robot, backward,
                      sample_every_s=1.0 / load_rig(robot=robot).command_rate_hz,
                      switch_to=(switch_s, cycles[1]) if len(cycles) > 1 else None)


def turn_deg(rows: np.ndarray, t0_s: float, t1_s: float, period_s: float) -> float:
    """The yaw's line fit over ``[t0_s, t1_s]`` as degrees per cycle, as the navigator measures a cycle."""
    inside = (rows[:, 0] >= t0_s) & (rows[:, 0] <= t1_s)
    return math.degrees(np.polyfit(rows[inside, 0], rows[inside, 3], 1)[0] * period_s)


def travel(rows: np.ndarray, t0_s: float, t1_s: float) -> tuple[float, float, float]:
    """(heading rad, distance m, mean yaw rad) of the move over ``[t0_s, t1_s]``."""
    i0, i1 = np.searchsorted(rows[:, 0], [t0_s, t1_s])
    i1 = min(i1, len(rows) - 1)
    dx, dy = rows[i1, 1:3] - rows[i0, 1:3]
    return math.atan2(dy, dx), math.hypot(dx, dy), float(np.mean(rows[i0:i1 + 1, 3]))


def steady(job) -> tuple:
    """A level held from rest: (rate deg/cycle, travel m/cycle, travel's angle from the yaw, deg)."""
    physics, direction, level, cycles, period_s = job
    rows = play(physics, direction, (level,), 0.0, cycles * period_s)
    rates, moves, offsets = [], [], []
    for k in range(2, cycles):
        t0, t1 = k * period_s, (k + 1) * period_s
        heading, distance, yaw = travel(rows, t0, t1)
        rates.append(turn_deg(rows, t0, t1, period_s))
        moves.append(distance)
        offsets.append(wrap_rad(heading - yaw))
    offset = math.atan2(np.mean(np.sin(offsets)), np.mean(np.cos(offsets)))
    return float(np.mean(rates)), float(np.mean(moves)), math.degrees(offset)


def change(job) -> tuple:
    """A change ``a`` -> ``b`` at gait ``phase``: (first measured cycle - the rate after, travel heading step), deg."""
    physics, direction, a, b, phase, hold_cycles, period_s = job
    backward = direction != DIRECTIONS[0]  # outward rolling: the phase runs down from 1
    switch_s = (hold_cycles + ((1.0 - phase) % 1.0 if backward else phase)) * period_s
    rows = play(physics, direction, (a, b), switch_s, switch_s + (AFTER_CYCLES + 2.5) * period_s)
    before = turn_deg(rows, switch_s - 2.0 * period_s, switch_s, period_s)
    first = turn_deg(rows, switch_s + 0.5 * period_s, switch_s + 1.5 * period_s, period_s)
    after = turn_deg(rows, switch_s + (AFTER_CYCLES - 0.5) * period_s, switch_s + (AFTER_CYCLES + 1.5) * period_s,
                     period_s)
    h0 = travel(rows, switch_s - period_s, switch_s)[0]
    h1 = travel(rows, switch_s + (AFTER_CYCLES - 0.5) * period_s, switch_s + (AFTER_CYCLES + 0.5) * period_s)[0]
    turned = 0.5 * before + AFTER_CYCLES * after
    return first - after, math.degrees(wrap_rad(h1 - h0 - math.radians(turned)))


def fit_headings(levels, steps: dict) -> tuple[np.ndarray, float]:
    """One travel heading per level (deg, level 0 at 0) fitted to the steps; the rms of what it leaves (deg)."""
    n, zero = len(levels), int(np.argmin(np.abs(levels)))
    rows, values = [], []
    for (a, b), step in steps.items():
        row = np.zeros(n)
        row[b], row[a] = 1.0, -1.0
        rows.append(row)
        values.append(step)
    design = np.vstack([rows, np.eye(n)[zero]])
    headings = np.linalg.lstsq(design, np.append(values, 0.0), rcond=None)[0]
    left = np.array(values) - np.array(rows) @ headings
    return headings, float(np.sqrt(np.mean(left ** 2)))


def report(physics: str, direction: str, levels, held: list, changes: dict, phases) -> None:
    """One table and its summary for a physics and direction."""
    steps = {key: float(np.mean([r[1] for r in runs])) for key, runs in changes.items()}
    firsts = np.array([r[0] for runs in changes.values() for r in runs])
    headings, left = fit_headings(levels, steps)
    zero = int(np.argmin(np.abs(levels)))
    trips = [steps[(a, b)] + steps[(b, a)] for a in range(len(levels)) for b in range(a + 1, len(levels))]
    print(f"\n{physics}, {direction}:")
    print("| turn_phase_rad | turn (deg/cycle) | travel (cm/cycle) | travel from the yaw (deg) | the same, "
          "from level 0's (deg) | travel heading fitted to the changes (deg) |")
    print("| --- | --- | --- | --- | --- | --- |")
    for i, level in enumerate(levels):
        rate, move, offset = held[i]
        print(f"| {level:+.2f} | {rate:+.1f} | {100 * move:.1f} | {offset:+.0f} | "
              f"{math.degrees(wrap_rad(math.radians(offset - held[zero][2]))):+.0f} | {headings[i]:+.0f} |")
    by_phase = ", ".join(f"{p:g}: {np.sqrt(np.mean([runs[k][0] ** 2 for runs in changes.values()])):.1f}"
                         for k, p in enumerate(phases))
    print(f"- first measured cycle after a change, against the rate 3.5-5.5 cycles after it: rms "
          f"{np.sqrt(np.mean(firsts ** 2)):.1f} deg, largest {np.max(np.abs(firsts)):.1f} deg ({len(firsts)} "
          f"changes); rms by the phase of the change: {by_phase}")
    print(f"- travel heading steps: rms {np.sqrt(np.mean(np.square(list(steps.values())))):.1f} deg; the fitted "
          f"headings leave {left:.1f} deg rms; a change and its reverse sum to {np.mean(trips):+.1f} deg "
          f"(mean), {np.sqrt(np.mean(np.square(trips))):.1f} deg rms", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--physics", nargs="+", default=["default", "calibrated"],
                        choices=("default", "calibrated", "anisotropic"))
    parser.add_argument("--directions", nargs="+", default=list(DIRECTIONS), choices=DIRECTIONS)
    parser.add_argument("--phases", type=float, nargs="+", default=[0.0, 0.5],
                        help="gait phases of the change (the gait player's phase, in [0, 1))")
    parser.add_argument("--steady-cycles", type=int, default=7)
    parser.add_argument("--hold-cycles", type=int, default=4)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    settings = load_navigation_settings()
    levels, period_s = np.asarray(settings.turn_levels_rad, dtype=float), 1.0 / settings.cruise_frequency_hz
    print(f"turn levels {', '.join(f'{lv:+g}' for lv in levels)} rad at {settings.amplitude_bar:g} bar, "
          f"{settings.cruise_frequency_hz:g} Hz; changes at phases {args.phases}, after {args.hold_cycles} cycles held")
    with ProcessPoolExecutor(args.workers) as pool:
        for physics in args.physics:
            for direction in args.directions:
                held = list(pool.map(steady, [(physics, direction, lv, args.steady_cycles, period_s) for lv in levels]))
                keys = [(a, b) for a in range(len(levels)) for b in range(len(levels)) if a != b]
                jobs = [(physics, direction, levels[a], levels[b], p, args.hold_cycles, period_s)
                        for a, b in keys for p in args.phases]
                results = list(pool.map(change, jobs))
                per = len(args.phases)
                changes = {key: results[i * per:(i + 1) * per] for i, key in enumerate(keys)}
                report(physics, direction, levels, held, changes, args.phases)


if __name__ == "__main__":
    main()
