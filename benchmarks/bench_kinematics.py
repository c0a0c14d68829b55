"""Benchmark: backbone points and Jacobians per second for a batch of 10^4 configurations x 31 points.

Run: python benchmarks/bench_kinematics.py [--batch 10000] [--repeat 7]
Pins NumPy/BLAS to one thread (the target is "on one core").
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from srs_ros.core.kinematics import backbone_jacobian, backbone_points  # noqa: E402
from srs_ros.core.robot import default_robot  # noqa: E402


def _median_seconds(func, repeat):
    func()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        func()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--batch", type=int, default=10_000)
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()
    robot = default_robot()
    q = np.random.default_rng(0).uniform(0, robot.max_extension_m, (args.batch, robot.joint_count))
    points = args.batch * robot.backbone_xi.size
    t_points = _median_seconds(lambda: backbone_points(q), args.repeat)
    t_jac = _median_seconds(lambda: backbone_jacobian(q), args.repeat)
    print(f"batch {args.batch} configurations x {robot.backbone_xi.size} points (median of {args.repeat})")
    print(f"backbone_points   : {t_points * 1e3:8.1f} ms  {points / t_points / 1e6:6.2f} M points/s   (target >= 5)")
    print(f"backbone_jacobian : {t_jac * 1e3:8.1f} ms  {args.batch / t_jac / 1e3:6.1f} k Jacobians/s "
          f"({points / t_jac / 1e6:.2f} M point-Jacobians/s)")


if __name__ == "__main__":
    main()
