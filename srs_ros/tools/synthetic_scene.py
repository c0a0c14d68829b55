"""``python -m srs_ros.tools.synthetic_scene out.avi``: a demo video of the robot crossing the floor at constant speed.

The scene itself (camera, floor, robot, renderer) is :mod:`srs_ros.sim.scene`; this is its command line.
"""

from __future__ import annotations

import argparse
import sys

from srs_ros.sim.scene import SyntheticScene, constant_velocity_poses, write_video


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
    scene = SyntheticScene()
    _, poses = constant_velocity_poses(args.duration, args.fps, (-0.1, -0.05, 0.3), (args.vx, args.vy))
    write_video(args.video, scene, poses, args.fps)
    print(f"wrote {len(poses)} frames to {args.video}")
    if args.calibration_out:
        from srs_ros.core.vision.camera_calibration import save_calibration

        save_calibration(scene.camera.calibration(), args.calibration_out, "synthetic camera of synthetic_scene.py")
        print(f"wrote calibration to {args.calibration_out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
