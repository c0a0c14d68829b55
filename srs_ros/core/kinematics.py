"""Floating-base kinematics of the SRS (paper eq. 1-2; modal kinematics of Godage et al. 2015).

Every function is batched: ``q`` has shape ``(..., 9)`` (actuator length changes in metres, order
``m1_pma1 ... m3_pma3``), ``xi`` is a 1-D array of body coordinates in ``[0, 3]`` and the optional
floating base ``base`` (``q_b = [x, y, z, roll, pitch, yaw]``, metres and radians) has shape
``(..., 6)``. Leading dimensions broadcast. Module frames and conventions: docs/conventions.md.

A body coordinate ``xi`` in ``[i, i+1)`` lies on module ``i+1`` (0-based ``i``), after the mounting
frame ``[Rot_z(sigma), (0, 0, delta)]`` that joins it to module ``i``; ``xi = 3`` is the tip.

Worked example (the sanity values of docs/conventions.md)::

    >>> import numpy as np
    >>> backbone_points(np.zeros(9))[-1].round(6).tolist()      # the tip of a straight robot
    [0.0, 0.0, 0.45]
"""

from __future__ import annotations

import numpy as np

from srs_ros.core.errors import InvalidInputError
from srs_ros.core.robot import RobotDescription, default_robot
from srs_ros.core.validation import finite_array

# Below this squared bending angle (rad^2) f and g are evaluated by their Taylor series: the
# truncation error there is below 1e-18, and the closed forms would lose digits to cancellation.
_SERIES_LIMIT_RAD2 = 1e-2


# --------------------------------------------------------------------------------------------
# The scalar shape functions f(t) = (1 - cos t) / t^2 and g(t) = sin t / t, as functions of s = t^2
# --------------------------------------------------------------------------------------------
def shape_functions(s: np.ndarray, derivatives: bool = False):
    """Return ``f(s), g(s)`` (and ``df/ds, dg/ds``) for ``s = t^2``, smooth through ``s = 0``.

    ``f = (1 - cos t)/t^2`` and ``g = sin t / t`` are entire functions of ``s``; near 0 they are
    evaluated by their series, so a straight module is exact and its derivatives are smooth.
    """
    s = np.asarray(s, dtype=np.float64)
    small = s < _SERIES_LIMIT_RAD2
    any_small = bool(small.any())
    s_big = np.where(small, 1.0, s) if any_small else s
    t = np.sqrt(s_big)
    cos_t, sin_t = np.cos(t), np.sin(t)
    f_big = (1.0 - cos_t) / s_big
    g_big = sin_t / t
    # Series: f = 1/2 - s/24 + s^2/720 - s^3/40320 + s^4/3628800, g = 1 - s/6 + s^2/120 - s^3/5040 + s^4/362880
    f_small = 0.5 + s * (-1.0 / 24 + s * (1.0 / 720 + s * (-1.0 / 40320 + s / 3628800)))
    g_small = 1.0 + s * (-1.0 / 6 + s * (1.0 / 120 + s * (-1.0 / 5040 + s / 362880)))
    f = np.where(small, f_small, f_big) if any_small else f_big
    g = np.where(small, g_small, g_big) if any_small else g_big
    if not derivatives:
        return f, g
    # df/ds = (g/2 - f)/s ... written for large s; series for small s.
    df_big = (0.5 * g_big - f_big) / s_big
    dg_big = (0.5 * cos_t - 0.5 * g_big) / s_big
    df_small = -1.0 / 24 + s * (2.0 / 720 + s * (-3.0 / 40320 + s * 4.0 / 3628800))
    dg_small = -1.0 / 6 + s * (2.0 / 120 + s * (-3.0 / 5040 + s * 4.0 / 362880))
    return f, g, np.where(small, df_small, df_big), np.where(small, dg_small, dg_big)


# --------------------------------------------------------------------------------------------
# Lengths <-> bend (bending angle, bending plane, arc length) of one module
# --------------------------------------------------------------------------------------------
def _bend_matrix(robot: RobotDescription) -> np.ndarray:
    """(2, n) matrix B with u = B @ l: u = -(2/(3r)) sum_j l_j (cos theta_j, sin theta_j)."""
    theta = robot.actuator_angles_rad
    n = robot.actuators_per_module
    return -(2.0 / (n * robot.actuator_radius_m)) * np.stack([np.cos(theta), np.sin(theta)])


