"""Figures of a gait cycle like the paper's Fig. 4 (gait curves with the bodies) and Fig. 5 (joint trajectories).

Everything drawn is what is commanded: the bodies are the backbones of the cycle's lengths, the curves the
gait's shape with the parameters solved for the cycle's amplitude (``GaitCycle.parameters``).
Matplotlib with the Agg backend (files only, no display); ``*_figure`` build a figure, ``plot_*`` write one
PNG and return its path.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from srs_ros.core.gait.library import gait_spec, shape_curves  # noqa: E402
from srs_ros.core.gait.trajectory import GaitCycle  # noqa: E402
from srs_ros.core.kinematics import backbone_points  # noqa: E402

#: Figure size in inches and resolution: 1200 x 800 pixels.
FIGURE_SIZE_IN = (12.0, 8.0)
DPI = 100
#: Line styles and sample markers of the actuators of one module, so that overlapping traces stay apart.
ACTUATOR_STYLES = (("-", "o"), ("--", "s"), (":", "^"))
#: Line width of the commanded bodies (the gait curves are thin).
BODY_LINE_WIDTH = 3.0


def _gait_parameters(cycle: GaitCycle) -> dict:
    """The gait's own parameters from ``cycle.parameters`` (the commanded shape's, without derived values)."""
    names = {p.name for p in gait_spec(cycle.gait).parameters}
    return {k: v for k, v in cycle.parameters.items() if k in names}


def is_planar(curves: np.ndarray, tolerance_m: float = 1e-9) -> bool:
    """True when every curve lies in the ground plane, the body's X-Z plane (+Y is up, e.g. serpentine)."""
    return float(np.ptp(curves[..., 1])) <= tolerance_m


def shapes_figure(cycle: GaitCycle, shapes: int = 8):
    """Fig. 4: ``shapes`` gait curves of the cycle (thin) and the commanded bodies (thick), robot frame, mm.

    A planar gait is seen from above (forward +Z to the right, left +X up, equal scales); others in 3-D.
    """
    robot = cycle.robot
    index = np.unique(np.linspace(0, cycle.sample_count, shapes, endpoint=False).astype(int))
    curves, _, _ = shape_curves(cycle.gait, cycle.phase[index], robot, _gait_parameters(cycle))
    bodies = backbone_points(cycle.lengths_m[index], robot=robot) * 1e3
    curves = curves * 1e3
    colours = plt.cm.viridis(np.linspace(0.0, 0.9, len(index)))
    fig = plt.figure(figsize=FIGURE_SIZE_IN, dpi=DPI)
    planar = is_planar(curves)
    axes = fig.add_subplot(1, 1, 1) if planar else fig.add_subplot(1, 1, 1, projection="3d")
    for n, colour in enumerate(colours):
        label = f"phase {cycle.phase[index[n]]:.3f} ({cycle.fit_error_mm[index[n]]:.2f} mm)"
        if planar:
            axes.plot(curves[n, :, 2], curves[n, :, 0], color=colour, linewidth=0.8, alpha=0.7)
            axes.plot(bodies[n, :, 2], bodies[n, :, 0], color=colour, linewidth=BODY_LINE_WIDTH, label=label)
        else:
            axes.plot(*curves[n].T, color=colour, linewidth=0.8, alpha=0.7)
            axes.plot(*bodies[n].T, color=colour, linewidth=BODY_LINE_WIDTH, label=label)
    shape = ", ".join(f"{name} = {cycle.parameters[name]:.4g}" for name in cycle.shape_parameters)
    title = (f"{cycle.gait} at {cycle.amplitude_bar:g} bar{' (' + shape + ')' if shape else ''}: gait curves (thin), "
             f"commanded body (thick)")
    if planar:
        axes.set_xlabel("z, forward (mm)")
        axes.set_ylabel("x, left (mm)")
        axes.set_aspect("equal", adjustable="datalim")
        axes.grid(True, alpha=0.3)
        axes.set_title(title + "; seen from above")
    else:
        axes.set_xlabel("x (mm)")
        axes.set_ylabel("y (mm)")
        axes.set_zlabel("z (mm)")
        span = np.ptp(bodies.reshape(-1, 3), axis=0).max() / 2 + 10
        centre = bodies.reshape(-1, 3).mean(axis=0)
        for setter, mid in zip((axes.set_xlim, axes.set_ylim, axes.set_zlim), centre):
            setter(mid - span, mid + span)
        axes.set_title(title + "; robot frame")
    axes.legend(loc="upper left", fontsize=8, title="sample (fit error)")
    return fig


def joints_figure(cycle: GaitCycle, cycles: int = 3, points_per_cycle: int = 200):
    """Fig. 5: the nine actuator length changes (mm) and pressures (bar) over ``cycles`` cycles, against time (s).

    The three actuators of a module differ in line style and sample marker (:data:`ACTUATOR_STYLES`), so
    traces that overlap (e.g. at zero while an actuator rests) stay readable.
    """
    time_s = np.linspace(0.0, cycles * cycle.period_s, cycles * points_per_cycle + 1)
    lengths_mm = cycle.lengths_at(time_s * cycle.frequency_hz) * 1e3
    per_bar = cycle.robot.pressure_per_length_bar_per_m / 1e3
    n_act = cycle.robot.actuators_per_module
    fig, axes = plt.subplots(cycle.robot.module_count, 1, figsize=FIGURE_SIZE_IN, dpi=DPI, sharex=True)
    for module, axis in enumerate(np.atleast_1d(axes)):
        for j in range(n_act):
            k = module * n_act + j
            line_style, marker = ACTUATOR_STYLES[j % len(ACTUATOR_STYLES)]
            axis.plot(time_s, lengths_mm[:, k], linestyle=line_style, linewidth=1.6, label=cycle.joint_names[k])
            axis.plot(cycle.time_s, cycle.lengths_m[:, k] * 1e3, linestyle="none", marker=marker, markersize=3,
                      color=axis.lines[-1].get_color())
        axis.set_ylabel(f"module {module + 1}\nlength change (mm)")
        axis.grid(True, alpha=0.3)
        axis.legend(loc="upper right", fontsize=8)
        right = axis.secondary_yaxis("right", functions=(lambda mm: mm * per_bar, lambda bar: bar / per_bar))
        right.set_ylabel("pressure (bar)")
    np.atleast_1d(axes)[-1].set_xlabel("time (s)")
    fig.suptitle(f"{cycle.gait}: joint-space trajectories, A = {cycle.amplitude_bar:g} bar, "
                 f"f = {cycle.frequency_hz:g} Hz, {cycles} cycles (markers: samples)")
    return fig


def _save(fig, path: str | Path) -> Path:
    path = Path(path)
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return path


def plot_shapes(cycle: GaitCycle, path: str | Path, shapes: int = 8) -> Path:
    """Write :func:`shapes_figure` to ``path`` (PNG)."""
    return _save(shapes_figure(cycle, shapes), path)


def plot_joint_trajectories(cycle: GaitCycle, path: str | Path, cycles: int = 3, points_per_cycle: int = 200) -> Path:
    """Write :func:`joints_figure` to ``path`` (PNG)."""
    return _save(joints_figure(cycle, cycles, points_per_cycle), path)
