"""Joint-space shape fitting: the body's backbone points onto a target curve (paper eq. 3), batched.

Cost of one shape (paper eq. 3 in its least-squares form)::

    F(q) = sum_k || p_k(q) - c(p_k(q)) ||^2 + w * sum_ij l_ij^2,   0 <= l_ij <= max_extension_m

``p_k`` are the 31 backbone points (eq. 2, base at the robot origin), ``c(p)`` is the nearest
point of the target curve (a dense polyline; the projection falls on a segment, not just a vertex),
``w`` is ``fitting.length_weight`` of ``config/gaits.yaml``. The paper sums unsquared distances; the
squares make the cost smooth where a point lies on the curve, so a Gauss-Newton solver can use the
exact Jacobian of the kinematics, and they rank good fits the same way.

Solver: a projected Levenberg-Marquardt, batched over all samples of a cycle (one NumPy evaluation of
the kinematics and its Jacobian per iteration for every sample), with an active set for the bounds.
Starts: a geometric guess that bends each module toward the curve; then every sample is restarted
from its neighbours' solutions (warm starts along the cycle) until nothing improves; a sample that is
still poor is retried from many random starts (the global fallback), and reported if still poor.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from srs_ros.core.kinematics import backbone_points, backbone_points_and_jacobian, bend_to_lengths, body_transforms
from srs_ros.core.robot import RobotDescription
from srs_ros.core.schema import Field, Table

# Convergence of one start: relative cost decrease, step (m) and damping limits.
_RELATIVE_DECREASE = 1e-6
_ABSOLUTE_COST_M2 = 1e-16
_STEP_M = 1e-11
_LAMBDA_MAX = 1e10
_SNAP_M = 1e-6
_MAX_REJECTED = 6


@dataclass(frozen=True)
class FitSettings:
    """Fitter settings (``fitting:`` of ``config/gaits.yaml``)."""

    length_weight: float = 0.05
    curve_points: int = 201
    max_iterations: int = 60
    neighbour_sweeps: int = 3
    multistart_count: int = 24
    seed: int = 7

    @classmethod
    def from_config(cls, section: Mapping[str, Any] | None, source: str = "gaits.yaml") -> FitSettings:
        """Build from the ``fitting:`` mapping of ``source``; unknown keys or bad values raise ConfigurationError."""
        return cls(**FIT_SETTINGS.read(section or {}, source))


#: The ``fitting:`` section of ``config/gaits.yaml`` (defaults: :class:`FitSettings`).
FIT_SETTINGS = Table("fitting", (
    Field("length_weight", float, FitSettings.length_weight, minimum=0.0, unit="1",
          description="w of paper eq. 3: cost = sum d^2 + w sum l^2"),
    Field("curve_points", int, FitSettings.curve_points, minimum=3, unit="points",
          description="samples of each target curve"),
    Field("max_iterations", int, FitSettings.max_iterations, minimum=1, unit="iterations",
          description="Levenberg-Marquardt iterations per start"),
    Field("neighbour_sweeps", int, FitSettings.neighbour_sweeps, minimum=0, unit="passes",
          description="passes that restart suspect samples from their neighbours"),
    Field("multistart_count", int, FitSettings.multistart_count, minimum=0, unit="starts",
          description="random starts per poor sample in the global fallback"),
    Field("seed", int, FitSettings.seed, minimum=0, description="seed of the fallback's random starts"),
), description="a mapping of fitter settings")


@dataclass(frozen=True)
class FitResult:
    """Fitted lengths of N shapes with their quality.

    ``lengths_m`` (N, 9); ``error_mm`` (N,) RMS distance of the backbone points to the curve;
    ``cost`` (N,) the value of F; ``poor`` (N,) error above the threshold after every retry;
    ``retried`` indices that went through the global fallback.
    """

    lengths_m: np.ndarray
    error_mm: np.ndarray
    cost: np.ndarray
    poor: np.ndarray
    retried: tuple[int, ...]


# --------------------------------------------------------------------------------------------
# Closest points on a polyline, residuals, cost
# --------------------------------------------------------------------------------------------
def _project(points, start, end):
    """Nearest point of segments [start, end] to points (all (..., 3)): (point, unit tangent, strictly inside)."""
    direction = end - start
    length2 = np.einsum("...i,...i->...", direction, direction)
    safe = np.where(length2 > 0.0, length2, 1.0)
    t = np.clip(np.einsum("...i,...i->...", points - start, direction) / safe, 0.0, 1.0)
    nearest = start + t[..., None] * direction
    tangent = direction / np.sqrt(safe)[..., None] * (length2 > 0.0)[..., None]
    return nearest, tangent, (t > 0.0) & (t < 1.0)


#: Most elements (B K M) of the point-to-vertex distances computed at once: 8e6, a few 64 MB arrays. Above it the
#: shapes go in batches: 100 000 rolling samples asked for 4.5 GiB at once and ended in a MemoryError (a review).
CLOSEST_BATCH_ELEMENTS = 8_000_000


def closest_points(points, curves):
    """Nearest points of polylines ``curves`` (B, M, 3) to ``points`` (B, K, 3).

    Returns ``(nearest (B, K, 3), unit tangent (B, K, 3), inside (B, K))``; ``inside`` is true where
    the nearest point lies strictly inside a segment (there the distance slides along the curve).
    """
    batch, per_shape = points.shape[0], points.shape[1] * curves.shape[1]
    if batch > 1 and batch * per_shape > CLOSEST_BATCH_ELEMENTS:
        step = max(1, CLOSEST_BATCH_ELEMENTS // per_shape)
        parts = [closest_points(points[i:i + step], curves[i:i + step]) for i in range(0, batch, step)]
        return tuple(np.concatenate(part, axis=0) for part in zip(*parts))
    cross = points @ np.swapaxes(curves, -1, -2)                                 # (B, K, M)
    dist2 = np.einsum("bmi,bmi->bm", curves, curves)[:, None, :] - 2.0 * cross
    index = np.argmin(dist2, axis=-1)                                            # (B, K)
    last = curves.shape[1] - 1

    def vertex(i):
        return np.take_along_axis(curves, np.clip(i, 0, last)[..., None], axis=1)

    here = vertex(index)
    near_a, tan_a, in_a = _project(points, vertex(index - 1), here)
    near_b, tan_b, in_b = _project(points, here, vertex(index + 1))
    use_b = (np.sum((points - near_b) ** 2, -1) <= np.sum((points - near_a) ** 2, -1))[..., None]
    return (np.where(use_b, near_b, near_a), np.where(use_b, tan_b, tan_a),
            np.where(use_b[..., 0], in_b, in_a))


def shape_cost(lengths_m, curves, robot: RobotDescription, length_weight: float) -> np.ndarray:
    """F(q) of paper eq. 3 (least-squares form) for lengths (B, 9) against curves (B, M, 3): (B,) in m^2."""
    points = backbone_points(lengths_m, robot=robot)
    nearest, _, _ = closest_points(points, curves)
    return np.sum((points - nearest) ** 2, axis=(-1, -2)) + length_weight * np.sum(lengths_m ** 2, axis=-1)


def fit_error_mm(lengths_m, curves, robot: RobotDescription) -> np.ndarray:
    """RMS distance (mm) of the backbone points of lengths (B, 9) to curves (B, M, 3): (B,)."""
    points = backbone_points(lengths_m, robot=robot)
    nearest, _, _ = closest_points(points, curves)
    return 1e3 * np.sqrt(np.mean(np.sum((points - nearest) ** 2, axis=-1), axis=-1))


def _residuals(q, curves, robot, root_weight, jacobian):
    """Stacked residuals r (B, 3K+9) with sum r^2 = F, and optionally dr/dq (B, 3K+9, 9)."""
    if jacobian:
        points, jac = backbone_points_and_jacobian(q, robot=robot)
    else:
        points = backbone_points(q, robot=robot)
    nearest, tangent, inside = closest_points(points, curves)
    res = np.concatenate([(points - nearest).reshape(len(q), -1), root_weight * q], axis=-1)
    if not jacobian:
        return res, None
    # Inside a segment the nearest point slides with p: d(p - c) = (I - t t^T) dp.
    tangent = tangent * inside[..., None]
    jac = jac - tangent[..., :, None] * np.einsum("bki,bkij->bkj", tangent, jac)[..., None, :]
    eye = np.broadcast_to(root_weight * np.eye(q.shape[-1]), (len(q),) + (q.shape[-1],) * 2)
    return res, np.concatenate([jac.reshape(len(q), -1, q.shape[-1]), eye], axis=1)


def _bounded_step(system, grad, q, lower, upper, free, eye):
    """Minimiser of the damped model with the lengths in ``~free`` held, and any that would cross a bound put on it.

    A plain clipped step bends the direction and is often rejected; instead the lengths that the
    free step would push past a bound are fixed on it and the rest re-solved with that fixed move.
    """
    pair = free[:, :, None] & free[:, None, :]
    fixed_move = np.where(free, 0.0, np.clip(q, lower, upper) - q)
    step = -np.linalg.solve(np.where(pair, system, eye), np.where(free, grad, 0.0)[..., None])[..., 0]
    target = q + step
    crossing = free & ((target < lower) | (target > upper))
    if not np.any(crossing):
        return np.where(free, step, fixed_move)
    still = free & ~crossing
    fixed_move = np.where(crossing, np.clip(target, lower, upper) - q, fixed_move)
    rhs = grad + np.einsum("bij,bj->bi", system, fixed_move)
    pair = still[:, :, None] & still[:, None, :]
    step = -np.linalg.solve(np.where(pair, system, eye), np.where(still, rhs, 0.0)[..., None])[..., 0]
    return np.where(still, step, fixed_move)


def levenberg_marquardt(q0, curves, robot: RobotDescription, length_weight: float, max_iterations: int = 60):
    """Minimise F from starts q0 (B, 9) against curves (B, M, 3), all at once: ``(q (B, 9), F (B,))``.

    Projected Levenberg-Marquardt with Marquardt scaling; a length at a bound whose gradient pushes
    outward is held there for the step (active set), so the bounds ``[0, max_extension_m]`` hold
    exactly and the free lengths still take full Gauss-Newton steps.
    """
    lower, upper = 0.0, robot.max_extension_m
    root_weight = np.sqrt(length_weight)
    q = np.clip(np.array(q0, dtype=np.float64), lower, upper)
    res, jac = _residuals(q, curves, robot, root_weight, True)
    cost = np.sum(res ** 2, axis=-1)
    damping = np.full(len(q), 1e-2)
    growth = np.full(len(q), 2.0)
    rejected = np.zeros(len(q), dtype=np.intp)
    active = np.ones(len(q), dtype=bool)
    eye = np.eye(q.shape[-1])
    for _ in range(max_iterations):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        j_a, r_a, q_a, cost_a = jac[idx], res[idx], q[idx], cost[idx]
        grad = np.einsum("bri,br->bi", j_a, r_a)                                # half the gradient of F
        hess = np.einsum("bri,brj->bij", j_a, j_a)
        # Lengths within _SNAP_M of a bound whose gradient pushes outward are held on the bound.
        at_lower, at_upper = (q_a <= lower + _SNAP_M) & (grad > 0.0), (q_a >= upper - _SNAP_M) & (grad < 0.0)
        free = ~(at_lower | at_upper)
        diag = np.einsum("bii->bi", hess)
        # Marquardt scaling, floored so that no direction (e.g. extension along the curve) is undamped.
        scale = diag + 1e-3 * diag.mean(axis=-1, keepdims=True)
        damped = hess + damping[idx, None, None] * (eye * scale[:, None, :])
        step = _bounded_step(damped, grad, q_a, lower, upper, free, eye)
        # Newton decrement of the undamped model: the decrease still available near this point.
        free_grad = np.where(free, grad, 0.0)[..., None]
        newton = np.where(free[:, :, None] & free[:, None, :], hess + 1e-9 * (eye * scale[:, None, :]), eye)
        available = np.einsum("bi,bi->b", free_grad[..., 0], np.linalg.solve(newton, free_grad)[..., 0])
        q_new = np.clip(q_a + step, lower, upper)
        step = q_new - q_a
        predicted = -2.0 * np.einsum("bi,bi->b", grad, step) - np.einsum("bi,bij,bj->b", step, hess, step)
        res_new, _ = _residuals(q_new, curves[idx], robot, root_weight, False)
        cost_new = np.sum(res_new ** 2, axis=-1)
        decrease = cost_a - cost_new
        better = decrease > 0.0
        if np.any(better):
            good = idx[better]
            res_good, jac_good = _residuals(q_new[better], curves[good], robot, root_weight, True)
            q[good], res[good], jac[good], cost[good] = q_new[better], res_good, jac_good, cost_new[better]
        # Nielsen's damping update from the gain ratio actual / predicted decrease.
        gain = decrease / np.maximum(predicted, 1e-300)
        shrink = np.maximum(1.0 / 3.0, 1.0 - (2.0 * np.clip(gain, 0.0, 1.0) - 1.0) ** 3)
        damping[idx] = np.where(better, np.maximum(damping[idx] * shrink, 1e-12), damping[idx] * growth[idx])
        growth[idx] = np.where(better, 2.0, growth[idx] * 2.0)
        rejected[idx] = np.where(better, 0, rejected[idx] + 1)
        tolerance = _RELATIVE_DECREASE * cost_a + _ABSOLUTE_COST_M2
        done = (available <= tolerance) | (better & (decrease <= tolerance))
        done |= np.max(np.abs(step), axis=-1) < _STEP_M
        done |= (damping[idx] > _LAMBDA_MAX) | (rejected[idx] >= _MAX_REJECTED)
        active[idx[done]] = False
    return q, cost


# --------------------------------------------------------------------------------------------
# Starts
# --------------------------------------------------------------------------------------------
def _curve_at(curves, s_m, arc_m):
    """Points of curves (B, M, 3) sampled on the uniform grid s_m, at arc lengths arc_m (B,), clamped."""
    step = s_m[1] - s_m[0]
    position = np.clip(arc_m / step, 0.0, len(s_m) - 1.0)
    i = np.minimum(np.floor(position).astype(np.intp), len(s_m) - 2)
    frac = (position - i)[:, None]
    rows = np.arange(len(curves))
    return curves[rows, i] * (1.0 - frac) + curves[rows, i + 1] * frac


def geometric_guess(curves, s_m, robot: RobotDescription) -> np.ndarray:
    """A start for every shape (B, 9): each module bent, as one arc, toward the curve point one module on.

    Module by module: the chord from the module's base to the curve point one arc length further, in
    the module's base frame, gives the bending plane (its direction) and angle (twice its angle to +Z);
    the least-extension lengths of that bend (docs/conventions.md) set the arc length; repeated 3 times.
    """
    count, n_act = len(curves), robot.actuators_per_module
    q = np.zeros((count, robot.joint_count))
    start_m = np.zeros(count)
    for module in range(robot.module_count):
        frame = body_transforms(q, np.array([float(module)]), robot=robot)[:, 0]
        rot, origin = frame[:, :3, :3], frame[:, :3, 3]
        arc_m = np.full(count, robot.unactuated_length_m)
        for _ in range(3):
            chord = np.einsum("bji,bj->bi", rot, _curve_at(curves, s_m, start_m + arc_m) - origin)
            bend = 2.0 * np.arctan2(np.hypot(chord[:, 0], chord[:, 1]), chord[:, 2])
            plane = np.arctan2(chord[:, 1], chord[:, 0])
            lengths = np.clip(bend_to_lengths(bend, plane, robot=robot), 0.0, robot.max_extension_m)
            arc_m = robot.unactuated_length_m + lengths.mean(axis=-1)
        q[:, module * n_act:(module + 1) * n_act] = lengths
        start_m = start_m + arc_m
    return q


def _best_of(q, cost, candidates, candidate_cost, owners):
    """Keep, per shape, the cheapest of its current solution and its candidates (owners: shape index)."""
    order = np.argsort(candidate_cost, kind="stable")
    best = order[np.unique(owners[order], return_index=True)[1]]
    who = owners[best]
    improve = candidate_cost[best] < cost[who] * (1.0 - 1e-9)
    q, cost = q.copy(), cost.copy()
    q[who[improve]] = candidates[best[improve]]
    cost[who[improve]] = candidate_cost[best[improve]]
    return q, cost, who[improve]


def _suspects(q, cost, periodic):
    """Pairs (shape, neighbour) worth a warm restart: a jump in joint space or a cost bump.

    A pair of neighbours whose step is more than 4x the median step (and over 1 mm) may sit in
    different basins: each is restarted from the other. A shape costlier than both neighbours by 2 %
    is restarted from both.

    """
    count = len(q)
    shapes = np.arange(count)
    nxt = (shapes + 1) % count if periodic else np.minimum(shapes + 1, count - 1)
    prev = (shapes - 1) % count if periodic else np.maximum(shapes - 1, 0)
    step = np.max(np.abs(q[nxt] - q), axis=-1)
    jump = (step > 4.0 * np.median(step)) & (step > 1e-3)
    bump = cost > 1.02 * np.maximum(cost[prev], cost[nxt]) + _ABSOLUTE_COST_M2
    owners = np.concatenate([shapes[jump], nxt[jump], shapes[bump], shapes[bump]])
    sources = np.concatenate([nxt[jump], shapes[jump], prev[bump], nxt[bump]])
    keep = owners != sources
    return owners[keep], sources[keep]


def _neighbour_sweeps(q, cost, curves, robot, settings, periodic=True):
    """Restart suspect shapes from their neighbours' solutions (warm starts along the cycle) while it helps."""
    if len(q) < 3:
        return q, cost
    for _ in range(settings.neighbour_sweeps):
        owners, sources = _suspects(q, cost, periodic)
        if owners.size == 0:
            break
        q_c, cost_c = levenberg_marquardt(q[sources], curves[owners], robot, settings.length_weight,
                                          settings.max_iterations)
        q, cost, improved = _best_of(q, cost, q_c, cost_c, owners)
        if improved.size == 0:
            break
    return q, cost


