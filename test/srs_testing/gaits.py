"""Gait cycles as a sender publishes them, written independently of the package's fitter."""

from __future__ import annotations

JOINT_NAMES = [f"m{module}_pma{muscle}" for module in (1, 2, 3) for muscle in (1, 2, 3)]


def rolling_cycle(count: int = 64, shift: float = 0.0, amplitude_m: float = 0.065):
    """A rolling-like cycle: lengths (count, 9) in m, each muscle a raised cosine, phases spread around."""
    import numpy as np

    phase = np.arange(count)[:, None] / count + shift
    offsets = np.arange(9)[None, :] * 2 * np.pi / 3 + np.repeat([0.0, 1.0, 2.0], 3)[None, :] * np.pi / 3
    return 0.5 * amplitude_m * (1 + np.cos(2 * np.pi * phase - offsets))


def trajectory(samples, frequency_hz: float, names=JOINT_NAMES):
    """One closed period as trajectory_server publishes it: ``samples`` (N, 9) columns in ``names`` order."""
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    msg = JointTrajectory(joint_names=list(names))
    count = len(samples)
    for i in range(count + 1):
        t_ns = round(1e9 / frequency_hz) * i // count
        msg.points.append(JointTrajectoryPoint(positions=samples[i % count].tolist(),
                                               time_from_start=Duration(sec=t_ns // 10**9, nanosec=t_ns % 10**9)))
    return msg
