"""Gait shapes: the serpenoid's geometry, the rolling arc's radius and plane per phase, outward = reversed inward."""

import math
import re

import numpy as np
import pytest
import yaml

from srs_ros.core.errors import ConfigurationError, InvalidInputError
from srs_ros.core.gait import library
from srs_ros.core.gait.library import curve_length_m, gait_curves, gait_spec, list_gaits, rolling_arc_lengths
from srs_ros.core.kinematics import backbone_points
from srs_ros.core.robot import default_robot

ROBOT = default_robot()
PHASES = np.arange(16) / 16


def test_every_gait_is_registered_with_typed_parameters():
    specs = list_gaits()
    assert {"serpentine", "inward_rolling", "outward_rolling", "sidewinding", "helical_rolling"} <= set(specs)
    for spec in specs.values():
        assert spec.description
        names = [p.name for p in spec.parameters]
        assert "poor_fit_mm" in names
        for p in spec.parameters:
            assert p.type in (float, int, bool)
            assert p.minimum <= p.default <= p.maximum
            assert p.unit


@pytest.mark.parametrize("name", sorted(list_gaits()))
def test_curves_start_at_the_origin_along_plus_z_with_unit_speed(name):
    curves, s_m, _ = gait_curves(name, PHASES, ROBOT)
    assert curves.shape == (len(PHASES), len(s_m), 3)
    np.testing.assert_allclose(curves[:, 0], 0.0, atol=1e-12)
    first = curves[:, 1] / np.linalg.norm(curves[:, 1], axis=-1, keepdims=True)
    assert np.all(first[:, 2] > 0.999)
    speed = np.linalg.norm(np.diff(curves, axis=1), axis=-1) / np.diff(s_m)
    np.testing.assert_allclose(speed, 1.0, atol=2e-3)
    assert s_m[-1] == pytest.approx(curve_length_m(ROBOT))


@pytest.mark.parametrize("name", sorted(list_gaits()))
def test_shapes_are_periodic_in_phase(name):
    start, _, _ = gait_curves(name, [0.0], ROBOT)
    end, _, _ = gait_curves(name, [1.0], ROBOT)
    np.testing.assert_allclose(start, end, atol=1e-9)


def test_serpentine_is_the_scaled_serpenoid_in_the_body_xz_plane():
    curves, s_m, used = gait_curves("serpentine", PHASES, ROBOT)
    # Default: the 0.45 m unbent body spans 0.75 of the 8-unit wavelength.
    assert used["scale_m_per_unit"] == pytest.approx(3 * 0.15 / (0.75 * 8.0))
    assert used["a_rad"] == pytest.approx(-math.pi / 4) and used["b_rad_per_unit"] == pytest.approx(math.pi / 4)
    np.testing.assert_allclose(curves[..., 1], 0.0, atol=1e-12)          # body +Y is the ground normal
    # The heading relative to the tangent at the origin follows a cos(b sigma) - a cos(b sigma0).
    scale, b, a = used["scale_m_per_unit"], used["b_rad_per_unit"], used["a_rad"]
    heading = np.arctan2(np.diff(curves[..., 0], axis=1), np.diff(curves[..., 2], axis=1))
    sigma0 = PHASES[:, None] * used["wavelength_m"]
    mid = 0.5 * (s_m[1:] + s_m[:-1])
    expected = a * np.cos(b * (sigma0 + mid) / scale) - a * np.cos(b * sigma0 / scale)
    np.testing.assert_allclose(heading, expected, atol=2e-3)            # +X is the left normal


def test_rolling_arc_has_radius_r_and_its_plane_turns_once_per_cycle():
    radius = 0.25
    curves, _, _ = gait_curves("inward_rolling", PHASES, ROBOT, {"radius_m": radius})
    for n, phase in enumerate(PHASES):
        psi = 2 * math.pi * phase
        normal = np.array([math.cos(psi), math.sin(psi), 0.0])
        center = radius * normal
        np.testing.assert_allclose(np.linalg.norm(curves[n] - center, axis=-1), radius, atol=1e-12)
        binormal = np.cross([0.0, 0.0, 1.0], normal)
        np.testing.assert_allclose(curves[n] @ binormal, 0.0, atol=1e-12)   # planar, in the plane (Z, normal)


