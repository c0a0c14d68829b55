"""The periodic spline of a sampled cycle: the periodic C2 cubic spline SciPy's CubicSpline fits, without SciPy."""

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from srs_ros.core.errors import InvalidInputError
from srs_ros.core.gait.interpolation import PeriodicTrajectory


def scipy_periodic(samples: np.ndarray) -> CubicSpline:
    count = samples.shape[0]
    return CubicSpline(np.arange(count + 1) / count, np.vstack([samples, samples[:1]]), axis=0, bc_type="periodic")


@pytest.mark.parametrize("count", [4, 5, 16, 64, 201])
def test_same_spline_as_scipy_periodic_cubic_spline(count):
    rng = np.random.default_rng(count)
    samples = rng.normal(0.02, 0.01, (count, 9))
    ours, reference = PeriodicTrajectory(samples), scipy_periodic(samples)
    phase = np.concatenate([rng.uniform(-3.0, 3.0, 500), np.arange(count + 1) / count, [1.0, -1e-20, 1 - 1e-12]])
    wrapped = np.mod(phase, 1.0)
    np.testing.assert_allclose(ours.values(phase), reference(wrapped), rtol=0, atol=1e-12)
    np.testing.assert_allclose(ours.derivatives(phase), reference.derivative()(wrapped), rtol=0, atol=1e-9)
    for one in phase[:50]:  # the player's path: one phase at a time
        np.testing.assert_allclose(ours.values(float(one)), reference(np.mod(one, 1.0)), rtol=0, atol=1e-12)
        np.testing.assert_allclose(ours.derivatives(one), reference.derivative()(np.mod(one, 1.0)), rtol=0, atol=1e-9)


def test_passes_through_the_samples_and_wraps():
    samples = np.random.default_rng(0).normal(size=(12, 3))
    cycle = PeriodicTrajectory(samples)
    np.testing.assert_allclose(cycle.values(np.arange(12) / 12), samples, atol=1e-14)
    np.testing.assert_allclose(cycle.values(1.0), samples[0], atol=1e-14)
    np.testing.assert_allclose(cycle.values(2.25), cycle.values(0.25), atol=1e-14)
    assert cycle.values(np.zeros((2, 3))).shape == (2, 3, 3)
    assert cycle.derivatives([0.1, 0.2]).shape == (2, 3)


def test_nan_phase_gives_nan_not_an_index_error():
    cycle = PeriodicTrajectory(np.random.default_rng(1).normal(size=(8, 2)))
    assert np.isnan(cycle.values(np.nan)).all()
    assert np.isnan(cycle.values(np.array([0.1, np.nan]))[1]).all()


@pytest.mark.parametrize("samples", [np.zeros((3, 2)), np.zeros(8), [[0.0, np.nan]] * 5])
def test_refuses_too_few_or_non_finite_samples(samples):
    with pytest.raises(InvalidInputError, match="samples"):
        PeriodicTrajectory(samples)
