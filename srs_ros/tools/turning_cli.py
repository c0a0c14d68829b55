"""``srs_turning``: measure how the simulated robot turns, print the tables, write the navigator's turn map.

Examples::

    python -m srs_ros.tools.turning_cli                    # turn_phase_rad levels at 4 bar 1 Hz (the navigator's map)
    python -m srs_ros.tools.turning_cli --write-map config/turning_map.yaml
    python -m srs_ros.tools.turning_cli --grid             # turn_phase_rad at 2-4 bar, 0.25-1 Hz
    python -m srs_ros.tools.turning_cli --candidates       # steering candidates compared at 4 bar 1 Hz
    python -m srs_ros.tools.turning_cli --serpentine       # serpentine c on anisotropic friction (or --friction)
    python -m srs_ros.tools.turning_cli --sidewinding --sim-config config/sim_calibrated_paper.yaml

Every run starts at rest and plays the gait through the gait player's logic, as the navigator does
(:mod:`srs_ros.experiments.turning`); each value is run from two start headings (the spread says how
repeatable it is). Re-run after any change of the simulated physics; the tables in docs/navigation.md
and docs/studies/navigation.md come from here. Exit codes: 0, 2 bad arguments or configuration, 130 Ctrl-C.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from srs_ros.core.errors import SrsError
from srs_ros.core.files import write_atomically
from srs_ros.core.navigation.settings import DIRECTIONS, NAVIGATION_TABLE, STOP_PHASES
from srs_ros.experiments import turning
from srs_ros.sim.config import load_sim_config, with_friction
from srs_ros.tools.output import prepare_output_file

#: The sidewinding settings measured by ``--sidewinding``: the default amplitude of its horizontal wave and half of
#: it, each way (a negative value is the gait's mirror image).
SIDEWINDING_LATERAL_RAD = (-0.6, -0.3, 0.3, 0.6)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="srs_turning", description=__doc__.splitlines()[0])
    parser.add_argument("--grid", action="store_true", help="turn_phase_rad -0.35, 0, 0.35 at 2, 3, 4 bar and "
                                                            "0.25, 0.5, 1 Hz")
    parser.add_argument("--candidates", action="store_true",
                        help="compare steering candidates (module phase offset, cone, unequal module amplitude, "
                             "alternating strokes) at 4 bar 1 Hz")
    parser.add_argument("--serpentine", action="store_true",
                        help="serpentine c_rad_per_unit on anisotropic friction (or on --friction's floor)")
    parser.add_argument("--sidewinding", action="store_true",
                        help="sidewinding's lateral_rad -0.6, -0.3, +0.3, +0.6 (negative: the mirror image)")
    parser.add_argument("--write-map", type=Path, metavar="FILE", help="write the navigator's turn map (YAML)")
    parser.add_argument("--amplitude-bar", type=float, default=NAVIGATION_TABLE["amplitude_bar"].default)
    parser.add_argument("--frequency-hz", type=float, default=NAVIGATION_TABLE["cruise_frequency_hz"].default)
    parser.add_argument("--friction", help="isotropic | anisotropic | MU | ALONG,ACROSS (as srs_sim)")
    parser.add_argument("--sim-config", help="simulation config YAML (default config/sim.yaml)")
    parser.add_argument("--cycles", type=int, default=turning.DEFAULT_CYCLES, help="cycles per run (default 8)")
    return parser


def _say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def map_runs(config, amplitude_bar: float, frequency_hz: float, cycles: int) -> dict:
    """The navigator's levels in both directions: direction -> runs."""
    levels = NAVIGATION_TABLE["turn_levels_rad"].default
    rows = {}
    for direction in DIRECTIONS:
        rows[direction] = []
        for level in levels:
            _say(f"  {direction} turn_phase_rad {level:+.2f} ...")
            rows[direction] += turning.measure_turn_phase(direction, amplitude_bar, frequency_hz, level, config,
                                                          cycles=cycles)
    return rows


def grid_runs(config, cycles: int) -> list:
    """turn_phase_rad -0.35, 0, 0.35 over the paper's amplitudes and frequencies."""
    runs = []
    for amplitude in (4.0, 3.0, 2.0):
        for frequency in (1.0, 0.5, 0.25):
            for direction in DIRECTIONS:
                for level in (-0.35, 0.0, 0.35):
                    _say(f"  {direction} {amplitude:g} bar {frequency:g} Hz turn_phase_rad {level:+.2f} ...")
                    runs += turning.measure_turn_phase(direction, amplitude, frequency, level, config, cycles=cycles)
    return runs


