"""Which way the simulated robot rolls: to which side of its body, and toward or away from its opening.

The paper's robot rolls inward toward the opening of its curve and outward away from it, the reverse gait the
other way, at every pressure and frequency where it moves (Sec. IV-C/D). For each rolling gait, pressure (2-4 bar)
and frequency (0.25-1 Hz) this runs the simulated robot from rest and prints the side of the body it travelled to
(the sine of the angle from the tail -> head heading, averaged over the run, to the net displacement: +1 square to
the left, -1 square to the right), the mean speed of the tracked point toward the body's opening
(``SimState.opening_speed_m_s``, cm/s; negative: away; meaningful while the bend stays put in the world, as it
does for a body that spins freely about its axis) and the net speed. A body whose spin about its own axis is held
(a crankshaft rather than a rolling pin) steps to the other side (docs/studies/simulation.md, "Which way a held spin
rolls"). Last, the share of the frames after the first cycle in which the curve an overhead camera sees (the body
projected on the floor, from its middle node toward the midpoint of its ends) opens toward the run's net travel:
1.00 or 0.00 is one steady opening, as the paper describes its robot rolling toward or away from it; near 0.5 the
seen curve opens to either side in turn.

Run: python benchmarks/rolling_direction.py [--sim-config FILE] [--set section.key=VALUE ...] [--duration-s 8]
"""

from __future__ import annotations

import argparse
import math

import numpy as np
from model_study import configured  # benchmarks/: a configuration with section.key changes

from srs_ros.core.errors import ConfigurationError
from srs_ros.experiments.fidelity import GAIT_SIDE, travel_side
from srs_ros.sim.experiment import run_experiment

AMPLITUDES_BAR = (2.0, 3.0, 4.0)
FREQUENCIES_HZ = (0.25, 0.5, 0.75, 1.0)


def roll(config, gait: str, amplitude_bar: float, frequency_hz: float, duration_s: float):
    """(side travelled to, mean speed toward the opening in cm/s, net speed in cm/s, share of the frames after the
    first cycle whose seen opening faces the net travel) of one run from rest."""
    toward, openings = [], []

    def on_frame(state) -> None:
        if not math.isnan(state.opening_speed_m_s):
            toward.append(state.opening_speed_m_s)
            if state.time_s > 1.0 / frequency_hz:
                openings.append(state.reference_xy_m - state.nodes_m[len(state.nodes_m) // 2, :2])

    result = run_experiment(gait, amplitude_bar, frequency_hz, duration_s, config, on_frame=on_frame)
    toward_cm_s = 100.0 * float(np.mean(toward)) if toward else math.nan
    travel = result.track[-1, 1:3] - result.track[0, 1:3]
    facing = float(np.mean(np.asarray(openings) @ travel > 0.0)) if openings else math.nan
    return travel_side(result.track), toward_cm_s, result.velocity.speed_cm_s, facing


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sim-config", help="simulation config (default config/sim.yaml)")
    parser.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                        help="change one value, e.g. contact.roll_damping_nms_per_rad=0.3")
    parser.add_argument("--duration-s", type=float, default=8.0)
    args = parser.parse_args()
    try:
        config = configured(args.sim_config, args.set)
    except ConfigurationError as exc:
        raise SystemExit(str(exc)) from None
    print(f"{config.source}, {args.duration_s:g} s from rest: side (+1 left of the heading) / speed toward the "
          f"opening (cm/s) / net speed (cm/s) / share of frames opening toward the travel")
    print("gait, bar | " + " | ".join(f"{f:g} Hz" for f in FREQUENCIES_HZ))
    sides, opening, steady = {gait: [] for gait in GAIT_SIDE}, 0, 0
    for gait, sign in GAIT_SIDE.items():
        for amplitude in AMPLITUDES_BAR:
            cells = []
            for frequency in FREQUENCIES_HZ:
                side, toward, speed, facing = roll(config, gait, amplitude, frequency, args.duration_s)
                sides[gait].append(side)
                opening += int(toward * sign > 0.0)
                steady += int(math.isfinite(facing) and not 0.1 < facing < 0.9)
                cells.append(f"{side:+5.2f} / {toward:+5.1f} / {speed:4.1f} / {facing:.2f}")
            print(f"{gait} {amplitude:g} | " + " | ".join(cells), flush=True)
    inward, outward = (np.sign(sides[g]) for g in GAIT_SIDE)
    apart = int(np.sum(inward != outward))
    print(f"inward rolling to the left in {int(np.sum(inward > 0))} of {len(inward)} cells, outward to the right in "
          f"{int(np.sum(outward < 0))} of {len(outward)}; the two to opposite sides in {apart} of {len(inward)}; "
          f"toward / away from the opening as the paper's: {opening} of {2 * len(inward)}; one steady seen opening "
          f"(toward the travel in over 90 % of the frames or under 10 %): {steady} of {2 * len(inward)}")


if __name__ == "__main__":
    main()