def bending_vectors(module_lengths_m, robot: RobotDescription | None = None) -> np.ndarray:
    """Bending vector ``u = (ux, uy)`` (rad) of modules with lengths ``(..., 3)``; ``|u|`` is the bending angle."""
    robot = robot or default_robot()
    lengths = finite_array("module_lengths_m", module_lengths_m, (robot.actuators_per_module,), "m")
    return lengths @ _bend_matrix(robot).T


def lengths_to_bend(module_lengths_m, robot: RobotDescription | None = None):
    """Convert actuator length changes ``(..., 3)`` (m) to ``(bend_angle_rad, plane_angle_rad, arc_length_m)``.

    ``bend_angle = |u|``, ``plane = atan2(uy, ux)`` (the direction the module bends toward, away
    from its longest actuator), ``arc_length = L0 + mean(l)``.
    Example: ``lengths_to_bend([0.03, 0, 0])`` -> ``(1.6, pi, 0.16)``.
    """
    robot = robot or default_robot()
    lengths = finite_array("module_lengths_m", module_lengths_m, (robot.actuators_per_module,), "m")
    u = lengths @ _bend_matrix(robot).T
    bend = np.hypot(u[..., 0], u[..., 1])
    plane = np.arctan2(u[..., 1], u[..., 0])
    arc = robot.unactuated_length_m + lengths.mean(axis=-1)
    return bend, plane, arc


def bend_to_lengths(bend_angle_rad, plane_angle_rad, arc_length_m=None,
                    robot: RobotDescription | None = None) -> np.ndarray:
    """Actuator length changes ``(..., 3)`` (m) that bend a module by ``bend_angle_rad`` toward ``plane_angle_rad``.

    ``l_j = c - r * phi * cos(theta_j - plane)``; the common part ``c`` makes the arc length
    ``arc_length_m`` if given, else the smallest ``l_j`` zero (the least-extension solution).
    """
    robot = robot or default_robot()
    phi = finite_array("bend_angle_rad", bend_angle_rad, (), "rad")
    plane = finite_array("plane_angle_rad", plane_angle_rad, (), "rad")
    varying = -robot.actuator_radius_m * phi[..., None] * np.cos(
        robot.actuator_angles_rad - plane[..., None])
    if arc_length_m is None:
        common = -varying.min(axis=-1, keepdims=True)
    else:
        arc = finite_array("arc_length_m", arc_length_m, (), "m")
        common = (arc - robot.unactuated_length_m)[..., None]
    return common + varying


# --------------------------------------------------------------------------------------------
# One module: pose at xi in [0, 1] and its partial derivatives
# --------------------------------------------------------------------------------------------
def _module_position(ax, ay, arc, xi):
    """Position only (..., 3) of a module point: ``p = xi*L*(ax f, ay f, g)`` (the fast path)."""
    f, g = shape_functions(ax * ax + ay * ay)
    scale = xi * arc
    return np.stack([scale * ax * f, scale * ay * f, scale * g], axis=-1)