def candidate_runs(config, amplitude_bar: float, frequency_hz: float, cycles: int) -> tuple[list, list]:
    """Each steering candidate at +- one setting, both directions; and the alternating strokes (turn in place)."""
    runs = []
    for direction in DIRECTIONS:
        reverse = direction == "outward_rolling"
        base = turning.rolling_cycle(amplitude_bar, frequency_hz, 0.0)
        for label, value, cycle in (
                ("phase offset (turn_phase_rad)", -0.35, turning.rolling_cycle(amplitude_bar, frequency_hz, -0.35)),
                ("phase offset (turn_phase_rad)", 0.35, turning.rolling_cycle(amplitude_bar, frequency_hz, 0.35)),
                ("cone (taper)", -1.0, turning.scaled_module_cycle(base, turning.cone_scales(-1.0))),
                ("cone (taper)", 1.0, turning.scaled_module_cycle(base, turning.cone_scales(1.0))),
                ("head module amplitude", 0.5, turning.scaled_module_cycle(base, (1.0, 1.0, 0.5))),
                ("tail module amplitude", 0.5, turning.scaled_module_cycle(base, (0.5, 1.0, 1.0)))):
            _say(f"  {direction} {label} {value:+g} ...")
            for yaw in turning.DEFAULT_START_YAWS_RAD:
                m = turning.measure(f"{direction}: {label}", cycle, value, config, reverse=reverse, cycles=cycles,
                                    start_yaw_rad=yaw)
                runs.append(m)
    pivots = []
    for inward, outward in ((-0.2, -0.5), (0.5, 0.2), (0.0, 0.0)):
        _say(f"  alternating strokes inward {inward:+g} / outward {outward:+g} ...")
        pivots.append((inward, outward, *turning.measure_pivot(inward, outward, amplitude_bar, frequency_hz,
                                                               config=config)))
    return runs, pivots


def main(argv: list[str] | None = None) -> int:
    """Console entry point."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.cycles <= turning.DEFAULT_SKIP_CYCLES:  # -1 ended in a traceback, 0-2 in NaN rows and a refused map
        parser.error(f"--cycles {args.cycles}: expected more than the {turning.DEFAULT_SKIP_CYCLES} cycles each run "
                     "leaves out before it measures")
    try:
        prepare_output_file(args.write_map, "--write-map")  # before the runs, not after them
        config = load_sim_config(args.sim_config)
        if args.friction:
            config = with_friction(config, args.friction)
        print(f"simulated robot: {config.source}, {config.contact.describe()}; each value from "
              f"{len(turning.DEFAULT_START_YAWS_RAD)} start headings, {args.cycles} cycles, the first "
              f"{turning.DEFAULT_SKIP_CYCLES} left out")
        if args.grid:
            print(turning.table_markdown(grid_runs(config, args.cycles), "turn_phase_rad"))
        if args.candidates:
            runs, pivots = candidate_runs(config, args.amplitude_bar, args.frequency_hz, args.cycles)
            print(turning.table_markdown(runs, "setting"))
            print("\n| alternating strokes (1 cycle each) | turn (deg per pair) | pair-to-pair sd (deg) | "
                  "drift (cm per pair) |\n| --- | --- | --- | --- |")
            for inward, outward, turn, spread, drift in pivots:
                print(f"| inward {inward:+g} / outward {outward:+g} | {turn:+.1f} | {spread:.1f} | {100 * drift:.1f} |")
        if args.serpentine:
            floor = config if args.friction else config.replace("contact", friction="anisotropic")
            _print_setting_runs("serpentine", "c_rad_per_unit", (-0.2, -0.1, 0.0, 0.1, 0.2), floor, args,
                                turning.measure_serpentine)
        if args.sidewinding:
            _print_setting_runs("sidewinding", "lateral_rad", SIDEWINDING_LATERAL_RAD, config, args,
                                turning.measure_sidewinding)
        if not (args.grid or args.candidates or args.serpentine or args.sidewinding) or args.write_map:
            _print_map(config, args)
    except (SrsError, ValueError) as exc:
        print(f"srs_turning: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # a traceback before (a helper's review); a map is written whole or not at all
        print("\nsrs_turning: interrupted", file=sys.stderr)
        return 130
    return 0


def _print_setting_runs(gait: str, setting: str, values, config, args, measure) -> None:
    """``measure(value, amplitude, frequency, config, cycles=...)`` for each value of a gait's setting, as a table."""
    runs = []
    for value in values:
        _say(f"  {gait} {setting} {value:+g} ...")
        runs += measure(value, args.amplitude_bar, args.frequency_hz, config, cycles=args.cycles)
    print(f"{gait} on {config.contact.describe()}:")
    print(turning.table_markdown(runs, setting))


def _print_map(config, args) -> None:
    rows = map_runs(config, args.amplitude_bar, args.frequency_hz, args.cycles)
    print(turning.table_markdown([m for runs in rows.values() for m in runs], "turn_phase_rad"))
    stops = {}
    for direction in DIRECTIONS:
        levels = sorted({m.value for m in rows[direction]})
        per_level = []
        for level in levels:
            _say(f"  {direction} stop offsets at turn_phase_rad {level:+g} ...")
            per_level.append(turning.measure_stop_offsets(direction, args.amplitude_bar, args.frequency_hz,
                                                          turn_phase_rad=level, config=config))
            cells = ", ".join(f"phase {p:g}: {100 * a:+.1f} / {100 * c:+.1f}" for p, (a, c) in
                              zip(STOP_PHASES, per_level[-1]))
            print(f"{direction} turn_phase_rad {level:+.2f}: rests after a stop (cm along / across the travel) "
                  f"{cells}")
        stops[direction] = np.array(per_level)
    if args.write_map:
        text = turning.turning_map_yaml(rows, stops, args.amplitude_bar, args.frequency_hz,
                                        f"{Path(config.source).name}, {config.contact.describe()}")
        write_atomically(args.write_map, text)
        print(f"wrote {args.write_map}")


if __name__ == "__main__":
    sys.exit(main())
