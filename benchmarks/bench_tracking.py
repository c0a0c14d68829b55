"""Camera tracking throughput: frames per second of Tracker.process on one core at 640x480 and 1280x720.

Frames are synthetic (srs_ros.tools.synthetic_scene) of a moving robot, rendered before timing.
Target (issue 6): at least 100 fps at 640x480. Also the hard case of a camera tilted 25 deg (4 cm markers,
noise, mild blur, MJPG): the tracker's pose rate against a plain cv2.aruco detector with OpenCV's defaults.
Run: python benchmarks/bench_tracking.py [--frames N]
"""

import argparse
import math
import os
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from srs_ros.core.vision import aruco
from srs_ros.core.vision.tracking import Tracker, TrackerConfig, to_gray
from srs_ros.sim.scene import (
    RobotAppearance,
    SyntheticCamera,
    SyntheticScene,
    constant_velocity_poses,
    write_video,
)


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


def tilted_camera(frames):
    """(tracker pose rate, plain detector both-markers rate, tracker fps, frames) on the tilted-camera video."""
    camera = SyntheticCamera(tilt_rad=math.radians(25.0))
    scene = SyntheticScene(camera=camera, robot=RobotAppearance(marker_size_m=0.04), noise_sigma=4.0,
                           blur_sigma_px=0.8)
    _, poses = constant_velocity_poses(frames / 10.0, 10.0, (-0.35, -0.1, 0.3), (7.0 / frames, 3.5 / frames),
                                       yaw_rate_rad_s=25.0 / frames)
    with tempfile.TemporaryDirectory() as folder:
        video = write_video(Path(folder) / "tilted.avi", scene, poses, 10.0)
        capture = cv2.VideoCapture(str(video))
        images = [capture.read()[1] for _ in poses]
        capture.release()
    plain = aruco.MarkerDetector("DICT_4X4_50")
    plain_both = sum({0, 1} <= set(plain.detect(to_gray(img))[1].tolist()) for img in images)
    tracker = Tracker(camera.calibration())
    start = time.perf_counter()
    tracked = sum(tracker.process(img, i / 10.0).tracked for i, img in enumerate(images))
    elapsed = time.perf_counter() - start
    return tracked / len(images), plain_both / len(images), len(images) / elapsed, len(images)


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
                          ("colour, ROI search", TrackerConfig(detector="color")),
                          ("colour, full frame", TrackerConfig(detector="color", roi_margin_px=0))):
        for width, height in ((640, 480), (1280, 720)):
            fps, tracked, total = measure(width, height, args.frames, config)
            target = "  (target >= 100 fps)" if width == 640 else ""
            print(f"{label:20s} {width}x{height}: {fps:7.1f} fps, {tracked}/{total} frames tracked{target}")
    rate, plain, fps, total = tilted_camera(args.frames)
    print(f"tilted camera 25 deg, 4 cm markers, noise, blur, MJPG, {total} frames: tracker pose in {rate:.0%} "
          f"({fps:.0f} fps), plain cv2.aruco (defaults) both markers in {plain:.0%}")


if __name__ == "__main__":
    main()
