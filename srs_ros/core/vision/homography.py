"""The plane homography ``H`` (3 x 3, up to scale) between two point sets: fitting, applying, its error.

:func:`fit_homography` is the normalised direct linear transform (Hartley and Zisserman, Alg. 4.2) refined by
Gauss-Newton on the target-side error, a step kept only when it lowers that error. Exactly four pairs fix ``H``
exactly (8 degrees of freedom, 2 equations per pair): their error is 0 by construction and is no estimate of
the fit's accuracy. NumPy only; :mod:`srs_ros.core.vision.camera_calibration` builds the floor calibration on it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from srs_ros.core.errors import InvalidInputError

#: Fewest point pairs that fix a plane homography (8 degrees of freedom, 2 equations per pair).
MIN_POINT_PAIRS = 4


def points_array(name: str, value: Any) -> np.ndarray:
    """``value`` as float points (..., 2); refused (naming ``name``) unless finite and of that shape."""
    points = np.asarray(value, dtype=np.float64)
    if points.ndim < 1 or points.shape[-1] != 2:
        raise InvalidInputError(f"{name} has shape {points.shape}; expected (..., 2) points.")
    if not np.all(np.isfinite(points)):
        raise InvalidInputError(f"{name} holds NaN or inf; expected finite coordinates.")
    return points


def apply_homography(homography: np.ndarray, points: Any) -> np.ndarray:
    """Map points (..., 2) through a 3 x 3 homography: ``p' ~ H [p, 1]``, batched over leading axes.

    Example: with ``H = diag(0.001, 0.001, 1)`` (1 mm per pixel), pixel (640, 480) maps to (0.64, 0.48) m.
    Points on the homography's line at infinity come out as inf (never silently as finite numbers).
    """
    points = points_array("points", points)
    h = np.asarray(homography, dtype=np.float64)
    if h.shape != (3, 3):
        raise InvalidInputError(f"homography has shape {h.shape}; expected (3, 3).")
    mapped = points @ h[:, :2].T + h[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        return mapped[..., :2] / mapped[..., 2:3]


def apply_homography_keeping_nan(homography: np.ndarray, points: Any) -> np.ndarray:
    """:func:`apply_homography` of points (..., 2) where a point with a NaN coordinate (lost) maps to NaN."""
    points = np.asarray(points, dtype=np.float64)
    valid = np.all(np.isfinite(points), axis=-1, keepdims=True)
    return np.where(valid, apply_homography(homography, np.where(valid, points, 0.0)), np.nan)


def _normalising_transform(points: np.ndarray) -> np.ndarray:
    """Similarity taking points to zero mean and mean distance sqrt(2) (Hartley normalisation)."""
    centre = points.mean(axis=0)
    spread = np.mean(np.linalg.norm(points - centre, axis=1))
    scale = math.sqrt(2.0) / spread if spread > 0 else 1.0
    return np.array([[scale, 0.0, -scale * centre[0]], [0.0, scale, -scale * centre[1]], [0.0, 0.0, 1.0]])


def fit_homography(source_points: Any, target_points: Any) -> np.ndarray:
    """Least-squares homography ``H`` with ``target ~ H source`` from n >= 4 point pairs (n, 2) each.

    Normalised direct linear transform (Hartley and Zisserman, Alg. 4.2) refined by Gauss-Newton steps on the
    target-side geometric error (each step kept only when it lowers that error), so the result minimises the
    error in target units (metres on the floor). Returns ``H`` scaled so that ``H[2, 2] = 1``. Raises
    :class:`InvalidInputError` when fewer than four pairs are given or the points are degenerate (with exactly
    four pairs: three on one line, on either side). Four pairs fit exactly (no error estimate: it is 0).
    """
    src = points_array("source_points", source_points).reshape(-1, 2)
    dst = points_array("target_points", target_points).reshape(-1, 2)
    if src.shape != dst.shape:
        raise InvalidInputError(f"{len(src)} source points but {len(dst)} target points; expected one per pair.")
    if len(src) < MIN_POINT_PAIRS:
        raise InvalidInputError(
            f"{len(src)} point pairs; a floor homography needs at least {MIN_POINT_PAIRS} (add known floor points)."
        )
    t_src, t_dst = _normalising_transform(src), _normalising_transform(dst)
    s = apply_homography(t_src, src)
    d = apply_homography(t_dst, dst)
    if len(src) == MIN_POINT_PAIRS:
        _refuse_collinear_triples(s, "source (image)")
        _refuse_collinear_triples(d, "target (floor)")
    zeros, ones = np.zeros(len(s)), np.ones(len(s))
    su, sv, du, dv = s[:, 0], s[:, 1], d[:, 0], d[:, 1]
    rows_u = np.stack([su, sv, ones, zeros, zeros, zeros, -du * su, -du * sv, -du], 1)
    rows_v = np.stack([zeros, zeros, zeros, su, sv, ones, -dv * su, -dv * sv, -dv], 1)
    _, singular, vt = np.linalg.svd(np.concatenate([rows_u, rows_v]))
    # 4 pairs give an 8 x 9 system and only 8 singular values: pad to the 9 of the 9 unknowns, so [7] is the 8th.
    singular = np.pad(singular, (0, 9 - len(singular)))
    if singular[7] < 1e-9 * singular[0]:
        raise InvalidInputError("the point pairs are degenerate (collinear or repeated); spread them over the floor.")
    h = np.linalg.inv(t_dst) @ vt[-1].reshape(3, 3) @ t_src
    h = _refine(h / h[2, 2], src, dst)
    if abs(np.linalg.det(h)) < 1e-15:
        raise InvalidInputError("the fitted homography is singular; the point pairs do not span the floor plane.")
    return h


#: Three normalised points (mean distance sqrt(2) from their centre) closer to one line than this are collinear.
COLLINEAR_TOLERANCE = 1e-6


def _refuse_collinear_triples(points: np.ndarray, side: str) -> None:
    """Refuse four (normalised) points of which three lie on one line: they cannot fix a homography."""
    for skip in range(len(points)):
        a, b, c = np.delete(points, skip, axis=0)
        (ux, uy), (vx, vy) = b - a, c - a
        longest = max(float(np.hypot(ux, uy)), float(np.hypot(vx, vy)), float(np.linalg.norm(c - b)))
        if abs(ux * vy - uy * vx) <= COLLINEAR_TOLERANCE * longest**2:
            pairs = ", ".join(str(i + 1) for i in range(len(points)) if i != skip)
            raise InvalidInputError(
                f"the point pairs are degenerate: the {side} points of pairs {pairs} (of 4) lie on one line; four "
                "pairs fix a homography only with no three on a line, in the image and on the floor. Move one point "
                "off the line or add pairs.")


def _cost(params: np.ndarray, src: np.ndarray, dst: np.ndarray) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
    """The sum of squared target-side errors of the 8 free entries ``params`` of H, and its parts.

    Returns (the sum, inf where a point maps to infinity; the residuals (2n,); the mapped points (n, 2); their
    denominators (n,)).
    """
    hh = np.append(params, 1.0).reshape(3, 3)
    den = src @ hh[2, :2] + hh[2, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        pred = (src @ hh[:2, :2].T + hh[:2, 2]) / den[:, None]
    residual = (pred - dst).ravel()
    cost = float(residual @ residual)
    return (cost if np.isfinite(cost) else math.inf), residual, pred, den


def _refine(h: np.ndarray, src: np.ndarray, dst: np.ndarray, iterations: int = 10) -> np.ndarray:
    """Gauss-Newton on the 8 free entries of H, minimising the sum of squared target-side errors.

    A step is kept only when it lowers that sum; otherwise half of it is tried, down to 1/1024, and when none
    does the previous estimate stands (undamped steps could leave the fit worse than the DLT's).
    """
    params = h.ravel()[:8].copy()
    cost, residual, pred, den = _cost(params, src, dst)
    ext = np.column_stack([src, np.ones(len(src))])
    for _ in range(iterations):
        jac = np.zeros((len(src), 2, 8))
        jac[:, 0, 0:3] = ext / den[:, None]
        jac[:, 1, 3:6] = ext / den[:, None]
        jac[:, :, 6:8] = -pred[:, :, None] * src[:, None, :] / den[:, None, None]
        step, *_ = np.linalg.lstsq(jac.reshape(-1, 8), -residual, rcond=None)
        for _halving in range(11):
            trial = params + step
            trial_cost, trial_residual, trial_pred, trial_den = _cost(trial, src, dst)
            if trial_cost < cost:
                break
            step = 0.5 * step
        else:
            break  # no step along the Gauss-Newton direction lowers the error: the previous estimate stands
        converged = np.max(np.abs(step)) < 1e-14 * (1.0 + np.max(np.abs(trial)))
        params, cost, residual, pred, den = trial, trial_cost, trial_residual, trial_pred, trial_den
        if converged:
            break
    return np.append(params, 1.0).reshape(3, 3)


def reprojection_errors_mm(homography: np.ndarray, image_px: Any, floor_m: Any) -> np.ndarray:
    """Distance (mm) between each known floor point and its pixel mapped through ``homography``."""
    mapped = apply_homography(homography, image_px)
    return 1000.0 * np.linalg.norm(mapped - points_array("floor_m", floor_m), axis=-1)