def test_outward_rolling_is_inward_rolling_reversed_in_time():
    inward, _, _ = gait_curves("inward_rolling", PHASES, ROBOT)
    outward, _, _ = gait_curves("outward_rolling", PHASES, ROBOT)
    reversed_index = (-np.arange(len(PHASES))) % len(PHASES)
    np.testing.assert_allclose(outward, inward[reversed_index], atol=1e-12)


def test_rolling_exact_solution_lies_on_the_arc():
    lengths = rolling_arc_lengths(PHASES, 0.2, ROBOT)
    assert lengths.min() >= 0.0 and lengths.max() <= ROBOT.max_extension_m
    points = backbone_points(lengths, robot=ROBOT)
    for n, phase in enumerate(PHASES):
        center = 0.2 * np.array([math.cos(2 * math.pi * phase), math.sin(2 * math.pi * phase), 0.0])
        np.testing.assert_allclose(np.linalg.norm(points[n] - center, axis=-1), 0.2, atol=1e-9)
    # Least extension: one actuator of every module at 0.
    np.testing.assert_allclose(lengths.reshape(-1, 3, 3).min(axis=-1), 0.0, atol=1e-15)


def test_helix_has_constant_curvature_and_torsion():
    curves, s_m, _ = gait_curves("helical_rolling", [0.3], ROBOT, {"helix_radius_m": 0.1, "helix_pitch_m": 0.3})
    c = 0.3 / (2 * math.pi)
    h = s_m[1] - s_m[0]
    second = (curves[0, 2:] - 2 * curves[0, 1:-1] + curves[0, :-2]) / h**2
    np.testing.assert_allclose(np.linalg.norm(second, axis=-1), 0.1 / (0.1**2 + c**2), rtol=1e-3)


def test_sidewinding_leaves_the_ground_plane_and_is_periodic():
    curves, _, _ = gait_curves("sidewinding", PHASES, ROBOT)
    assert np.ptp(curves[..., 1]) > 0.01     # a vertical wave (body +Y is the ground normal)
    assert np.ptp(curves[..., 0]) > 0.01     # and a horizontal one


def test_unknown_gait_and_bad_parameters_are_refused_with_the_allowed_values():
    with pytest.raises(InvalidInputError, match="expected one of .*inward_rolling"):
        gait_spec("slither")
    with pytest.raises(InvalidInputError, match=r"inward_rolling.radius is not a known key; expected .*radius_m"):
        gait_curves("inward_rolling", PHASES, ROBOT, {"radius": 0.2})
    with pytest.raises(InvalidInputError, match=r"inward_rolling.radius_m is 0.01; expected .*\[0.08, 2\] \(m\)"):
        gait_curves("inward_rolling", PHASES, ROBOT, {"radius_m": 0.01})
    with pytest.raises(InvalidInputError, match="radius_m"):
        gait_curves("inward_rolling", PHASES, ROBOT, {"radius_m": "big"})
    with pytest.raises(InvalidInputError, match="radius_m"):
        gait_curves("inward_rolling", PHASES, ROBOT, {"radius_m": float("nan")})


def test_a_rolling_cycle_played_backward_is_the_other_rolling_gait():
    from srs_ros.core.gait.library import played_gait

    assert played_gait("inward_rolling", True) == "outward_rolling"
    assert played_gait("outward_rolling", True) == "inward_rolling"
    assert played_gait("inward_rolling", False) == "inward_rolling"
    assert played_gait("serpentine", True) == "serpentine (played backward)"


@pytest.mark.parametrize(("change", "message"), [
    (lambda p: p.update(a_radx=p.pop("a_rad")), "gaits.serpentine.parameters has no 'a_rad', which the serpentine "
                                                "shape reads"),
    (lambda p: p.update(a_deg=dict(p["a_rad"])), "gaits.serpentine.parameters.a_deg is not read by the serpentine "
                                                 "shape"),
])
def test_a_gait_block_must_declare_what_its_shape_reads(tmp_path, change, message):
    """A misspelled parameter passed the schema and was a KeyError at the first cycle (a helper's config review)."""
    data = yaml.safe_load(library.gaits_config_path().read_text())
    change(data["gaits"]["serpentine"]["parameters"])
    path = tmp_path / "gaits.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigurationError, match=re.escape(message)):
        library.list_gaits(path)
