"""Benchmark of the gait fitter: time per 64-sample cycle and fit errors, against a global-optimiser baseline.

For each gait: the time to fit one cycle (best of --repeats), the mean and worst RMS fit error, the
samples still poor; then, on a few samples, the authors' way (scipy differential_evolution, a global
search, polished by a local bounded solver, on the same cost of paper eq. 3) side by side: its time
per sample, the speed ratio (baseline time per sample / ours per sample) and the cost ratio
(ours / baseline, at most 1.01 is the target).

Run: python benchmarks/bench_fitting.py [--samples 64] [--baseline-samples 3] [--repeats 3]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.optimize import differential_evolution

from srs_ros.core.gait.fitting import fit_shapes, shape_cost
from srs_ros.core.gait.library import gait_curves, list_gaits
from srs_ros.core.gait.trajectory import fit_settings
from srs_ros.core.robot import default_robot


def baseline_fit(curve, robot, weight, seed):
    """Global search + local polish on one shape (the authors' approach): returns (lengths, cost, seconds)."""
    bounds = [(0.0, robot.max_extension_m)] * robot.joint_count

    def cost(q):
        batch = np.atleast_2d(np.asarray(q).T)
        values = shape_cost(batch, np.broadcast_to(curve, (len(batch),) + curve.shape), robot, weight)
        return values if np.ndim(q) > 1 else float(values[0])

    start = time.perf_counter()
    result = differential_evolution(cost, bounds, popsize=15, maxiter=300, tol=1e-8, seed=seed, polish=True,
                                    vectorized=True, updating="deferred")
    return result.x, float(result.fun), time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--baseline-samples", type=int, default=3)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    robot, settings = default_robot(), fit_settings()
    header = (f"{'gait':16s} {'cycle s':>8s} {'mean mm':>8s} {'worst mm':>8s} {'poor':>4s} {'retried':>7s} | "
              f"{'base s/smp':>10s} {'speed x':>8s} {'cost ratio max':>14s}")
    print(header)
    print("-" * len(header))
    for name in list_gaits():
        phase = np.arange(args.samples) / args.samples
        curves, s_m, used = gait_curves(name, phase, robot, None, settings.curve_points)
        best = np.inf
        for _ in range(args.repeats):
            start = time.perf_counter()
            result = fit_shapes(curves, s_m, robot, settings, poor_fit_mm=used["poor_fit_mm"])
            best = min(best, time.perf_counter() - start)
        picks = np.linspace(0, args.samples, args.baseline_samples, endpoint=False).astype(int) + args.samples // 7
        picks %= args.samples
        ratios, base_times = [], []
        for k in picks:
            _, base_cost, seconds = baseline_fit(curves[k], robot, settings.length_weight, seed=int(k))
            ratios.append(result.cost[k] / base_cost)
            base_times.append(seconds)
        per_sample = best / args.samples
        print(f"{name:16s} {best:8.3f} {result.error_mm.mean():8.3f} {result.error_mm.max():8.3f} "
              f"{int(result.poor.sum()):4d} {len(result.retried):7d} | {np.mean(base_times):10.3f} "
              f"{np.mean(base_times) / per_sample:8.0f} {max(ratios):14.6f}")


if __name__ == "__main__":
    main()