def _module_pose(ax, ay, arc, xi, derivatives=False):
    """Rotation (..., 3, 3) and position (..., 3) of a module point, given a = xi*u, L, xi.

    ``p = xi*L*(ax f, ay f, g)``, ``R = I + g A + f A^2`` with ``A = skew(-ay, ax, 0)`` (Rodrigues
    about ``(-ay, ax, 0)/t`` by ``t = |a|``, written without dividing by t). With ``derivatives``
    also returns d(R, p)/d(ax, ay) (stacked on a new axis -1 of length 2) and dp/dL.
    """
    s = ax * ax + ay * ay
    if derivatives:
        f, g, df, dg = shape_functions(s, derivatives=True)
    else:
        f, g = shape_functions(s)
    rot = np.empty(ax.shape + (3, 3))
    rot[..., 0, 0] = 1.0 - f * ax * ax
    rot[..., 0, 1] = -f * ax * ay
    rot[..., 0, 2] = g * ax
    rot[..., 1, 0] = rot[..., 0, 1]
    rot[..., 1, 1] = 1.0 - f * ay * ay
    rot[..., 1, 2] = g * ay
    rot[..., 2, 0] = -rot[..., 0, 2]
    rot[..., 2, 1] = -rot[..., 1, 2]
    rot[..., 2, 2] = 1.0 - f * s
    scale = xi * arc
    pos = np.stack([scale * ax * f, scale * ay * f, scale * g], axis=-1)
    if not derivatives:
        return rot, pos
    d_rot = np.empty(ax.shape + (3, 3, 2))
    d_pos = np.empty(ax.shape + (3, 2))
    for k, (a_k, a_o) in enumerate(((ax, ay), (ay, ax))):
        # d/da_k of f and g through s = ax^2 + ay^2
        df_k, dg_k = 2.0 * a_k * df, 2.0 * a_k * dg
        # rows/cols for the "own" (k) and "other" (o) coordinate
        kk, oo = (0, 1) if k == 0 else (1, 0)
        d_rot[..., kk, kk, k] = -(df_k * a_k * a_k + 2.0 * f * a_k)
        d_rot[..., oo, oo, k] = -df_k * a_o * a_o
        d_rot[..., kk, oo, k] = -(df_k * a_k * a_o + f * a_o)
        d_rot[..., oo, kk, k] = d_rot[..., kk, oo, k]
        d_rot[..., kk, 2, k] = dg_k * a_k + g
        d_rot[..., oo, 2, k] = dg_k * a_o
        d_rot[..., 2, kk, k] = -d_rot[..., kk, 2, k]
        d_rot[..., 2, oo, k] = -d_rot[..., oo, 2, k]
        d_rot[..., 2, 2, k] = -(df_k * s + 2.0 * f * a_k)
        d_pos[..., kk, k] = scale * (f + a_k * df_k)
        d_pos[..., oo, k] = scale * a_o * df_k
        d_pos[..., 2, k] = scale * dg_k
    d_pos_d_arc = np.stack([xi * ax * f, xi * ay * f, xi * g], axis=-1)
    return rot, pos, d_rot, d_pos, d_pos_d_arc


def _homogeneous(rot: np.ndarray, pos: np.ndarray) -> np.ndarray:
    out = np.zeros(rot.shape[:-2] + (4, 4))
    out[..., :3, :3] = rot
    out[..., :3, 3] = pos
    out[..., 3, 3] = 1.0
    return out


def module_transforms(module_lengths_m, xi, robot: RobotDescription | None = None) -> np.ndarray:
    """HTM ``T_i(q_i, xi)`` (..., 4, 4) of one module (paper eq. 1, without the mounting frame).

    ``module_lengths_m`` (..., 3) broadcasts against ``xi`` (...,) in [0, 1].
    """
    robot = robot or default_robot()
    lengths = finite_array("module_lengths_m", module_lengths_m, (robot.actuators_per_module,), "m")
    xi = finite_array("xi", xi, (), "")
    u = lengths @ _bend_matrix(robot).T
    arc = robot.unactuated_length_m + lengths.mean(axis=-1)
    return _homogeneous(*_module_pose(xi * u[..., 0], xi * u[..., 1], arc, xi))


# --------------------------------------------------------------------------------------------
# Whole body
# --------------------------------------------------------------------------------------------
def base_transform(base) -> np.ndarray:
    """``T_b = Trans(x, y, z) Rot_z(yaw) Rot_y(pitch) Rot_x(roll)`` (..., 4, 4) from ``q_b`` (..., 6)."""
    qb = finite_array("base", base, (6,), "m and rad")
    cr, sr = np.cos(qb[..., 3]), np.sin(qb[..., 3])
    cp, sp = np.cos(qb[..., 4]), np.sin(qb[..., 4])
    cy, sy = np.cos(qb[..., 5]), np.sin(qb[..., 5])
    rot = np.empty(qb.shape[:-1] + (3, 3))
    rot[..., 0, 0] = cy * cp
    rot[..., 0, 1] = cy * sp * sr - sy * cr
    rot[..., 0, 2] = cy * sp * cr + sy * sr
    rot[..., 1, 0] = sy * cp
    rot[..., 1, 1] = sy * sp * sr + cy * cr
    rot[..., 1, 2] = sy * sp * cr - cy * sr
    rot[..., 2, 0] = -sp
    rot[..., 2, 1] = cp * sr
    rot[..., 2, 2] = cp * cr
    return _homogeneous(rot, qb[..., :3])


