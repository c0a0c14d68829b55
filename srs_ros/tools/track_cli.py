"""``srs_track``: track the robot through a recorded overhead video, offline, as the paper did (Sec. IV).

``srs_track VIDEO --calibration FILE --out track.csv [--plot track.png]`` writes one CSV row
(time_s, x_m, y_m, yaw_rad) per frame where both markers were seen, prints the traveling velocity of the
run (X and Y displacement / time, cm/s, as in Table I) and optionally plots the path like Fig. 7.
"""

from __future__ import annotations

import argparse
import csv
import math
import re
import sys
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from srs_ros.core.errors import ConfigurationError, InvalidInputError, SrsError
from srs_ros.core.robot import config_dir
from srs_ros.core.vision.camera_calibration import DEFAULT_CALIBRATION_FILE, load_calibration
from srs_ros.core.vision.tracking import DETECTORS, TRACKER_TABLE, Tracker, TrackerConfig, traveling_velocity
from srs_ros.tools.output import check_distinct_paths, prepare_output_file

#: The tracker options srs_track takes, by flag (the camera_tracker node's parameter names).
OPTION_FLAGS = {"--detector": "detector", "--dictionary": "aruco_dictionary", "--tail-id": "tail_marker_id",
                "--head-id": "head_marker_id", "--position-ratio": "position_ratio"}


def _progress_bar(total: int | None, name: str):
    return tqdm(total=total, desc=name, unit="frame", file=sys.stderr, dynamic_ncols=True)


def track_video(video: str | Path, tracker: Tracker, fps: float | None = None, progress: bool = False
                ) -> tuple[np.ndarray, int]:
    """Track every frame of a video; returns (rows (n, 4) of time_s, x_m, y_m, yaw_rad; frame count).

    Frame times are ``index / fps`` (the file's frame rate unless ``fps`` is given). With ``progress`` a bar on
    stderr counts the frames. A frame the tracker refuses (e.g. a size other than the calibration's) stops the
    run with :class:`InvalidInputError` naming the video, the frame and the reason.
    """
    capture = cv2.VideoCapture(str(video))
    if not capture.isOpened():
        raise ConfigurationError(f"{video}: OpenCV cannot open it as a video (missing file or unsupported codec).")
    rate = fps or capture.get(cv2.CAP_PROP_FPS)
    if not rate or rate <= 0:
        raise ConfigurationError(f"{video}: the file gives no frame rate; pass --fps.")
    rows, index = [], 0
    total = int(capture.get(cv2.CAP_PROP_FRAME_COUNT)) or None
    bar = _progress_bar(total, Path(video).name) if progress else None
    try:
        while True:
            ok, frame = capture.read()
            if not ok:
                break
            try:
                result = tracker.process(frame, index / rate)
            except InvalidInputError as exc:
                raise InvalidInputError(f"{video}, frame {index}: {exc}") from None
            if result.tracked:
                rows.append((result.time_s, *result.pose))
            index += 1
            if bar is not None:
                bar.update()
    finally:
        if bar is not None:
            bar.close()
        capture.release()
    return np.array(rows, dtype=np.float64).reshape(-1, 4), index


