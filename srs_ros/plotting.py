"""Figures of a gait cycle like the paper's Fig. 4 (gait curves with fitted bodies) and Fig. 5 (joint trajectories).

Matplotlib with the Agg backend (files only, no display); each function writes one PNG and returns its path.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from srs_ros.core.gaits import gait_curves, gait_spec  # noqa: E402
from srs_ros.core.kinematics import backbone_points  # noqa: E402
from srs_ros.core.trajectory import GaitCycle  # noqa: E402

#: Figure size in inches and resolution: 1200 x 800 pixels.
FIGURE_SIZE_IN = (12.0, 8.0)
DPI = 100


def _gait_parameters(cycle: GaitCycle) -> dict:
    """The gait's own parameters from ``cycle.parameters`` (without derived values)."""
    names = {p.name for p in gait_spec(cycle.gait).parameters}
    return {k: v for k, v in cycle.parameters.items() if k in names}


def plot_shapes(cycle: GaitCycle, path: str | Path, shapes: int = 8) -> Path:
    """Fig. 4: ``shapes`` gait curves of the cycle (thin) and the body fitted to each (thick), robot frame, mm.

    The fitted body is the reference fit (lengths / ``amplitude_scale``), the one whose error is
    ``fit_error_mm``; the command scaled to the amplitude is drawn dashed.
    """
    path = Path(path)
    robot = cycle.robot
    index = np.unique(np.linspace(0, cycle.sample_count, shapes, endpoint=False).astype(int))
    curves, _, _ = gait_curves(cycle.gait, cycle.phase[index], robot, _gait_parameters(cycle))
    scale = float(cycle.parameters.get("amplitude_scale", 1.0))
    fitted = backbone_points(cycle.lengths_m[index] / scale, robot=robot) * 1e3
    played = backbone_points(cycle.lengths_m[index], robot=robot) * 1e3
    colours = plt.cm.viridis(np.linspace(0.0, 0.9, len(index)))
    fig = plt.figure(figsize=FIGURE_SIZE_IN, dpi=DPI)
    axes = fig.add_subplot(1, 1, 1, projection="3d")
    for n, colour in enumerate(colours):
        c = curves[n] * 1e3
        label = f"phase {cycle.phase[index[n]]:.3f} ({cycle.fit_error_mm[index[n]]:.2f} mm)"
        axes.plot(c[:, 0], c[:, 1], c[:, 2], color=colour, linewidth=0.8, alpha=0.7)
        axes.plot(*fitted[n].T, color=colour, linewidth=3.0, label=label)
        axes.plot(*played[n].T, color=colour, linewidth=1.2, linestyle="--")
    axes.set_xlabel("x (mm)")
    axes.set_ylabel("y (mm)")
    axes.set_zlabel("z (mm)")
    span = np.ptp(np.concatenate([fitted.reshape(-1, 3), played.reshape(-1, 3)]), axis=0).max() / 2 + 10
    centre = np.concatenate([fitted.reshape(-1, 3), played.reshape(-1, 3)]).mean(axis=0)
    for setter, mid in zip((axes.set_xlim, axes.set_ylim, axes.set_zlim), centre):
        setter(mid - span, mid + span)
    axes.set_title(f"{cycle.gait}: gait curves (thin), fitted body (thick), command at {cycle.amplitude_bar:g} bar "
                   f"(dashed); robot frame")
    axes.legend(loc="upper left", fontsize=8, title="sample (fit error)")
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return path


def plot_joint_trajectories(cycle: GaitCycle, path: str | Path, cycles: int = 3, points_per_cycle: int = 200) -> Path:
    """Fig. 5: the nine actuator length changes (mm) and pressures (bar) over ``cycles`` cycles, against time (s)."""
    path = Path(path)
    time_s = np.linspace(0.0, cycles * cycle.period_s, cycles * points_per_cycle + 1)
    lengths_mm = cycle.lengths_at(time_s * cycle.frequency_hz) * 1e3
    per_bar = cycle.robot.pressure_per_length_bar_per_m / 1e3
    n_act = cycle.robot.actuators_per_module
    fig, axes = plt.subplots(cycle.robot.module_count, 1, figsize=FIGURE_SIZE_IN, dpi=DPI, sharex=True)
    for module, axis in enumerate(np.atleast_1d(axes)):
        for j in range(n_act):
            k = module * n_act + j
            axis.plot(time_s, lengths_mm[:, k], label=cycle.joint_names[k])
            axis.plot(cycle.time_s, cycle.lengths_m[:, k] * 1e3, "o", markersize=2, color=axis.lines[-1].get_color())
        axis.set_ylabel(f"module {module + 1}\nlength change (mm)")
        axis.grid(True, alpha=0.3)
        axis.legend(loc="upper right", fontsize=8)
        right = axis.secondary_yaxis("right", functions=(lambda mm: mm * per_bar, lambda bar: bar / per_bar))
        right.set_ylabel("pressure (bar)")
    np.atleast_1d(axes)[-1].set_xlabel("time (s)")
    fig.suptitle(f"{cycle.gait}: joint-space trajectories, A = {cycle.amplitude_bar:g} bar, "
                 f"f = {cycle.frequency_hz:g} Hz, {cycles} cycles (dots: fitted samples)")
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return path
