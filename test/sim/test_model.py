"""The MuJoCo model: built with MjSpec from the robot description; servo targets reproduce the kinematic shape."""

import dataclasses

import mujoco
import numpy as np
import pytest

from srs_ros.core.kinematics import backbone_points
from srs_ros.core.robot import default_robot
from srs_ros.sim.config import load_sim_config, with_friction
from srs_ros.sim.model import ShapeTargets, build_model, build_spec

ROBOT = default_robot()
CONFIG = load_sim_config()
RNG = np.random.default_rng(3)


@pytest.mark.parametrize("segments", [3, 5, 8])
def test_the_body_is_a_chain_of_segments_with_the_robot_mass_and_a_servo_on_every_joint(segments):
    config = CONFIG.replace("body", segments_per_module=segments)
    model, layout = build_model(config, ROBOT)
    count = ROBOT.module_count * segments
    assert layout.segment_count == count and len(layout.node_body) == count + 1
    assert model.nv == 6 + 2 * (count - 1) + count             # free base, 2 hinges per inner node, slides
    assert model.nu == 2 * (count - 1) + count
    assert model.body_mass[layout.node_body].sum() == pytest.approx(ROBOT.mass_kg)
    assert np.all(model.geom_size[layout.segment_geom, 0] == config.body.skin_radius_m)
    assert model.opt.timestep == config.physics.time_step_s
    # No joint twists a segment about its own axis: hinges are about the segment's x and y only.
    hinge_axes = model.jnt_axis[model.jnt_type == mujoco.mjtJoint.mjJNT_HINGE]
    assert np.all(hinge_axes[:, 2] == 0.0)


@pytest.mark.parametrize("robot", [ROBOT, dataclasses.replace(ROBOT, mounting_offset_m=0.01)])
def test_target_nodes_are_the_kinematic_backbone(robot):
    _, layout = build_model(CONFIG, robot)
    shape = ShapeTargets(layout, robot)
    for q in RNG.uniform(0.0, robot.max_extension_m, (10, robot.joint_count)):
        np.testing.assert_allclose(shape.nodes(q), backbone_points(q, layout.node_xi, robot), atol=1e-12)


@pytest.mark.parametrize("segments", [3, 5])
def test_joints_at_their_targets_give_the_kinematic_shape(segments):
    config = CONFIG.replace("body", segments_per_module=segments)
    model, layout = build_model(config, ROBOT)
    data = mujoco.MjData(model)
    shape = ShapeTargets(layout, ROBOT)
    for q in RNG.uniform(0.0, ROBOT.max_extension_m, (5, ROBOT.joint_count)):
        nodes = shape.nodes(q)
        angles, slides = shape.joint_targets(q)
        chord = (nodes[1] - nodes[0]) / np.linalg.norm(nodes[1] - nodes[0])
        # Put the tail segment at the kinematic base, along its first chord, then every joint at its target.
        quat = np.zeros(4)
        axis = np.cross([0.0, 0.0, 1.0], chord)
        mujoco.mju_axisAngle2Quat(quat, axis / np.linalg.norm(axis), np.arccos(chord[2]))
        data.qpos[:7] = [0.0, 0.0, 0.0, *quat]
        data.qpos[layout.hinge_qpos.ravel()] = angles.ravel()
        data.qpos[layout.slide_qpos] = slides
        mujoco.mj_kinematics(model, data)
        np.testing.assert_allclose(data.xpos[layout.node_body], nodes, atol=1e-9)


def test_floor_friction_is_one_pair_per_segment_along_and_across_the_capsule():
    for text, expected in (("isotropic", (0.8, 0.8)), ("0.3,0.9", (0.3, 0.9))):
        config = with_friction(CONFIG.replace("contact", friction_coefficient=0.8), text)
        model, layout = build_model(config, ROBOT)
        assert model.npair == layout.segment_count
        np.testing.assert_allclose(model.pair_friction[:, :2], np.tile(expected, (model.npair, 1)))
    # The mechanism: MuJoCo orients a capsule-plane contact's first tangent along the capsule's axis.
    model, layout = build_model(CONFIG.replace("start", yaw_rad=0.7), ROBOT)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert data.ncon >= layout.segment_count
    for contact in data.contact[:data.ncon]:
        geom = contact.geom[1] if contact.geom[0] == layout.floor_geom else contact.geom[0]
        capsule_axis = data.geom_xmat[geom].reshape(3, 3)[:, 2]
        assert abs(contact.frame[3:6] @ capsule_axis) == pytest.approx(1.0, abs=1e-9)


def test_self_contact_excludes_only_neighbours_closer_than_the_separation():
    spec = build_spec(CONFIG, ROBOT)
    count = ROBOT.module_count * CONFIG.body.segments_per_module
    excluded = {(e.bodyname1, e.bodyname2) for e in spec.excludes}
    rest_chord = ROBOT.unactuated_length_m / CONFIG.body.segments_per_module
    for i in range(count):
        for j in range(i + 1, count):
            near = (j - i) * rest_chord < CONFIG.contact.self_contact_min_separation_m or j == i + 1
            assert ((f"segment_{i}", f"segment_{j}") in excluded) == near
    model, layout = build_model(CONFIG.replace("contact", self_contact=False), ROBOT)
    assert np.all(model.geom_contype[layout.segment_geom] == 0)


def _spin_left(config, dof: int, speed_rad_s: float = 10.0, duration_s: float = 0.1) -> float:
    """Angular speed (rad/s) of the straight body's base about its local axis ``dof`` (3 x, 4 y, 5 z), later."""
    model, _ = build_model(config, ROBOT)
    data = mujoco.MjData(model)
    data.qpos[2] += 0.05                              # in the air: no floor contact, only the joint's damping
    data.qvel[dof] = speed_rad_s
    mujoco.mj_step(model, data, nstep=int(round(duration_s / model.opt.timestep)))
    return float(data.qvel[dof])


def test_roll_damping_slows_the_body_spinning_about_its_axis_and_nothing_else():
    plain = CONFIG.replace("contact", roll_damping_nms_per_rad=0.0)
    damped = CONFIG.replace("contact", roll_damping_nms_per_rad=0.05)
    assert _spin_left(damped, 5) < 0.5 * _spin_left(plain, 5)          # about the body's own axis (local z)
    assert _spin_left(damped, 4) == pytest.approx(_spin_left(plain, 4), rel=1e-6)   # turning on the floor: free