def _mounting_transform(robot: RobotDescription) -> np.ndarray:
    c, s = np.cos(robot.module_twist_rad), np.sin(robot.module_twist_rad)
    mount = np.eye(4)
    mount[:2, :2] = [[c, -s], [s, c]]
    mount[2, 3] = robot.mounting_offset_m
    return mount


def _check_xi(xi, robot: RobotDescription) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Validate body coordinates; return (xi, module index, local coordinate in [0, 1])."""
    xi = robot.backbone_xi if xi is None else finite_array("xi", xi, (None,), "", min_ndim=1)
    if xi.ndim != 1:
        raise InvalidInputError(f"xi: expected a 1-D array of body coordinates, got shape {xi.shape}.")
    top = robot.body_length_xi
    if np.any((xi < 0.0) | (xi > top)):
        raise InvalidInputError(
            f"xi: body coordinates must lie in [0, {top:g}], got min {xi.min():g}, max {xi.max():g}.")
    module = np.minimum(np.floor(xi).astype(np.intp), robot.module_count - 1)
    return xi, module, xi - module


class _BodyModel:
    """Shared evaluation of the body: per-module bending, prefix transforms and local poses."""

    def __init__(self, q, xi, robot: RobotDescription | None, base, derivatives: bool):
        self.robot = robot = robot or default_robot()
        n_act, n_mod = robot.actuators_per_module, robot.module_count
        self.q = finite_array("q", q, (robot.joint_count,), "m")
        self.xi, self.module, self.local = _check_xi(xi, robot)
        lengths = self.q.reshape(self.q.shape[:-1] + (n_mod, n_act))          # (..., M, 3)
        self.bend_matrix = _bend_matrix(robot)                                # (2, 3)
        u = lengths @ self.bend_matrix.T                                       # (..., M, 2)
        arc = robot.unactuated_length_m + lengths.mean(axis=-1)                # (..., M)
        ones = np.ones(())
        # Module tips (xi = 1) build the prefix transforms P_m (base frame of module m).
        tip = _module_pose(u[..., 0], u[..., 1], arc, ones, derivatives)
        self.tip = _homogeneous(tip[0], tip[1])                                # (..., M, 4, 4)
        self.tip_parts = tip
        mount = _mounting_transform(robot)
        lead = np.broadcast_shapes(self.q.shape[:-1], () if base is None else np.shape(base)[:-1])
        first = np.broadcast_to(np.eye(4) if base is None else base_transform(base), lead + (4, 4))
        prefix = [first]
        for m in range(n_mod - 1):
            prefix.append(prefix[-1] @ self.tip[..., m, :, :] @ mount)
        self.prefix = np.stack(prefix, axis=-3)                                # (..., M, 4, 4)
        self.u, self.arc, self.derivatives = u, arc, derivatives
        self._point_parts = None

    @property
    def point_parts(self):
        """Local pose (and derivatives) of every body point on its own module."""
        if self._point_parts is None:
            local, u_pt = self.local, self.u[..., self.module, :]              # (..., K, 2)
            self._point_parts = _module_pose(local * u_pt[..., 0], local * u_pt[..., 1],
                                             self.arc[..., self.module], local, self.derivatives)
        return self._point_parts

    def transforms(self) -> np.ndarray:
        local = _homogeneous(self.point_parts[0], self.point_parts[1])
        return self.prefix[..., self.module, :, :] @ local

    def _module_selections(self):
        """(module, selection of body points on it): a slice when contiguous (the usual sorted xi)."""
        for m in range(self.robot.module_count):
            idx = np.flatnonzero(self.module == m)
            if idx.size:
                contiguous = idx[-1] - idx[0] + 1 == idx.size
                yield m, slice(idx[0], idx[-1] + 1) if contiguous else idx

    def points(self) -> np.ndarray:
        lead = np.broadcast_shapes(self.u.shape[:-2], self.prefix.shape[:-3])
        out = np.empty(lead + (self.xi.size, 3))
        # Per module: local positions of its points, then one batched matmul with its prefix.
        for m, sel in self._module_selections():
            local = self.local[sel]
            a = local[:, None] * self.u[..., m, None, :]                       # (..., K_m, 2)
            pos = _module_position(a[..., 0], a[..., 1], self.arc[..., m, None], local)
            rot, trans = self.prefix[..., m, :3, :3], self.prefix[..., m, :3, 3]
            out[..., sel, :] = pos @ np.swapaxes(rot, -1, -2) + trans[..., None, :]
        return out

    def jacobian(self) -> np.ndarray:
        """d(points)/dq, (..., K, 3, 9)."""
        robot = self.robot
        n_act, n_mod = robot.actuators_per_module, robot.module_count
        # d(ax, ay)/dl_j = xi * B[:, j]; dL/dl_j = 1/n
        inv_n = 1.0 / n_act
        points = self.points()                                                 # (..., K, 3)
        jac = np.zeros(points.shape + (robot.joint_count,))
        # (1) own module: dp_world = R_prefix @ (dp/da . xi B + dp/dL / n)
        _, _, _, d_pos, d_pos_arc = self.point_parts                           # (...,K,3,2), (...,K,3)
        local = self.local[:, None, None]
        d_local = local * (d_pos @ self.bend_matrix) + d_pos_arc[..., None] * inv_n   # (..., K, 3, 3)
        prefix_rot = self.prefix[..., self.module, :3, :3]                     # (..., K, 3, 3)
        own = prefix_rot @ d_local                                             # (..., K, 3, 3)
        cols = self.module[:, None] * n_act + np.arange(n_act)                 # (K, 3)
        k_idx = np.arange(self.xi.size)[:, None]
        jac_t = np.moveaxis(jac, -1, -2)                                       # (..., K, 9, 3) view
        jac_t[..., k_idx, cols, :] = np.moveaxis(own, -1, -2)
        # (2) upstream modules m < module(k): dx = P_m (dT_m T_m^-1) P_m^-1 x, a rigid-motion twist.
        rot_tip, pos_tip, d_rot_tip, d_pos_tip, d_pos_arc_tip = self.tip_parts
        for m in range(n_mod - 1):
            after = self.module > m
            if not np.any(after):
                continue
            d_rot = d_rot_tip[..., m, :, :, :] @ self.bend_matrix              # (..., 3, 3, 3): dR/dl_j
            d_pos = d_pos_tip[..., m, :, :] @ self.bend_matrix + d_pos_arc_tip[..., m, :, None] * inv_n
            rot_m, pos_m = rot_tip[..., m, :, :], pos_tip[..., m, :]
            p_rot, p_pos = self.prefix[..., m, :3, :3], self.prefix[..., m, :3, 3]
            # In the module-m base frame, a point y moves by dR R^T (y - p) + dp.
            x_local = np.einsum("...ji,...kj->...ki", p_rot, points[..., after, :] - p_pos[..., None, :])
            y = x_local - pos_m[..., None, :]                                  # (..., Ka, 3)
            omega = np.einsum("...abj,...cb->...acj", d_rot, rot_m)             # dR R^T per j: (..., 3, 3, 3)
            moved = np.einsum("...acj,...kc->...kaj", omega, y) + d_pos[..., None, :, :]
            jac[..., after, :, m * n_act:(m + 1) * n_act] = p_rot[..., None, :, :] @ moved
        return jac


def body_transforms(q, xi, robot: RobotDescription | None = None, base=None) -> np.ndarray:
    """HTMs ``T(q_b, q, xi)`` of body points (paper eq. 2): shape ``(..., len(xi), 4, 4)``.

    ``q`` (..., 9) in metres, ``xi`` 1-D in [0, 3], ``base`` (..., 6) or None for the identity.
    """
    return _BodyModel(q, xi, robot, base, derivatives=False).transforms()


def backbone_points(q, xi=None, robot: RobotDescription | None = None, base=None) -> np.ndarray:
    """Backbone positions ``(..., K, 3)`` in metres; by default the 31 points xi = 0, 0.1, ..., 3."""
    return _BodyModel(q, xi, robot, base, derivatives=False).points()


def backbone_jacobian(q, xi=None, robot: RobotDescription | None = None, base=None) -> np.ndarray:
    """Exact Jacobian ``d p_k / d q`` of the backbone points: shape ``(..., K, 3, 9)`` (m per m)."""
    return _BodyModel(q, xi, robot, base, derivatives=True).jacobian()


def backbone_points_and_jacobian(q, xi=None, robot: RobotDescription | None = None, base=None):
    """Both backbone points ``(..., K, 3)`` and their Jacobian ``(..., K, 3, 9)`` in one evaluation."""
    model = _BodyModel(q, xi, robot, base, derivatives=True)
    return model.points(), model.jacobian()
