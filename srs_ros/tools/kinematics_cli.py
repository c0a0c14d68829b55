"""``srs_kinematics``: print the SRS backbone's points (the last the tip) and each module's bend for length changes.

Example: ``srs_kinematics --lengths-m 0.03 0 0 0 0 0 0 0 0`` prints the 31 backbone points (m) and
the tip's bending summary per module. ``--pressures-bar`` takes pressures instead (P = 100 l).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from srs_ros.core.actuation.pressure import pressures_to_lengths_m
from srs_ros.core.errors import InvalidInputError, SrsError
from srs_ros.core.kinematics import backbone_points, lengths_to_bend
from srs_ros.core.robot import load_robot


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="srs_kinematics", description=__doc__.split("\n")[0])
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--lengths-m", type=float, nargs="+", metavar="L", help="9 length changes l_ij (m)")
    group.add_argument("--pressures-bar", type=float, nargs="+", metavar="P", help="9 pressures (bar)")
    parser.add_argument("--robot", default=None, help="robot description YAML (default: the package's)")
    return parser


def _checked(flag: str, values: list[float], top: float, unit: str, robot) -> np.ndarray:
    """``values`` as an array of one per actuator within [0, top]; InvalidInputError naming ``flag`` otherwise."""
    array = np.asarray(values, dtype=float)
    if array.shape != (robot.joint_count,) or not np.all(np.isfinite(array)) or np.any((array < 0) | (array > top)):
        raise InvalidInputError(f"{flag} {' '.join(f'{v:g}' for v in values)}: expected {robot.joint_count} values "
                                f"in [0, {top:g}] {unit}, one per actuator in {', '.join(robot.joint_names)} order.")
    return array


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        robot = load_robot(args.robot)
        if args.pressures_bar is not None:
            pressures = _checked("--pressures-bar", args.pressures_bar, robot.max_pressure_bar, "bar", robot)
            q = pressures_to_lengths_m(pressures, robot)
        elif args.lengths_m is not None:
            q = _checked("--lengths-m", args.lengths_m, robot.max_extension_m, "m", robot)
        else:
            q = np.zeros(robot.joint_count)
        points = backbone_points(q, robot=robot)
        bend, plane, arc = lengths_to_bend(np.reshape(q, (robot.module_count, robot.actuators_per_module)), robot)
    except SrsError as exc:
        print(f"srs_kinematics: {exc}", file=sys.stderr)
        return 2
    print("q (m): " + " ".join(f"{v:.4f}" for v in q))
    for m in range(robot.module_count):
        toward = "(straight)" if bend[m] < 1e-9 else f"toward {np.degrees(plane[m]):7.2f} deg"  # no plane when straight
        print(f"module {m + 1}: bend {bend[m]:.4f} rad {toward}, arc {arc[m]:.4f} m")
    print("xi, x_m, y_m, z_m")
    for xi, (x, y, z) in zip(robot.backbone_xi, points):
        print(f"{xi:.1f}, {x:.6f}, {y:.6f}, {z:.6f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
