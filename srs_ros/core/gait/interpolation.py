"""Periodic interpolation of a sampled joint-space cycle, for smooth phase-based playback.

NumPy only: the periodic cubic spline through equally spaced samples solves a circulant system, which an
FFT solves exactly. (SciPy's ``CubicSpline(bc_type="periodic")`` gives the same spline, to rounding; importing
``scipy.interpolate`` cost every gait_player, trajectory_server and srs_bringup start 0.4-0.9 s.)
"""

from __future__ import annotations

import math

import numpy as np

from srs_ros.core.errors import InvalidInputError
from srs_ros.core.validation import finite_array


class PeriodicTrajectory:
    """A periodic C2 cubic spline through N equally spaced samples of one cycle, phase in [0, 1).

    ``samples`` has shape ``(N, D)``: sample ``i`` is the value at phase ``i / N``; the cycle closes
    (phase 1 equals phase 0). Evaluation wraps any real phase.

    >>> import numpy as np
    >>> cycle = PeriodicTrajectory(np.sin(2 * np.pi * np.arange(16) / 16)[:, None])
    >>> round(float(cycle.values(0.25)[0]), 3)
    1.0
    """

    def __init__(self, samples):
        values = finite_array("samples", samples, (None, None))
        if values.ndim != 2 or values.shape[0] < 4:
            raise InvalidInputError(f"samples: expected shape (N >= 4, D), got {values.shape}.")
        self.samples = values
        self._coefficients = np.stack(periodic_spline_coefficients(values), axis=1)  # (N, 4, D)

    @property
    def sample_count(self) -> int:
        return self.samples.shape[0]

    def values(self, phase) -> np.ndarray:
        """Interpolated values at ``phase`` (any shape, wrapped into [0, 1)): shape ``phase.shape + (D,)``."""
        (a, b, c, d), t = self._piece(phase)
        return a + t * (b + t * (c + t * d))

    def derivatives(self, phase) -> np.ndarray:
        """d(values)/d(phase) at ``phase`` (per unit phase; multiply by the frequency for per second)."""
        (_, b, c, d), t = self._piece(phase)
        return b + t * (2.0 * c + t * (3.0 * d))

    def _piece(self, phase) -> tuple[np.ndarray, np.ndarray]:
        """The coefficients ``a, b, c, d`` of the piece each phase falls in, and the phase's offset into it."""
        count = self.sample_count
        if np.ndim(phase) == 0 and math.isfinite(phase):  # the player's one phase per tick: plain floats
            position = float(phase) % 1.0 * count
            index = min(int(position), count - 1)
            return self._coefficients[index], (position - index) / count
        position = np.mod(phase, 1.0) * count
        index = np.floor(position)
        index = np.clip(np.where(np.isfinite(index), index, 0.0), 0, count - 1).astype(int)  # NaN phase -> NaN
        offset = np.expand_dims((position - index) / count, -1)
        return np.moveaxis(self._coefficients[index], -2, 0), offset


def periodic_spline_coefficients(samples: np.ndarray) -> tuple[np.ndarray, ...]:
    """The coefficients ``a, b, c, d`` (each ``(N, D)``) of the periodic C2 cubic spline through ``samples``.

    Piece ``i`` spans phase ``i/N`` to ``(i+1)/N`` and is ``a + b t + c t^2 + d t^3``, ``t`` the phase offset into it.
    With spacing ``h = 1/N`` the second derivatives ``M`` satisfy ``M[i-1] + 4 M[i] + M[i+1] = 6 (y[i-1] - 2 y[i]
    + y[i+1]) / h^2`` cyclically: a circulant system whose eigenvalues ``4 + 2 cos(2 pi k / N)`` are at least 2.
    """
    count = samples.shape[0]
    step = 1.0 / count
    following = np.roll(samples, -1, axis=0)
    curvature = 6.0 * (np.roll(samples, 1, axis=0) - 2.0 * samples + following) / step**2
    eigenvalues = 4.0 + 2.0 * np.cos(2.0 * np.pi * np.arange(count) / count)
    second = np.fft.ifft(np.fft.fft(curvature, axis=0) / eigenvalues[:, None], axis=0).real
    second_following = np.roll(second, -1, axis=0)
    slope = (following - samples) / step - step * (2.0 * second + second_following) / 6.0
    return samples, slope, second / 2.0, (second_following - second) / (6.0 * step)
