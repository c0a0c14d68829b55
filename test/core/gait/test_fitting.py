"""Shape fitting (paper eq. 3): the exact rolling solution is found, the solver matches a brute-force search."""

import numpy as np
import pytest
from scipy.optimize import minimize

from srs_ros.core.errors import ConfigurationError
from srs_ros.core.gait.fitting import (
    FitSettings,
    closest_points,
    fit_error_mm,
    fit_shapes,
    levenberg_marquardt,
    shape_cost,
)
from srs_ros.core.gait.library import gait_curves, rolling_arc_lengths
from srs_ros.core.gait.trajectory import fit_settings
from srs_ros.core.robot import default_robot

ROBOT = default_robot()
SETTINGS = fit_settings()


def test_closest_points_project_onto_segments():
    curve = np.array([[[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 1.0]]])
    points = np.array([[[0.3, 0.0, 0.4], [0.5, 0.2, 1.5], [-1.0, 0.0, -1.0]]])
    nearest, tangent, inside = closest_points(points, curve)
    np.testing.assert_allclose(nearest[0], [[0.0, 0.0, 0.4], [0.5, 0.0, 1.0], [0.0, 0.0, 0.0]])
    np.testing.assert_allclose(tangent[0, :2], [[0, 0, 1], [1, 0, 0]])
    assert inside[0].tolist() == [True, True, False]


@pytest.mark.parametrize("gait", ["inward_rolling", "outward_rolling"])
def test_fitter_recovers_the_exact_rolling_solution(gait):
    phases = np.arange(32) / 32
    curves, s_m, _ = gait_curves(gait, phases, ROBOT, {"radius_m": 0.2})
    result = fit_shapes(curves, s_m, ROBOT, SETTINGS, poor_fit_mm=0.5)
    assert result.error_mm.max() < 0.5
    assert not result.poor.any()
    exact = rolling_arc_lengths(phases, 0.2, ROBOT, 1.0 if gait == "inward_rolling" else -1.0)
    np.testing.assert_allclose(result.lengths_m, exact, atol=0.5e-3)       # metres: within 0.5 mm
    assert result.lengths_m.min() >= 0.0 and result.lengths_m.max() <= ROBOT.max_extension_m


def test_lm_gradient_is_stationary_and_bounds_hold():
    curves, _, _ = gait_curves("serpentine", [0.2], ROBOT)
    q, cost = levenberg_marquardt(np.full((1, 9), 0.02), curves, ROBOT, SETTINGS.length_weight, 100)
    assert np.all((q >= 0.0) & (q <= ROBOT.max_extension_m))
    assert cost[0] == pytest.approx(shape_cost(q, curves, ROBOT, SETTINGS.length_weight)[0])
    # Free coordinates have (numerically) zero gradient.
    grad = np.zeros(9)
    for i in range(9):
        step = np.zeros(9)
        step[i] = 1e-7
        grad[i] = (shape_cost(q + step, curves, ROBOT, SETTINGS.length_weight)[0]
                   - shape_cost(q - step, curves, ROBOT, SETTINGS.length_weight)[0]) / 2e-7
    free = (q[0] > 1e-6) & (q[0] < ROBOT.max_extension_m - 1e-6)
    assert np.all(np.abs(grad[free]) < 1e-5 * max(1.0, np.abs(grad).max()) + 1e-6)


@pytest.mark.parametrize("gait,phase", [("serpentine", 0.1), ("serpentine", 0.45), ("sidewinding", 0.3),
                                        ("helical_rolling", 0.6)])
def test_cycle_fit_is_as_good_as_a_multistart_local_search(gait, phase):
    curves, s_m, _ = gait_curves(gait, np.arange(16) / 16, ROBOT, points=SETTINGS.curve_points)
    result = fit_shapes(curves, s_m, ROBOT, SETTINGS, poor_fit_mm=100.0)
    k = int(round(phase * 16))
    one = curves[k:k + 1]

    def cost(q):
        return float(shape_cost(q[None], one, ROBOT, SETTINGS.length_weight)[0])

    rng = np.random.default_rng(0)
    best = min(minimize(cost, x0, method="L-BFGS-B", bounds=[(0.0, ROBOT.max_extension_m)] * 9).fun
               for x0 in rng.uniform(0.0, ROBOT.max_extension_m, size=(6, 9)))
    assert result.cost[k] <= 1.01 * best


def test_poor_fits_are_flagged_not_hidden():
    # A sharp serpenoid the three modules cannot follow: the fit reports it.
    curves, s_m, _ = gait_curves("serpentine", np.arange(8) / 8, ROBOT, {"body_wavelengths": 2.0})
    result = fit_shapes(curves, s_m, ROBOT, FitSettings(multistart_count=4), poor_fit_mm=1.0)
    assert result.poor.all()
    assert len(result.retried) == 8
    np.testing.assert_allclose(result.error_mm, fit_error_mm(result.lengths_m, curves, ROBOT))


def test_fit_settings_are_validated():
    with pytest.raises(ConfigurationError, match="fitting.lenght_weight is not a known key"):
        FitSettings.from_config({"lenght_weight": 1.0})
    with pytest.raises(ConfigurationError, match="fitting.max_iterations is -1; expected an integer >= 1"):
        FitSettings.from_config({"max_iterations": -1})
    assert FitSettings.from_config({}) == FitSettings()


def test_closest_points_in_batches_give_what_one_pass_gives(monkeypatch):
    """Above CLOSEST_BATCH_ELEMENTS the shapes go in batches (100 000 rolling samples asked for 4.5 GiB at once)."""
    from srs_ros.core.gait import fitting

    rng = np.random.default_rng(1)
    points, curves = rng.normal(size=(10, 31, 3)), np.cumsum(rng.normal(size=(10, 200, 3)) * 0.01, axis=1)
    whole = fitting.closest_points(points, curves)
    monkeypatch.setattr(fitting, "CLOSEST_BATCH_ELEMENTS", 3 * 31 * 200)  # batches of three shapes
    batched = fitting.closest_points(points, curves)
    for one, other in zip(whole, batched):
        np.testing.assert_array_equal(one, other)
