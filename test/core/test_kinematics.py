"""Kinematics (paper eq. 1-2): the sanity table of docs/conventions.md, exact Jacobian, properties, bad input."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from srs_ros.core.errors import InvalidInputError
from srs_ros.core.kinematics import (
    backbone_jacobian,
    backbone_points,
    backbone_points_and_jacobian,
    base_transform,
    bend_to_lengths,
    body_transforms,
    lengths_to_bend,
    module_transforms,
    shape_functions,
)
from srs_ros.core.robot import default_robot

ROBOT = default_robot()
lengths = st.floats(0.0, ROBOT.max_extension_m, allow_nan=False)
q_arrays = arrays(np.float64, 9, elements=lengths)
base_arrays = arrays(np.float64, 6, elements=st.floats(-3.0, 3.0, allow_nan=False))


def _fd_jacobian(q, base=None, eps=1e-7):
    cols = []
    for j in range(9):
        dq = np.zeros(9)
        dq[j] = eps
        cols.append((backbone_points(q + dq, base=base) - backbone_points(q - dq, base=base)) / (2 * eps))
    return np.stack(cols, axis=-1)


def test_straight_robot_tip():
    assert backbone_points(np.zeros(9))[-1] == pytest.approx([0.0, 0.0, 0.45], abs=1e-15)
    points = backbone_points(np.zeros(9))
    assert points.shape == (31, 3)
    assert points[:, 2] == pytest.approx(np.linspace(0, 0.45, 31))


@pytest.mark.parametrize(
    ("lengths_m", "arc_m", "bend_rad", "tip_m"),
    [
        ((0.02, 0.02, 0.02), 0.17, 0.0, (0, 0, 0.17)),
        ((0.03, 0, 0), 0.16, 1.6, (-0.102920, 0, 0.099957)),
        ((0, 0.03, 0), 0.16, 1.6, (0.051460, -0.089131, 0.099957)),
        ((0.065, 0.065, 0), 0.193333, 3.466667, (-0.054309, -0.094066, -0.017812)),
    ],
)
def test_conventions_sanity_table(lengths_m, arc_m, bend_rad, tip_m):
    bend, _, arc = lengths_to_bend(np.array(lengths_m))
    assert arc == pytest.approx(arc_m, abs=1e-6)
    assert bend == pytest.approx(bend_rad, abs=1e-6)
    tip = module_transforms(np.array(lengths_m), 1.0)[:3, 3]
    assert tip == pytest.approx(tip_m, abs=1e-6)
    # The whole body with only module 1 actuated: point xi = 1 is module 1's tip.
    q = np.zeros(9)
    q[:3] = lengths_m
    assert backbone_points(q, xi=[1.0])[0] == pytest.approx(tip_m, abs=1e-6)


def test_module_bends_away_from_longest_actuator():
    tip = module_transforms(np.array([0.03, 0.0, 0.0]), 1.0)[:3, 3]
    assert tip[0] < 0  # actuator 1 sits on +X: the module bends toward -X


def test_mounting_frame_twists_the_next_module():
    q = np.zeros(9)
    q[3] = 0.03  # module 2, actuator 1: bends toward -X rotated by sigma
    tip = backbone_points(q)[-1]
    direction = math.atan2(tip[1], tip[0])
    assert direction == pytest.approx(math.pi + ROBOT.module_twist_rad - 2 * math.pi, abs=1e-9)


def test_shape_functions_series_matches_closed_form():
    # Closed forms are accurate away from 0 (near 0 they cancel: that is why the series exists).
    s = np.array([1e-3, 9.99e-3, 1.001e-2, 0.5, 4.0])
    f, g, df, dg = shape_functions(s, derivatives=True)
    t = np.sqrt(s)
    assert f == pytest.approx((1 - np.cos(t)) / s, rel=1e-12)
    assert g == pytest.approx(np.sin(t) / t, rel=1e-12)
    h = 1e-7
    f2, g2 = shape_functions(s + h)
    f1, g1 = shape_functions(s - h)
    assert df == pytest.approx((f2 - f1) / (2 * h), rel=1e-5, abs=1e-9)
    assert dg == pytest.approx((g2 - g1) / (2 * h), rel=1e-5, abs=1e-9)


def test_jacobian_matches_finite_differences_with_base():
    rng = np.random.default_rng(1)
    q = rng.uniform(0, ROBOT.max_extension_m, (4, 9))
    base = rng.uniform(-1, 1, (4, 6))
    assert backbone_jacobian(q, base=base) == pytest.approx(_fd_jacobian(q, base), abs=1e-7)


def test_jacobian_smooth_through_straight_configuration():
    for q in (np.zeros(9), np.full(9, 0.02), np.r_[1e-9, 0, 0, 0, 2e-9, 0, 0, 0, 0]):
        assert backbone_jacobian(q) == pytest.approx(_fd_jacobian(q), abs=1e-7)
    points, jac = backbone_points_and_jacobian(np.zeros(9))
    assert np.all(np.isfinite(jac)) and points[-1] == pytest.approx([0, 0, 0.45])


def test_base_transform_is_ros_rpy():
    roll, pitch, yaw = 0.3, -0.2, 1.1
    rx = np.array([[1, 0, 0], [0, math.cos(roll), -math.sin(roll)], [0, math.sin(roll), math.cos(roll)]])
    ry = np.array([[math.cos(pitch), 0, math.sin(pitch)], [0, 1, 0], [-math.sin(pitch), 0, math.cos(pitch)]])
    rz = np.array([[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0], [0, 0, 1]])
    transform = base_transform([1, 2, 3, roll, pitch, yaw])
    assert transform[:3, :3] == pytest.approx(rz @ ry @ rx)
    assert transform[:3, 3] == pytest.approx([1, 2, 3])
    q = np.full(9, 0.01)
    moved = backbone_points(q, base=[1, 2, 3, roll, pitch, yaw])
    assert moved == pytest.approx(backbone_points(q) @ (rz @ ry @ rx).T + [1, 2, 3])


@settings(max_examples=60, deadline=None)
@given(q=q_arrays, base=base_arrays)
def test_rotations_are_orthonormal_and_positions_agree(q, base):
    transforms = body_transforms(q, ROBOT.backbone_xi, base=base)
    rot = transforms[..., :3, :3]
    assert np.abs(rot @ np.swapaxes(rot, -1, -2) - np.eye(3)).max() < 1e-12
    assert np.linalg.det(rot) == pytest.approx(np.ones(31), abs=1e-12)
    assert transforms[..., :3, 3] == pytest.approx(backbone_points(q, base=base), abs=1e-14)


@settings(max_examples=60, deadline=None)
@given(q=q_arrays)
def test_arc_length_of_each_module(q):
    xi = np.linspace(0, 3, 3001)
    points = backbone_points(q, xi=xi)
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    for m in range(3):
        expected = ROBOT.unactuated_length_m + q[3 * m:3 * m + 3].mean()
        assert steps[1000 * m:1000 * (m + 1)].sum() == pytest.approx(expected, rel=1e-6)


@settings(max_examples=60, deadline=None)
@given(q=q_arrays, tiny=st.floats(-1e-7, 1e-7))
def test_continuity_through_straight_configurations(q, tiny):
    straight = np.repeat(q.reshape(3, 3).mean(axis=1), 3)  # equal lengths per module: straight modules
    bend = tiny * np.array([1.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0])  # start bending every module
    # Lipschitz bounds: |dp/dq| < 50 and |d2p/dq2| < 1e4 on this robot (L / r^2 scale).
    assert np.abs(backbone_points(straight + bend) - backbone_points(straight)).max() <= 50 * abs(tiny) + 1e-15
    assert np.abs(backbone_jacobian(straight + bend) - backbone_jacobian(straight)).max() <= 1e4 * abs(tiny) + 1e-12


@settings(max_examples=30, deadline=None)
@given(batch=arrays(np.float64, (5, 9), elements=lengths))
def test_batch_equals_one_at_a_time(batch):
    points, jac = backbone_points_and_jacobian(batch)
    for i in range(5):
        assert points[i] == pytest.approx(backbone_points(batch[i]), abs=1e-15)
        assert jac[i] == pytest.approx(backbone_jacobian(batch[i]), abs=1e-13)
    grid = np.stack([batch[:2], batch[2:4]])  # (2, 2, 9) broadcasts too
    assert backbone_points(grid).shape == (2, 2, 31, 3)


@settings(max_examples=100, deadline=None)
@given(module=arrays(np.float64, 3, elements=lengths))
def test_round_trip_lengths_bend_lengths(module):
    bend, plane, arc = lengths_to_bend(module)
    assert bend_to_lengths(bend, plane, arc) == pytest.approx(module, abs=1e-12)
    minimal = bend_to_lengths(bend, plane)
    assert minimal.min() == pytest.approx(0.0, abs=1e-15)
    assert minimal == pytest.approx(module - module.min(), abs=1e-12)


def test_bend_conversions_are_batched():
    modules = np.random.default_rng(2).uniform(0, 0.065, (7, 3))
    bend, plane, arc = lengths_to_bend(modules)
    assert bend.shape == plane.shape == arc.shape == (7,)
    assert bend_to_lengths(bend, plane, arc) == pytest.approx(modules)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: backbone_points(np.zeros(8)), "q: expected an array of shape (..., 9) in m, got shape (8,)"),
        (lambda: backbone_points(np.r_[np.nan, np.zeros(8)]), "q: every value must be finite, got nan at index (0,)"),
        (lambda: backbone_points(np.zeros(9), xi=[0, 3.5]), "xi: body coordinates must lie in [0, 3]"),
        (lambda: backbone_points(np.zeros(9), xi=[[0.0]]), "xi: expected a 1-D array"),
        (lambda: backbone_points(np.zeros(9), base=[0, 0, 0]), "base: expected an array of shape (..., 6)"),
        (lambda: body_transforms(np.zeros(9), [np.inf]), "xi: every value must be finite"),
        (lambda: lengths_to_bend("abc"), "module_lengths_m: expected numbers"),
    ],
)
def test_bad_input_says_what_was_expected(call, message):
    with pytest.raises(InvalidInputError) as info:
        call()
    assert message in str(info.value)
    assert isinstance(info.value, ValueError)
