"""SimWorld: clamped commands through the muscle model, fixed-step time, the state, self-contact, divergence."""

import math

import mujoco
import numpy as np
import pytest

from srs_ros.core.errors import InvalidInputError, SimulationError
from srs_ros.core.kinematics import base_transform
from srs_ros.core.robot import default_robot
from srs_ros.sim.config import load_sim_config
from srs_ros.sim.model import _start_frame
from srs_ros.sim.world import SimWorld

CONFIG = load_sim_config()
ROBOT = default_robot()


def test_commands_go_through_the_one_clamp():
    world = SimWorld(CONFIG)
    sent = world.command_pressures([5.0, -1.0, 2.0, 0, 0, 0, 0, 0, 0])
    np.testing.assert_array_equal(sent[:3], [ROBOT.max_pressure_bar, 0.0, 2.0])
    np.testing.assert_array_equal(world.state().commanded_pressure_bar, sent)
    for bad in ([np.nan] * 9, [1.0] * 8):
        with pytest.raises(InvalidInputError):
            world.command_pressures(bad)
    np.testing.assert_array_equal(world.state().commanded_pressure_bar, sent)  # a bad command changes nothing


def test_the_muscles_see_the_supply_delay_and_the_deadzone():
    world = SimWorld(CONFIG)
    world.command_pressures([4.0, 0.8, 0, 0, 0, 0, 0, 0, 0])
    world.step(CONFIG.muscles.transport_delay_s - 0.01)
    assert np.all(world.state().pressure_bar == 0.0)                 # still in the supply line
    world.step(2.0)
    state = world.state()
    assert state.pressure_bar[:2] == pytest.approx([4.0, 0.8], abs=1e-3)
    assert state.length_m[0] == pytest.approx(ROBOT.max_extension_m, abs=1e-4) and state.length_m[1] == 0.0


def test_time_moves_in_whole_steps_and_commands_cannot_go_back():
    world = SimWorld(CONFIG)
    world.step(0.0105)
    assert world.time_s == pytest.approx(round(0.0105 / world.time_step_s) * world.time_step_s)
    world.advance_to(0.1)
    assert world.time_s == pytest.approx(0.1)
    world.advance_to(0.05)                                            # a clock behind the world: no-op
    assert world.time_s == pytest.approx(0.1)
    world.command_pressures(np.ones(9), now_s=0.1)
    with pytest.raises(InvalidInputError, match="now_s"):
        world.command_pressures(np.ones(9), now_s=0.09)
    with pytest.raises(InvalidInputError, match="now_s"):
        world.command_pressures(np.ones(9), now_s=5.0)               # far in the future
    with pytest.raises(InvalidInputError, match="duration_s"):
        world.step(-1.0)


def test_the_body_bends_to_the_servo_share_of_the_kinematic_shape():
    # Without gravity nothing loads the body: each joint settles where servo and skin springs balance.
    config = CONFIG.replace("physics", gravity_m_s2=0.0)
    world = SimWorld(config)
    world.command_pressures([3.0, 0, 0, 0, 3.0, 0, 0, 0, 3.0])
    world.step(2.0)
    state = world.state()
    servo = config.servo
    share = servo.bend_stiffness_nm_per_rad / (servo.bend_stiffness_nm_per_rad + servo.skin_bend_stiffness_nm_per_rad)
    assert state.target_bend_rad == pytest.approx(np.full(3, 2 * state.length_m[0] / (3 * ROBOT.actuator_radius_m)))
    np.testing.assert_allclose(state.body_bend_rad, share * state.target_bend_rad, rtol=0.05)


