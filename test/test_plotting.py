"""Fig. 4/5 figures show what is commanded: the bodies of the cycle's lengths on the solved gait shape, a top-down
view for planar gaits, and distinct line styles for the actuators of a module."""

import numpy as np
import pytest

from srs_ros.core.gait.trajectory import GaitCycle, generate_cycle
from srs_ros.core.kinematics import backbone_points
from srs_ros.plotting import BODY_LINE_WIDTH, joints_figure, shapes_figure


def thick_lines(axes):
    return [line for line in axes.lines if line.get_linewidth() == BODY_LINE_WIDTH]


def expected_bodies_mm(cycle, shapes=8):
    index = np.unique(np.linspace(0, cycle.sample_count, shapes, endpoint=False).astype(int))
    return backbone_points(cycle.lengths_m[index], robot=cycle.robot) * 1e3


def test_planar_gait_is_drawn_from_above_with_the_commanded_bodies():
    cycle = generate_cycle("serpentine", 4.0, 1.0, samples=16)
    fig = shapes_figure(cycle)
    (axes,) = fig.axes
    assert axes.name == "rectilinear" and axes.get_aspect() == 1.0
    bodies = expected_bodies_mm(cycle)
    lines = thick_lines(axes)
    assert len(lines) == len(bodies)
    for line, body in zip(lines, bodies):
        np.testing.assert_allclose(line.get_xdata(), body[:, 2])  # forward
        np.testing.assert_allclose(line.get_ydata(), body[:, 0])  # left
    assert "a_rad = " in axes.get_title() and "from above" in axes.get_title()


@pytest.mark.parametrize("from_csv", [False, True])
def test_rolling_gait_is_drawn_in_3d_with_the_commanded_arcs(tmp_path, from_csv):
    cycle = generate_cycle("inward_rolling", 4.0, 1.0, samples=16)
    if from_csv:  # a cycle read back from its CSV (and sidecar) draws the same
        cycle = GaitCycle.from_csv(cycle.to_csv(tmp_path / "inward.csv"))
    fig = shapes_figure(cycle)
    (axes,) = fig.axes
    assert axes.name == "3d"
    for line, body in zip(thick_lines(axes), expected_bodies_mm(cycle)):
        np.testing.assert_allclose(np.array(line.get_data_3d()).T, body)
    assert f"radius_m = {cycle.parameters['radius_m']:.4g}" in axes.get_title()


def test_actuators_of_a_module_have_distinct_line_styles_and_markers():
    fig = joints_figure(generate_cycle("inward_rolling", 4.0, 1.0, samples=16), cycles=1)
    for axes in fig.axes[:3]:
        traces = [line for line in axes.lines if line.get_linestyle() != "None"]
        samples = [line for line in axes.lines if line.get_linestyle() == "None"]
        assert len({line.get_linestyle() for line in traces}) == 3
        assert len({line.get_marker() for line in samples}) == 3
