"""Periodic interpolation of a sampled joint-space cycle, for smooth phase-based playback."""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline

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
        count = values.shape[0]
        phase = np.arange(count + 1) / count
        closed = np.vstack([values, values[:1]])
        self._spline = CubicSpline(phase, closed, axis=0, bc_type="periodic")
        self._derivative = self._spline.derivative()

    @property
    def sample_count(self) -> int:
        return self.samples.shape[0]

    def values(self, phase) -> np.ndarray:
        """Interpolated values at ``phase`` (any shape, wrapped into [0, 1)): shape ``phase.shape + (D,)``."""
        return self._spline(np.mod(phase, 1.0))

    def derivatives(self, phase) -> np.ndarray:
        """d(values)/d(phase) at ``phase`` (per unit phase; multiply by the frequency for per second)."""
        return self._derivative(np.mod(phase, 1.0))