def test_the_first_muscle_of_the_tail_module_lies_on_the_left_level_with_the_axis():
    """config/sim.yaml's start: muscle 1 of module 1 on the robot's left (body +X = up x heading), not on top."""
    world = SimWorld(CONFIG)  # heading +x: the robot's left is +y
    start = world.node_positions_m().copy()
    world.command_pressures([4.0] + [0.0] * 8)  # muscle 1 extends: module 1 bends away from it
    world.step(2.0)
    nodes = world.node_positions_m()
    assert nodes[0, 1] - start[0, 1] < -0.03  # the tail swings to the right, in the floor plane
    assert nodes[:, 2].max() < start[:, 2].max() + 0.005  # nothing lifts
    turned = SimWorld(CONFIG.replace("start", roll_rad=math.pi))  # start.roll_rad pi: that muscle on the right
    turned.command_pressures([4.0] + [0.0] * 8)
    turned.step(2.0)
    assert turned.node_positions_m()[0, 1] - start[0, 1] > 0.03  # the tail swings to the left


@pytest.mark.parametrize(("roll_rad", "first_muscle_side"), [(0.0, (0, 1, 0)), (math.pi / 2, (0, 0, 1)),
                                                             (math.pi, (0, -1, 0))])
def test_start_roll_turns_the_first_muscle_from_the_left_to_the_top_to_the_right(roll_rad, first_muscle_side):
    """start.roll_rad turns the body about its axis: the robot frame's +X (muscle 1 of module 1) in the floor frame."""
    _, quat = _start_frame(CONFIG.replace("start", roll_rad=roll_rad), ROBOT)
    rotation = np.zeros(9)
    mujoco.mju_quat2Mat(rotation, quat)
    rotation = rotation.reshape(3, 3)
    np.testing.assert_allclose(rotation[:, 0], first_muscle_side, atol=1e-12)  # heading +x, left +y
    np.testing.assert_allclose(rotation[:, 2], (1, 0, 0), atol=1e-12)  # the axis stays along the heading


def test_the_tracked_pose_alone_and_the_offline_runs_sample_are_the_states_while_the_body_rolls():
    """sim_world publishes the pose at 50 Hz from tracked_pose (a sixth of the state's cost), run_experiment records
    track_sample (a third): the same figures as the state's."""
    world = SimWorld(CONFIG.replace("start", x_m=0.1, y_m=-0.2, yaw_rad=0.5))
    phase = np.tile([0.0, 2.1, 4.2], 3)  # each module's three muscles a third of a cycle apart: it bends round
    for step in range(60):
        world.command_pressures(2.0 + 2.0 * np.sin(2 * np.pi * step / 30 + phase))
        world.step(0.02)
        reference_xy_m, heading_rad = world.tracked_pose()
        state = world.state(with_contacts=False)
        np.testing.assert_array_equal(reference_xy_m, state.reference_xy_m)
        assert heading_rad == state.heading_rad
        pose, target_bend_rad, body_bend_rad = world.track_sample()
        np.testing.assert_array_equal(pose, state.pose)
        assert target_bend_rad == state.target_bend_rad.sum() and body_bend_rad == np.nansum(state.body_bend_rad)
    assert np.linalg.norm(state.reference_xy_m - [0.1, -0.2]) > 0.01  # it moved: the check saw a changing body


def test_the_state_reports_the_tracked_point_between_the_markers():
    world = SimWorld(CONFIG.replace("start", x_m=0.1, y_m=-0.2, yaw_rad=0.5))
    state = world.state()
    np.testing.assert_allclose(state.reference_xy_m, [0.1, -0.2], atol=1e-3)
    assert state.heading_rad == pytest.approx(0.5, abs=1e-3)
    assert state.backbone_m.shape == (31, 3)
    np.testing.assert_allclose(state.backbone_m[[0, -1]], state.nodes_m[[0, -1]])
    # base_pose is the paper's q_b of the tail segment: its +Z (the body's axis) along the heading.
    base = base_transform(state.base_pose)
    np.testing.assert_allclose(base[:3, 3], state.nodes_m[0])
    np.testing.assert_allclose(base[:3, 2], [math.cos(0.5), math.sin(0.5), 0.0], atol=1e-3)
    tail_to_head = state.head_marker_m - state.tail_marker_m
    length = ROBOT.module_count * ROBOT.unactuated_length_m
    assert np.linalg.norm(tail_to_head) == pytest.approx(length - 2 * CONFIG.body.marker_offset_m, abs=1e-3)
    np.testing.assert_allclose(state.reference_xy_m, 0.5 * (state.tail_marker_m + state.head_marker_m)[:2])
    # Lying straight on the floor: it touches the floor along its length and not itself.
    world.step(0.2)
    state = world.state()
    assert state.contacts.floor_count >= world.layout.segment_count and state.contacts.self_count == 0
    assert state.contacts.normal_force_n.sum() == pytest.approx(ROBOT.mass_kg * CONFIG.physics.gravity_m_s2, rel=0.05)


