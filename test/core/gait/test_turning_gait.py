"""The rolling gaits' steering parameter turn_phase_rad: exact, clamped, a gait parameter like any other."""

import math

import numpy as np
import pytest

from srs_ros.core.errors import InvalidInputError
from srs_ros.core.gait.library import gait_curves, gait_spec, rolling_arc_lengths, rolling_module_bends
from srs_ros.core.gait.trajectory import generate_cycle
from srs_ros.core.kinematics import backbone_points, lengths_to_bend
from srs_ros.core.robot import default_robot

ROBOT = default_robot()
PHASES = np.arange(16) / 16


@pytest.mark.parametrize("gait", ["inward_rolling", "outward_rolling"])
def test_turn_phase_is_a_typed_parameter_with_a_range_and_a_unit(gait):
    parameter = {p.name: p for p in gait_spec(gait).parameters}["turn_phase_rad"]
    assert (parameter.default, parameter.minimum, parameter.maximum, parameter.unit) == (0.0, -0.6, 0.6, "rad")
    with pytest.raises(InvalidInputError, match=rf"{gait}.turn_phase_rad is 0.9; expected a number in \[-0.6, 0.6\]"):
        generate_cycle(gait, 4.0, 1.0, 16, params={"turn_phase_rad": 0.9})


@pytest.mark.parametrize("turn_phase", [-0.5, 0.3])
@pytest.mark.parametrize("amplitude", [2.0, 4.0])
def test_turning_cycle_is_exact_and_peaks_at_the_amplitude(turn_phase, amplitude):
    cycle = generate_cycle("inward_rolling", amplitude, 1.0, 32, params={"turn_phase_rad": turn_phase})
    assert cycle.pressures_bar.max() == pytest.approx(amplitude, abs=1e-9)
    assert cycle.pressures_bar.min() >= 0.0
    assert cycle.fit_error_mm.max() < 0.01               # the chained arcs are the body's exact shape
    assert cycle.ok


def test_each_module_bends_its_plane_turn_phase_ahead_of_the_previous_one():
    turn_phase = 0.4
    lengths = rolling_arc_lengths(PHASES, 0.15, ROBOT, 1.0, turn_phase)
    bend, plane, _ = lengths_to_bend(lengths.reshape(len(PHASES), 3, 3), ROBOT)
    # In each module's own frame the plane is psi + i (turn_phase - sigma); every module has the same curvature.
    expected = 2 * math.pi * PHASES[:, None] + np.arange(3) * (turn_phase - ROBOT.module_twist_rad)
    np.testing.assert_allclose(np.angle(np.exp(1j * (plane - expected))), 0.0, atol=1e-9)
    _, reach, phi = rolling_module_bends(PHASES, 0.15, ROBOT, 1.0, turn_phase)
    np.testing.assert_allclose(bend, phi, rtol=1e-12)
    np.testing.assert_allclose(phi * 0.15, ROBOT.unactuated_length_m + ROBOT.actuator_radius_m * phi * reach)


def test_zero_turn_phase_is_the_papers_planar_arc():
    curves, _, _ = gait_curves("inward_rolling", PHASES, ROBOT, {"radius_m": 0.25, "turn_phase_rad": 0.0})
    for n, phase in enumerate(PHASES):
        centre = 0.25 * np.array([math.cos(2 * math.pi * phase), math.sin(2 * math.pi * phase), 0.0])
        np.testing.assert_allclose(np.linalg.norm(curves[n] - centre, axis=-1), 0.25, atol=1e-12)


def test_a_turn_phase_makes_the_body_leave_the_plane():
    lengths = rolling_arc_lengths([0.0], 0.15, ROBOT, 1.0, 0.5)
    points = backbone_points(lengths, robot=ROBOT)[0]
    normal = np.cross(points[5] - points[0], points[10] - points[0])
    assert np.max(np.abs((points - points[0]) @ (normal / np.linalg.norm(normal)))) > 0.01


def test_outward_with_turn_phase_is_inward_reversed_in_time():
    params = {"turn_phase_rad": -0.3}
    inward = generate_cycle("inward_rolling", 3.0, 1.0, 16, params=params)
    outward = generate_cycle("outward_rolling", 3.0, 1.0, 16, params=params)
    np.testing.assert_allclose(outward.lengths_m, inward.lengths_m[(-np.arange(16)) % 16], atol=1e-12)


def _mirror_columns(robot) -> list[int]:
    """Joint columns relabelled by the mirror in the plane of the axis and module 1's first muscle (level at rest)."""
    columns = []
    for module in range(robot.module_count):
        angles = module * robot.module_twist_rad + np.asarray(robot.actuator_angles_rad)
        for angle in angles:
            gap = np.abs((angles + angle + math.pi) % (2 * math.pi) - math.pi)  # the muscle at -angle
            columns.append(module * robot.actuators_per_module + int(np.argmin(gap)))
    return columns


def test_sidewinding_with_a_negative_lateral_wave_is_its_mirror_image_half_a_cycle_on():
    """The steering of sidewinding (docs/navigation.md): lateral_rad's sign mirrors the gait, nothing else.

    The body's shape is the left-right mirror image at the same phase; in the muscles' lengths that is the
    positive gait with its columns relabelled by the mirror and shifted half a cycle.
    """
    parameter = {p.name: p for p in gait_spec("sidewinding").parameters}["lateral_rad"]
    assert (parameter.minimum, parameter.maximum) == (-1.5, 1.5)
    positive = generate_cycle("sidewinding", 4.0, 1.0, 32)
    negative = generate_cycle("sidewinding", 4.0, 1.0, 32, params={"lateral_rad": -0.6})
    columns = _mirror_columns(ROBOT)
    assert sorted(columns) == list(range(9)) and columns != list(range(9))
    mirrored = np.roll(positive.lengths_m[:, columns], 16, axis=0)  # half a cycle on
    assert np.abs(negative.lengths_m - mirrored).max() < 1e-6
    assert np.abs(negative.lengths_m - positive.lengths_m).max() > 0.02  # a different cycle, not the same one
    assert negative.pressures_bar.max() == pytest.approx(4.0, abs=1e-6) and negative.ok


def test_outward_rolling_is_inward_rolling_mirrored_in_the_plane_of_the_first_muscle():
    """That plane lies level at rest (test/sim/test_world.py), so the two gaits are mirror images upside down only."""
    inward = generate_cycle("inward_rolling", 4.0, 1.0, 32)
    outward = generate_cycle("outward_rolling", 4.0, 1.0, 32)
    assert np.abs(outward.lengths_m - inward.lengths_m[:, _mirror_columns(ROBOT)]).max() < 1e-9
    assert np.abs(outward.lengths_m - inward.lengths_m).max() > 0.01
