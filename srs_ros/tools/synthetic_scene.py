"""``python -m srs_ros.tools.synthetic_scene out.avi``: a demo video of the robot crossing the floor at constant speed.

The scene itself (camera, floor, robot, renderer) is :mod:`srs_ros.sim.scene`; this is its command line.
"""

from __future__ import annotations

import argparse
import math
import os
import sys

from srs_ros.core.errors import SrsError
from srs_ros.sim.scene import SyntheticScene, constant_velocity_poses, write_video
from srs_ros.tools.output import check_distinct_paths, partial_path, prepare_output_file

#: The largest frame rate (Hz), run length (s) and floor speed (m/s) taken: beyond them a "demo" is a mistake.
MAX_FPS_HZ, MAX_DURATION_S, MAX_SPEED_M_S = 1000.0, 3600.0, 1.0


def main(argv: list[str] | None = None) -> int:
    """Write a demo video (and its calibration) of the robot crossing the floor at constant speed."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0].split(": ", 1)[1])
    parser.add_argument("video", help="output video (.avi, MJPG)")
    parser.add_argument("--calibration-out", help="also write the matching calibration YAML here")
    parser.add_argument("--duration", type=float, default=5.0, help="run length, s (default 5)")
    parser.add_argument("--fps", type=float, default=30.0, help="frame rate, Hz (default 30)")
    parser.add_argument("--vx", type=float, default=0.04, help="floor X velocity, m/s (default 0.04)")
    parser.add_argument("--vy", type=float, default=0.02, help="floor Y velocity, m/s (default 0.02)")
    args = parser.parse_args(argv)
    for flag, value, low, high in (("--duration", args.duration, 0.0, MAX_DURATION_S),
                                   ("--fps", args.fps, 0.0, MAX_FPS_HZ)):
        if not (math.isfinite(value) and low < value <= high):  # NaN, inf, 0 or below gave tracebacks or no frames
            parser.error(f"{flag} {value:g}: expected a number in ({low:g}, {high:g}]")
    for flag, value in (("--vx", args.vx), ("--vy", args.vy)):
        if not (math.isfinite(value) and abs(value) <= MAX_SPEED_M_S):
            parser.error(f"{flag} {value:g}: expected a speed in [-{MAX_SPEED_M_S:g}, {MAX_SPEED_M_S:g}] m/s")
    try:  # every output checked before any is written; the video written whole or not at all
        check_distinct_paths({"the video": args.video, "--calibration-out": args.calibration_out})
        video, calibration = prepare_output_file(args.video, "video"), prepare_output_file(args.calibration_out,
                                                                                           "--calibration-out")
        scene = SyntheticScene()
        _, poses = constant_velocity_poses(args.duration, args.fps, (-0.1, -0.05, 0.3), (args.vx, args.vy))
        partial = partial_path(video)
        try:
            write_video(partial, scene, poses, args.fps)
            os.replace(partial, video)
        finally:
            partial.unlink(missing_ok=True)
        print(f"wrote {len(poses)} frames to {video}")
        if calibration is not None:
            from srs_ros.core.vision.camera_calibration import save_calibration

            save_calibration(scene.camera.calibration(), calibration, "synthetic camera of synthetic_scene.py")
            print(f"wrote calibration to {calibration}")
    except (SrsError, OSError) as exc:
        print(f"synthetic_scene: error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
