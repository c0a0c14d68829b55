"""``srs_sim``: run one gait on the simulated robot (MuJoCo) and measure it like the paper's Table I.

``srs_sim --gait inward_rolling --amplitude-bar 4 --frequency-hz 1 --duration-s 15 --out run.csv
[--plot run.png] [--video run.avi] [--friction isotropic|anisotropic|MU|ALONG,ACROSS] [--sim-config FILE]``
writes the track of the reference point (CSV ``time_s,x_m,y_m,yaw_rad``, floor frame, the point the camera
tracker reports), prints the traveling velocity (v_x, v_y in cm/s: displacement / run time), the signed
displacement and the real-time factor; ``--video`` writes what the overhead camera sees (MJPG .avi),
``--plot`` the path like the paper's Fig. 7.
"""

from __future__ import annotations

import argparse
import math
import sys

from srs_ros.core.errors import SrsError
from srs_ros.core.gait.library import list_gaits
from srs_ros.core.gait.request import MAX_RUN_S
from srs_ros.core.gait.trajectory import generate_cycle
from srs_ros.experiments.table import paper_table
from srs_ros.sim.camera import OverheadCamera
from srs_ros.sim.config import load_sim_config, with_friction
from srs_ros.sim.experiment import DEFAULT_RECORD_RATE_HZ, check_record_rate, run_experiment
from srs_ros.tools.output import VideoFile, prepare_output_file
from srs_ros.tools.track_cli import plot_track, write_track_csv

#: Runs longer than this (simulated seconds) print their progress.
PROGRESS_AFTER_S = 5.0


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"{text!r}: expected a number > 0")
    return value


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="srs_sim", description=__doc__.splitlines()[0])
    parser.add_argument("--gait", required=True, help=f"gait name ({', '.join(sorted(list_gaits()))})")
    parser.add_argument("--amplitude-bar", type=_positive, required=True, help="pressure amplitude A, bar (1-4)")
    parser.add_argument("--frequency-hz", type=_positive, required=True, help="cycle frequency f, Hz")
    paper_s = paper_table().duration_s  # one source: the paper's run time, as srs_sweep's default
    parser.add_argument("--duration-s", type=_positive, default=paper_s,
                        help=f"run time, s (default {paper_s:g}, as the paper; at most {MAX_RUN_S:g})")
    parser.add_argument("--out", required=True, help="output CSV of the track (time_s,x_m,y_m,yaw_rad)")
    parser.add_argument("--plot", help="also save the path plot (PNG)")
    parser.add_argument("--video", help="also save the overhead camera's view (MJPG .avi)")
    parser.add_argument("--friction", help="isotropic | anisotropic (coefficients of the sim config), a coefficient "
                                           "(isotropic, e.g. 0.8) or along,across the body (e.g. 0.3,0.9)")
    parser.add_argument("--sim-config", help="simulation config YAML (default config/sim.yaml)")
    parser.add_argument("--record-rate-hz", type=_positive, default=DEFAULT_RECORD_RATE_HZ,
                        help=f"track and video frame rate, Hz (default {DEFAULT_RECORD_RATE_HZ:g})")
    return parser


class _VideoSink(VideoFile):
    """Renders each recorded state into the video (:class:`~srs_ros.tools.output.VideoFile`: kept on success only)."""

    def __init__(self, path: str, camera: OverheadCamera, fps: float):
        super().__init__(path, fps, camera.size_px)
        self.camera = camera

    def __call__(self, state) -> None:
        self.write(self.camera.render(state.nodes_m))


def main(argv: list[str] | None = None) -> int:
    """Console script ``srs_sim``; exits 2 with the reason on a bad argument or configuration, 130 on Ctrl-C."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.gait not in list_gaits():
        parser.error(f"--gait {args.gait!r}: expected one of {', '.join(sorted(list_gaits()))}")
    if not 0.0 < args.duration_s <= MAX_RUN_S:  # before any file is made (an empty video was left behind)
        parser.error(f"--duration-s {args.duration_s:g}: expected seconds in (0, {MAX_RUN_S:g}]")
    sink = None
    try:
        for path, flag in ((args.out, "--out"), (args.plot, "--plot"), (args.video, "--video")):
            prepare_output_file(path, flag)  # before the run, not after it
        config = load_sim_config(args.sim_config)
        if args.friction:
            config = with_friction(config, args.friction)
        check_record_rate(args.record_rate_hz, config, "--record-rate-hz")
        cycle = generate_cycle(args.gait, args.amplitude_bar, args.frequency_hz)  # its arguments checked first
        if args.video:
            sink = _VideoSink(args.video, OverheadCamera(config), args.record_rate_hz)
        result = run_experiment(args.gait, args.amplitude_bar, args.frequency_hz, args.duration_s, config,
                                record_rate_hz=args.record_rate_hz, on_frame=sink, progress=_progress, cycle=cycle)
        if args.duration_s >= PROGRESS_AFTER_S:
            print(file=sys.stderr)
        if sink is not None:
            sink.keep()
    except SrsError as exc:
        print(f"srs_sim: {exc}" + ("; no video written" if sink is not None else ""), file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("\nsrs_sim: interrupted; nothing written", file=sys.stderr)
        return 130
    finally:
        if sink is not None:
            sink.close()
    _write_results(args, result)
    return 0


def _progress(now_s: float, total_s: float) -> None:
    if total_s >= PROGRESS_AFTER_S:
        print(f"\r  simulated {now_s:5.1f} / {total_s:g} s", end="", file=sys.stderr, flush=True)


def _write_results(args: argparse.Namespace, result) -> None:
    write_track_csv(args.out, result.track)
    print(result.summary())
    print(f"track written to {args.out}")
    if args.video:
        print(f"video written to {args.video}")
    if args.plot:
        title = (f"{result.gait} {result.amplitude_bar:g} bar {result.frequency_hz:g} Hz (simulated): "
                 f"{result.velocity.table_text()}")
        plot_track(args.plot, result.track, title)
        print(f"plot written to {args.plot}")


if __name__ == "__main__":
    sys.exit(main())
