"""Camera tracking throughput: frames per second of Tracker.process on one core at 640x480 and 1280x720.

Frames are synthetic (srs_ros.tools.synthetic_scene) of a moving robot, rendered before timing.
Target (issue 6): at least 100 fps at 640x480. Run: python benchmarks/bench_tracking.py [--frames N]
"""

import argparse
import math
import os
import time

import cv2
import numpy as np

from srs_ros.core.tracking import Tracker, TrackerConfig
from srs_ros.tools.synthetic_scene import RobotAppearance, SyntheticCamera, SyntheticScene, constant_velocity_poses


def measure(width, height, frames, config):
    robot = RobotAppearance(marker_style="color" if config.detector == "color" else "aruco")
    scene = SyntheticScene(camera=SyntheticCamera(width_px=width, height_px=height,
                                                  horizontal_fov_rad=math.radians(60 if width == 640 else 66)),
                           robot=robot, supersample=2)
    times, poses = constant_velocity_poses(frames / 30.0, 30.0, (-0.25, -0.1, 0.3), (0.1, 0.05), 0.2)
    rng = np.random.default_rng(0)
    images = [scene.render(p, rng) for p in poses[:frames]]
    tracker = Tracker(scene.camera.calibration(), config)
    tracker.process(images[0], 0.0)  # warm-up
    start = time.perf_counter()
    tracked = sum(tracker.process(img, t).tracked for img, t in zip(images, times))
    elapsed = time.perf_counter() - start
    return len(images) / elapsed, tracked, len(images)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=150)
    args = parser.parse_args()
    cv2.setNumThreads(1)
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
    print(f"OpenCV {cv2.__version__}, threads {cv2.getNumThreads()}, {args.frames} frames per case")
    for label, config in (("aruco, ROI search", TrackerConfig()),
                          ("aruco, full frame", TrackerConfig(roi_margin_px=0)),
                          ("colour blobs", TrackerConfig(detector="color"))):
        for width, height in ((640, 480), (1280, 720)):
            fps, tracked, total = measure(width, height, args.frames, config)
            target = "  (target >= 100 fps)" if width == 640 else ""
            print(f"{label:20s} {width}x{height}: {fps:7.1f} fps, {tracked}/{total} frames tracked{target}")


if __name__ == "__main__":
    main()
