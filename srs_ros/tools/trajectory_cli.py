"""``srs_trajectory``: fit a gait's joint-space cycle and write it as CSV (and the paper's figures as PNG).

Example::

    srs_trajectory --gait inward_rolling --amplitude-bar 4 --frequency-hz 1 --samples 64 --out traj.csv --plot traj.png
    srs_trajectory --list

``--plot traj.png`` writes ``traj_shapes.png`` (paper Fig. 4) and ``traj_joints.png`` (Fig. 5).
Exit codes: 0 success, 2 bad arguments or input (with a message saying what is allowed), 3 poor
samples with ``--strict``.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

from srs_ros.core.errors import SrsError
from srs_ros.core.gait.request import FREQUENCY_FIELD, MIN_SAMPLES, SAMPLES_FIELD
from srs_ros.core.gait.trajectory import PoorFitWarning, generate_cycle, list_gaits
from srs_ros.core.robot import ROBOT_FILE, config_dir, default_robot, load_robot
from srs_ros.tools.output import check_distinct_paths, prepare_output_file

#: Most cycles the joint plot shows (200 points a cycle and joint: a million asked for 14 GB after the CSV was written).
MAX_PLOT_CYCLES = 1000


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="srs_trajectory",
        description="Fit a gait's joint-space cycle (paper Sec. III), scale it to a pressure amplitude and "
                    "write it as CSV: phase, time_s, m1_pma1..m3_pma3 (m), fit_error_mm, <joint>_bar, poor.")
    parser.add_argument("--gait", help="gait name, or 'list' to print the gaits and their parameters")
    parser.add_argument("--list", action="store_true", help="print the gaits and their parameters and exit")
    parser.add_argument("--amplitude-bar", type=float, default=None,
                        help="largest pressure of the cycle, bar (0 < A <= max_pressure_bar, 4 bar)")
    parser.add_argument("--frequency-hz", type=float, default=None,
                        help=f"cycle frequency: {FREQUENCY_FIELD.expected}")
    parser.add_argument("--samples", type=int, default=SAMPLES_FIELD.default,
                        help=f"samples per cycle (>= {MIN_SAMPLES}, default {SAMPLES_FIELD.default})")
    parser.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                        help="gait parameter override, repeatable (see --list)")
    parser.add_argument("--out", type=Path, help="CSV file to write (a <out>.yaml sidecar holds the metadata)")
    parser.add_argument("--plot", type=Path, help="PNG path: writes <stem>_shapes.png and <stem>_joints.png")
    parser.add_argument("--plot-cycles", type=int, default=3,
                        help=f"cycles shown in the joint plot, 1 to {MAX_PLOT_CYCLES} (default 3)")
    parser.add_argument("--robot", type=Path, help="robot description YAML (default: the package's robot.yaml)")
    parser.add_argument("--strict", action="store_true", help="exit with 3 if any sample fits poorly")
    return parser


def format_gaits() -> str:
    """The gait list as text: name, description, and one line per parameter (default, range, unit)."""
    lines = []
    for spec in list_gaits().values():
        lines.append(f"{spec.name}: {spec.description}")
        for p in spec.parameters:
            lines.append(f"    {p.name} = {p.default!r}  ({p.allowed_text()}) {p.description}")
    return "\n".join(lines)


def _parse_params(items: list[str]) -> dict:
    params = {}
    for item in items:
        name, sep, text = item.partition("=")
        if not sep or not name:
            raise ValueError(f"--param {item!r}: expected NAME=VALUE, e.g. --param radius_m=0.25")
        low = text.strip().lower()
        if low in ("true", "false"):
            params[name.strip()] = low == "true"
            continue
        try:
            value = float(text)
        except ValueError:
            raise ValueError(f"--param {item!r}: the value must be a number or true/false") from None
        params[name.strip()] = int(value) if value.is_integer() and "." not in text and "e" not in low else value
    return params


def _check_outputs(args: argparse.Namespace) -> None:
    """Every file the run will write, checked writable and distinct (ConfigurationError naming the option)."""
    stem = args.plot.with_suffix("") if args.plot else None
    outputs = {"--out": args.out, "--out's metadata": f"{args.out}.yaml" if args.out else None,
               "--plot (shapes)": f"{stem}_shapes.png" if stem else None,
               "--plot (joints)": f"{stem}_joints.png" if stem else None}
    check_distinct_paths({"--robot": args.robot or config_dir() / ROBOT_FILE, **outputs})  # the input too
    for flag, path in outputs.items():
        prepare_output_file(path, flag)


def main(argv: list[str] | None = None) -> int:
    """Console entry point; returns the exit code (0, 2 bad arguments, 3 poor samples with --strict)."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.list or args.gait == "list":
        print(format_gaits())
        return 0
    missing = [flag for flag, value in (("--gait", args.gait), ("--amplitude-bar", args.amplitude_bar),
                                        ("--frequency-hz", args.frequency_hz)) if value is None]
    if missing:
        parser.error(f"missing {', '.join(missing)} (or use --list to see the gaits)")
    if args.plot is not None and args.plot.suffix.lower() != ".png":
        parser.error(f"--plot {args.plot}: expected a .png path")
    if not 1 <= args.plot_cycles <= MAX_PLOT_CYCLES:
        parser.error(f"--plot-cycles {args.plot_cycles}: expected an integer from 1 to {MAX_PLOT_CYCLES}")
    try:
        _check_outputs(args)  # before the fit: a plot that failed after it left a CSV beside an exit 2
        params = _parse_params(args.param)
        robot = load_robot(args.robot) if args.robot else default_robot()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", PoorFitWarning)
            cycle = generate_cycle(args.gait, args.amplitude_bar, args.frequency_hz, args.samples, robot, params)
        for warning in caught:
            print(f"srs_trajectory: warning: {warning.message}", file=sys.stderr)
    except (SrsError, ValueError) as exc:
        print(f"srs_trajectory: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # said as "cannot write output" before
        print(f"srs_trajectory: error: cannot read --robot {args.robot} ({exc})", file=sys.stderr)
        return 2
    except MemoryError:
        print(f"srs_trajectory: error: --samples {args.samples} needs more memory than this machine gives; use "
              "fewer samples (the default is enough to play a cycle smoothly)", file=sys.stderr)
        return 2
    try:
        if args.out:
            cycle.to_csv(args.out)
        if args.plot:
            from srs_ros.plotting import plot_joint_trajectories, plot_shapes

            stem = args.plot.with_suffix("")
            shapes = plot_shapes(cycle, f"{stem}_shapes.png")
            joints = plot_joint_trajectories(cycle, f"{stem}_joints.png", cycles=args.plot_cycles)
            print(f"wrote {shapes} and {joints}")
    except (SrsError, ValueError) as exc:
        print(f"srs_trajectory: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"srs_trajectory: error: cannot write output ({exc})", file=sys.stderr)
        return 2
    print(cycle.summary())
    if args.out:
        print(f"wrote {args.out}")
    return 3 if args.strict and not cycle.ok else 0


if __name__ == "__main__":
    sys.exit(main())