def write_track_csv(path: str | Path, rows: np.ndarray) -> Path:
    """Write rows (n, 4) as CSV with header time_s,x_m,y_m,yaw_rad."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="", encoding="utf-8") as stream:
        writer = csv.writer(stream)
        writer.writerow(["time_s", "x_m", "y_m", "yaw_rad"])
        writer.writerows([f"{t:.4f}", f"{x:.6f}", f"{y:.6f}", f"{yaw:.6f}"] for t, x, y, yaw in rows)
    return path


def plot_track(path: str | Path, rows: np.ndarray, title: str) -> Path:
    """The path on the floor (cm) with heading arrows, start and end, like the paper's Fig. 7."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x_cm, y_cm, yaw = 100.0 * rows[:, 1], 100.0 * rows[:, 2], rows[:, 3]
    fig, ax = plt.subplots(figsize=(6, 5))
    ax.plot(x_cm, y_cm, "-", color="tab:blue", lw=1.5, label="path")
    step = max(1, len(rows) // 15)
    ax.quiver(x_cm[::step], y_cm[::step], np.cos(yaw[::step]), np.sin(yaw[::step]), color="tab:gray",
              width=0.004, scale=25, label="heading")
    ax.plot(x_cm[0], y_cm[0], "o", color="tab:green", label="start")
    ax.plot(x_cm[-1], y_cm[-1], "s", color="tab:red", label="end")
    ax.set_xlabel("X (cm)")
    ax.set_ylabel("Y (cm)")
    ax.set_title(title)
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def tracker_config(args: argparse.Namespace, parser: argparse.ArgumentParser) -> TrackerConfig:
    """The tracker options of the flags, each checked first (a refusal names the flag, before any work)."""
    values = {option: getattr(args, flag[2:].replace("-", "_")) for flag, option in OPTION_FLAGS.items()}
    for flag, option in OPTION_FLAGS.items():
        if not TRACKER_TABLE[option].convert(values[option])[0]:
            parser.error(f"{flag} {values[option]}: expected {TRACKER_TABLE[option].expected}")
    try:
        return TrackerConfig.from_dict(values, "srs_track")
    except ConfigurationError as exc:  # a combination: equal ids, an id the dictionary does not hold
        message = str(exc).removeprefix("srs_track: ")
        for flag, option in OPTION_FLAGS.items():
            message = re.sub(rf"\b{option}\b", flag, message)
        parser.error(message)


#: The highest frame rate taken (Hz): a camera's file rarely says more; 1e300 made every frame one instant.
MAX_FPS_HZ = 1000.0


def main(argv: list[str] | None = None) -> int:
    """Console script ``srs_track``."""
    parser = argparse.ArgumentParser(prog="srs_track", description=__doc__.splitlines()[0])
    parser.add_argument("video", help="recorded overhead video")
    parser.add_argument("--calibration", help="floor calibration YAML (default config/camera_calibration.yaml)")
    parser.add_argument("--out", required=True, help="output CSV (time_s, x_m, y_m, yaw_rad)")
    parser.add_argument("--plot", help="also save a plot of the path (PNG)")
    parser.add_argument("--fps", type=float, help="frame rate, Hz, if the file's is wrong or missing")
    option = {f.name: f for f in TRACKER_TABLE}  # the defaults and ranges of the camera_tracker node's options
    parser.add_argument("--detector", choices=DETECTORS, default=option["detector"].default,
                        help=f"marker kind (default {option['detector'].default})")
    parser.add_argument("--dictionary", default=option["aruco_dictionary"].default, help="ArUco dictionary")
    parser.add_argument("--tail-id", type=int, default=option["tail_marker_id"].default,
                        help=f"ArUco id of the tail marker (default {option['tail_marker_id'].default})")
    parser.add_argument("--head-id", type=int, default=option["head_marker_id"].default,
                        help=f"ArUco id of the head marker (default {option['head_marker_id'].default})")
    parser.add_argument("--position-ratio", type=float, default=option["position_ratio"].default,
                        help=f"tracked point between tail (0) and head (1) (default "
                             f"{option['position_ratio'].default})")
    parser.add_argument("--end-window", type=float, default=0.0,
                        help="average the position over this many seconds at each end of the run (default 0)")
    args = parser.parse_args(argv)
    if not (math.isfinite(args.end_window) and args.end_window >= 0.0):
        parser.error(f"--end-window {args.end_window}: expected seconds >= 0")
    if args.fps is not None and not (math.isfinite(args.fps) and 0.0 < args.fps <= MAX_FPS_HZ):
        parser.error(f"--fps {args.fps}: expected a frame rate in (0, {MAX_FPS_HZ:g}] Hz")
    if args.plot is not None and Path(args.plot).suffix.lower() != ".png":  # Matplotlib failed after the CSV
        parser.error(f"--plot {args.plot}: expected a .png path")
    config = tracker_config(args, parser)
    try:
        calibration = args.calibration or config_dir() / DEFAULT_CALIBRATION_FILE  # an input too, the default's
        check_distinct_paths({"the video": args.video, "--calibration": calibration, "--out": args.out,
                              "--plot": args.plot})
        for path, flag in ((args.out, "--out"), (args.plot, "--plot")):
            prepare_output_file(path, flag)  # before the video is tracked, not after it
        tracker = Tracker(load_calibration(args.calibration), config)
        rows, frames = track_video(args.video, tracker, args.fps, progress=True)
        velocity = traveling_velocity(rows[:, 0], rows[:, 1], rows[:, 2], args.end_window)  # refused: no CSV
        write_track_csv(args.out, rows)
        print(f"{args.video}: {frames} frames, {len(rows)} tracked, {frames - len(rows)} without a pose; "
              f"track written to {args.out}")
    except (SrsError, InvalidInputError) as exc:
        print(f"srs_track: {exc}", file=sys.stderr)
        return 2
    print(f"traveling velocity (Table I, v_x / v_y): {velocity.table_text()} over {velocity.duration_s:.2f} s "
          f"(signed vx {velocity.vx_cm_s:+.3f} cm/s, vy {velocity.vy_cm_s:+.3f} cm/s, "
          f"net {velocity.speed_cm_s:.3f} cm/s)")
    if args.plot:
        plot_track(args.plot, rows, f"{Path(args.video).name}: {velocity.table_text()}")
        print(f"plot written to {args.plot}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