def global_fallback(q, cost, curves, robot: RobotDescription, settings: FitSettings, which):
    """Multi-start for the shapes ``which``: random starts in the bounds plus the straight body, batched."""
    which = np.asarray(which, dtype=np.intp)
    if which.size == 0:
        return q, cost
    rng = np.random.default_rng(settings.seed)
    starts_per = max(settings.multistart_count, 1)
    starts = rng.uniform(0.0, robot.max_extension_m, size=(which.size, starts_per, robot.joint_count))
    starts[:, 0] = 0.0
    owners = np.repeat(which, starts_per)
    q_c, cost_c = levenberg_marquardt(starts.reshape(-1, robot.joint_count), curves[owners], robot,
                                      settings.length_weight, settings.max_iterations)
    q, cost, _ = _best_of(q, cost, q_c, cost_c, owners)
    return q, cost


def fit_shapes(curves, s_m, robot: RobotDescription, settings: FitSettings | None = None,
               poor_fit_mm: float = 1.0, periodic: bool = True) -> FitResult:
    """Fit the body to N target curves (N, M, 3) on the arc-length grid s_m (M,) (paper eq. 3).

    Geometric start, batched Levenberg-Marquardt, neighbour warm-start sweeps (around the cycle if
    ``periodic``), then a global multi-start for every shape whose RMS error exceeds ``poor_fit_mm``;
    shapes still above it are flagged in :attr:`FitResult.poor`.
    """
    settings = settings or FitSettings()
    curves = np.asarray(curves, dtype=np.float64)
    q, cost = levenberg_marquardt(geometric_guess(curves, s_m, robot), curves, robot, settings.length_weight,
                                  settings.max_iterations)
    q, cost = _neighbour_sweeps(q, cost, curves, robot, settings, periodic)
    error = fit_error_mm(q, curves, robot)
    retried = np.flatnonzero(error > poor_fit_mm)
    if retried.size:
        q, cost = global_fallback(q, cost, curves, robot, settings, retried)
        q, cost = _neighbour_sweeps(q, cost, curves, robot, settings, periodic)
        error = fit_error_mm(q, curves, robot)
    return FitResult(lengths_m=q, error_mm=error, cost=cost, poor=error > poor_fit_mm,
                     retried=tuple(int(i) for i in retried))
