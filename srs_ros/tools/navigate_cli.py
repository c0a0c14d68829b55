"""``srs_navigate``: drive the simulated robot to goals with the navigator's controller, offline and without ROS.

Example::

    srs_navigate --goal 0.5 0.3 --goal -0.4 0.6 --out nav.csv --plot nav.png [--video nav.avi] [--camera]

Each goal is driven to a stop, one after the other (``--path``: followed as waypoints, stopping at the last).
The pose comes from the simulator's tracked point, or with ``--camera`` from the simulated overhead camera's
image through the camera tracker. Prints one line per goal (reached or not, time, resting error, path
length) and writes the track as CSV (:data:`srs_ros.sim.navigation.COLUMNS`; state and direction as names).
Exit codes: 0 every goal reached, 1 some goal not reached, 2 bad arguments or configuration, 130 Ctrl-C
(nothing written).
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from pathlib import Path

import numpy as np

from srs_ros.core.errors import InvalidInputError, SrsError
from srs_ros.core.navigation.commands import NavigationState
from srs_ros.core.navigation.settings import NAVIGATION_TABLE, load_navigation_settings
from srs_ros.core.schema import parse_assignments
from srs_ros.sim.config import load_sim_config, with_friction
from srs_ros.sim.navigation import (
    COLUMNS,
    DEFAULT_GOAL_TIMEOUT_S,
    DIRECTION_CODES,
    STATE_CODES,
    default_area,
    run_navigation,
)
from srs_ros.tools.output import VideoFile, prepare_output_file


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="srs_navigate", description=__doc__.splitlines()[0])
    parser.add_argument("--goal", nargs=2, type=float, action="append", required=True, metavar=("X_M", "Y_M"),
                        help="a goal on the floor (m, floor frame); repeat for more")
    parser.add_argument("--out", type=Path, required=True, help="CSV of the run, one row per camera frame")
    parser.add_argument("--plot", type=Path, help="PNG of the path, the goals and their tolerance")
    parser.add_argument("--video", type=Path, help="MJPG .avi of the overhead camera with the goal drawn")
    parser.add_argument("--camera", action="store_true", help="pose from the simulated camera image + tracker")
    parser.add_argument("--path", action="store_true", help="follow the goals as waypoints, stop at the last")
    parser.add_argument("--friction", help="isotropic | anisotropic | MU | ALONG,ACROSS (as srs_sim)")
    parser.add_argument("--sim-config", help="simulation config YAML (default config/sim.yaml)")
    parser.add_argument("--timeout-s", type=float, default=DEFAULT_GOAL_TIMEOUT_S,
                        help=f"give a goal up after this long, simulated s (default {DEFAULT_GOAL_TIMEOUT_S:g})")
    parser.add_argument("--setting", action="append", default=[], metavar="NAME=VALUE",
                        help=f"a navigator setting, repeatable; one of {', '.join(NAVIGATION_TABLE.names)}")
    return parser


def _settings(items: list[str]):
    values = parse_assignments(items, "--setting", "goal_tolerance_m=0.03")
    return load_navigation_settings(values, where="srs_navigate --setting")


def write_csv(path: Path, rows: np.ndarray) -> Path:
    """The run's rows with state and direction as names."""
    states = {code: state.value for state, code in STATE_CODES.items()}
    directions = {code: name or "stopped" for name, code in DIRECTION_CODES.items()}
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="", encoding="utf-8") as stream:
        writer = csv.writer(stream)
        writer.writerow(COLUMNS)
        for row in rows:
            cells = [f"{v:.6g}" for v in row]
            cells[COLUMNS.index("state")] = states[int(row[COLUMNS.index("state")])]
            cells[COLUMNS.index("direction")] = directions[int(row[COLUMNS.index("direction")])]
            writer.writerow(cells)
    return path