def test_the_reported_velocity_is_the_rate_of_the_reported_position():
    world = SimWorld(CONFIG)
    world.command_pressures([4.0, 0, 0, 0, 0, 4.0, 4.0, 0, 0])
    world.step(0.3)
    before = world.state()
    dt = 0.004
    world.step(dt)
    after = world.state()
    rate = (after.reference_xy_m - before.reference_xy_m) / dt
    average = 0.5 * (before.reference_velocity_m_s + after.reference_velocity_m_s)
    assert np.linalg.norm(average) > 0.01
    np.testing.assert_allclose(average, rate, atol=0.1 * np.linalg.norm(rate) + 1e-4)


def _min_segment_distance(world, state):
    """Smallest distance between the axes of segments that may touch each other."""
    layout, nodes = world.layout, state.nodes_m
    gap = int(math.ceil(CONFIG.contact.self_contact_min_separation_m / layout.rest_chord_m))
    best = np.inf
    samples = np.linspace(0.0, 1.0, 12)
    for i in range(layout.segment_count):
        a = nodes[i] + samples[:, None] * (nodes[i + 1] - nodes[i])
        for j in range(i + max(gap, 2), layout.segment_count):
            b = nodes[j] + samples[:, None] * (nodes[j + 1] - nodes[j])
            best = min(best, np.linalg.norm(a[:, None] - b[None], axis=-1).min())
    return best


@pytest.mark.parametrize("self_contact", [True, False])
def test_a_body_curled_past_a_full_circle_does_not_pass_through_itself(self_contact):
    # No skin: the servos reach the kinematic shape, about 1.7 turns.
    config = CONFIG.replace("servo", skin_bend_stiffness_nm_per_rad=0.0).replace("contact", self_contact=self_contact)
    world = SimWorld(config)
    # Bend every module toward the same side: the twist sigma = 60 deg turns each module's muscles.
    world.command_pressures([4.0, 0, 0, 4.0, 0, 4.0, 0, 0, 4.0])
    world.step(1.5)
    state = world.state()
    assert state.target_bend_rad.sum() > 2 * math.pi
    distance = _min_segment_distance(world, state)
    if self_contact:
        assert state.contacts.self_count > 0
        assert distance > 2 * CONFIG.body.skin_radius_m - 0.004     # a few mm of soft contact at most
    else:
        assert distance < CONFIG.body.skin_radius_m                  # without it the body passes through itself


def test_divergence_raises_and_never_returns_a_pose():
    config = CONFIG.replace("servo", bend_stiffness_nm_per_rad=1e4, hinge_armature_kg_m2=0.0,
                            bend_damping_nms_per_rad=0.0).replace("physics", time_step_s=0.01, control_period_s=0.01)
    world = SimWorld(config)
    world.command_pressures(np.full(9, 4.0))
    with pytest.raises(SimulationError, match="diverged"):
        world.step(2.0)
    with pytest.raises(SimulationError):
        world.state()
    with pytest.raises(SimulationError):
        world.step(0.01)
    world.reset()                                                     # back to a usable start
    assert np.isfinite(world.state().reference_xy_m).all()


def test_an_exploding_speed_is_divergence():
    world = SimWorld(CONFIG.replace("physics", divergence_speed_m_s=0.01))
    world.command_pressures([4.0, 0, 0, 0, 0, 4.0, 4.0, 0, 0])
    with pytest.raises(SimulationError, match="divergence_speed_m_s"):
        world.step(1.0)