def plot_run(path: Path, result, tolerance_m: float, title: str) -> Path:
    """The path on the floor with the goals, their tolerance circles and where each goal's run ended."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = result.rows
    fig, ax = plt.subplots(figsize=(7, 6))
    ax.plot(100 * rows[:, 1], 100 * rows[:, 2], "-", color="tab:blue", lw=0.8, label="tracked point (truth)")
    if result.camera:
        ax.plot(100 * rows[:, 4], 100 * rows[:, 5], ".", color="tab:orange", ms=1, label="camera pose")
    for i, outcome in enumerate(result.outcomes):
        gx, gy = 100 * np.asarray(outcome.goal_xy_m)
        colour = "tab:green" if outcome.reached else "tab:red"
        ax.add_patch(plt.Circle((gx, gy), 100 * tolerance_m, fill=False, color=colour))
        ax.plot(gx, gy, "+", color=colour, ms=10)
        ax.annotate(f"{i + 1}", (gx, gy), textcoords="offset points", xytext=(6, 6), color=colour)
    ax.plot(100 * rows[0, 1], 100 * rows[0, 2], "o", color="black", label="start")
    ax.set_xlabel("X (cm)")
    ax.set_ylabel("Y (cm)")
    ax.set_title(title, fontsize="small")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


class _Video(VideoFile):
    """Camera frames with the goal and the navigator's state drawn on them (kept only if the run ends)."""

    def __init__(self, path: Path, config):
        import cv2

        from srs_ros.sim.camera import OverheadCamera
        from srs_ros.sim.navigation import CAMERA_RATE_HZ

        self.cv2, self.calibration = cv2, OverheadCamera(config).calibration
        super().__init__(path, CAMERA_RATE_HZ, tuple(self.calibration.image_size_px or (640, 480)))

    def __call__(self, state, image, controller) -> None:
        cv2, frame = self.cv2, image.copy()
        goal = controller.goal
        if goal is not None:
            u, v = self.calibration.floor_to_image(np.asarray(goal))
            cv2.drawMarker(frame, (int(round(u)), int(round(v))), (0, 200, 0), cv2.MARKER_CROSS, 16, 2)
        progress = controller.progress(state.time_s)
        text = f"{progress.state.value} {progress.direction} d={progress.distance_to_go_m:.2f} m"
        cv2.putText(frame, text, (10, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 255, 255), 1, cv2.LINE_AA)
        self.write(frame)


def main(argv: list[str] | None = None) -> int:
    """Console entry point; 0 every goal reached, 1 not all, 2 bad arguments or configuration."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.plot is not None and args.plot.suffix.lower() != ".png":
        parser.error(f"--plot {args.plot}: expected a .png path")
    if not (math.isfinite(args.timeout_s) and args.timeout_s > 0):
        parser.error(f"--timeout-s {args.timeout_s}: expected a number of seconds > 0")
    video = None
    try:
        for path, flag in ((args.out, "--out"), (args.plot, "--plot"), (args.video, "--video")):
            prepare_output_file(path, flag)  # before the run, not after it
        settings = _settings(args.setting)
        config = load_sim_config(args.sim_config)
        if args.friction:
            config = with_friction(config, args.friction)
        area = default_area(config, settings)
        for index, (x_m, y_m) in enumerate(args.goal):  # all of them before any run (a refusal came minutes in)
            if refusal := area.refusal(x_m, y_m):
                raise InvalidInputError(f"--goal {index + 1} of {len(args.goal)}: {refusal}")
        video = _Video(args.video, config) if args.video else None
        result = run_navigation(args.goal, config, settings, camera=args.camera, as_path=args.path,
                                goal_timeout_s=args.timeout_s, on_frame=video, render=video is not None,
                                progress=lambda line: print(line, flush=True))
        if video is not None:
            video.keep()
    except (SrsError, ValueError) as exc:
        print(f"srs_navigate: error: {exc}" + ("; no video written" if video is not None else ""), file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # a traceback and a partial video before (a helper's review)
        print("\nsrs_navigate: interrupted; nothing written", file=sys.stderr)
        return 130
    finally:
        if video is not None:
            video.close()
    write_csv(args.out, result.rows)
    reached = sum(o.reached for o in result.outcomes)
    summary = (f"{reached} of {len(result.outcomes)} goals reached ({config.contact.describe()}, pose from "
               f"{'the camera' if args.camera else 'the simulator'}); {result.wall_time_s:.0f} s wall clock")
    print(summary)
    print(f"wrote {args.out}")
    if args.plot:
        print(f"wrote {plot_run(args.plot, result, settings.goal_tolerance_m, summary)}")
    if args.video:
        print(f"wrote {args.video}")
    return 0 if reached == len(result.outcomes) and all(
        o.state is NavigationState.REACHED for o in result.outcomes) else 1


if __name__ == "__main__":
    sys.exit(main())
