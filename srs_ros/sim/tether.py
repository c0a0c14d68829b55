"""The supply tubes as a tether (``sim.tether``, off by default): one bundle on the floor from an anchor to the tail.

The nine tubes leaving the robot's tail are modelled as one bundle: a chain of capsules lying on the floor
from a clamp ``length_m`` behind the robot (the regulators) to the tail, welded to it. Its joints bend and
twist with the bundle's rigidity (``EI / l``, ``GJ / l`` per link), so its torque on the tail grows with the
turns the body spins about its own axis, whatever their rate; ``slack_fraction`` lays it longer than the
anchor's distance as an S, and ``anchor_slip_torque_nm`` lets the clamp slip. docs/studies/simulation.md, "Supply
bundle", says what it does to the rolling robot.
"""

from __future__ import annotations

import mujoco
import numpy as np

from srs_ros.sim.config import TetherConfig

#: Added to every joint of the tether's chain: a few times a link's own inertia about its axis (numerical
#: regularisation of its stiff twist at the 2 ms step, as the body's hinge armature).
TETHER_ARMATURE_KG_M2 = 1e-6


def add_tether(spec: mujoco.MjSpec, tether: TetherConfig, tail: np.ndarray, quat: np.ndarray, solref: list[float],
               time_step_s: float) -> None:
    """``tether.enabled``: the supply tubes as one bundle from an anchor behind the robot to its tail.

    ``tail`` and ``quat`` (w, x, y, z) are the tail segment's start pose (its +Z along the robot's axis);
    ``solref`` the contacts' and the weld's; ``time_step_s`` the physics step.

    A chain of ``links`` capsules from the anchor (``length_m`` behind the tail along the robot's axis, on the
    floor) to the tail's end, where the last link is welded to the tail segment (an equality constraint at
    the start pose). With ``slack_fraction`` > 0 the chain is that much longer than the anchor's distance and
    lies on the floor as an S (:func:`_tether_path`), its rest shape, so the robot can move away from the
    anchor. At each link's start three hinges (bend about x and y with ``EI / l``, twist about the link's axis
    with ``GJ / l``) join it to the previous link, the first to the anchor (clamped). With
    ``anchor_slip_torque_nm`` > 0 the anchor's twist runs through one more hinge with only Coulomb friction
    (MuJoCo ``frictionloss``): the clamp slips above that torque. The links touch only the floor.
    """
    heading = np.zeros(3)
    mujoco.mju_rotVecQuat(heading, np.array([0.0, 0.0, 1.0]), quat)
    points = _tether_path(tail, heading, tether)
    lengths = np.linalg.norm(np.diff(points, axis=0), axis=1)
    frames = [_link_frame(points[i + 1] - points[i]) for i in range(tether.links)]
    frame = np.zeros(4)
    mujoco.mju_mat2Quat(frame, frames[0].ravel())
    parent = spec.worldbody.add_body(name="tether_anchor", pos=points[0], quat=frame)
    if tether.anchor_slip_torque_nm > 0:
        parent = parent.add_body(name="tether_clutch")
        parent.mass, parent.inertia, parent.explicitinertial = 1e-4, [1e-8] * 3, True
        clutch = parent.add_joint(name="tether_clutch", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0.0, 0.0, 1.0],
                                  armature=TETHER_ARMATURE_KG_M2, frictionloss=tether.anchor_slip_torque_nm,
                                  damping=tether.damping_nms_per_rad)
        # MuJoCo's friction loss is a soft constraint that creeps below its limit; as stiff as the contacts.
        clutch.solref_friction = [2.0 * time_step_s, 1.0]
    for i in range(tether.links):
        relative = np.zeros(4)
        if i > 0:
            mujoco.mju_mat2Quat(relative, (frames[i - 1].T @ frames[i]).ravel())
        body = parent.add_body(name=f"tether_{i}", pos=[0.0, 0.0, 0.0 if i == 0 else lengths[i - 1]],
                               quat=relative if i > 0 else [1.0, 0.0, 0.0, 0.0])
        link_m = float(lengths[i])
        for axis_name, axis, rigidity in (("x", [1.0, 0.0, 0.0], tether.bend_stiffness_nm2),
                                          ("y", [0.0, 1.0, 0.0], tether.bend_stiffness_nm2),
                                          ("twist", [0.0, 0.0, 1.0], tether.twist_stiffness_nm2)):
            body.add_joint(name=f"tether_{axis_name}_{i}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=axis,
                           stiffness=rigidity / link_m, damping=tether.damping_nms_per_rad,
                           armature=TETHER_ARMATURE_KG_M2)
        geom = body.add_geom(name=f"tether_link_{i}", type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                             fromto=[0.0, 0.0, 0.0, 0.0, 0.0, link_m], size=[tether.radius_m, 0.0, 0.0],
                             mass=tether.mass_per_m_kg * link_m, contype=0, conaffinity=0,
                             rgba=[0.85, 0.85, 0.9, 1.0])
        spec.add_pair(name=f"floor_tether_{i}", geomname1="floor", geomname2=geom.name, condim=3,
                      friction=[tether.friction_coefficient] * 2 + [0.0, 0.0, 0.0], solref=solref)
        parent = body
    # Welded to the tail at the start pose (relpose from qpos0); the weld point is the tail's end (node 0).
    spec.add_equality(name="tether_weld", type=mujoco.mjtEq.mjEQ_WELD, objtype=mujoco.mjtObj.mjOBJ_BODY,
                      name1=f"tether_{tether.links - 1}", name2="segment_0", solref=solref,
                      data=[0.0] * 3 + [0.0] * 3 + [0.0] * 4 + [1.0, 0.0])


def _tether_path(tail: np.ndarray, heading: np.ndarray, tether: TetherConfig) -> np.ndarray:
    """The ``links + 1`` joints of the tether's chain, anchor first, equally spaced along its laid path.

    From the anchor (``length_m`` behind ``tail`` along ``heading``, at the floor) to the tail: straight, or
    with ``slack_fraction`` an S in the floor plane, ``y(u) = A (sin 2 pi u - sin 4 pi u / 2)`` across the line
    (``u`` from 0 at the anchor to 1 at the tail: level at both ends, one lobe to each side), ``A`` chosen
    so the path is ``1 + slack_fraction`` times the straight distance.
    """
    anchor = tail - tether.length_m * heading
    side = np.cross([0.0, 0.0, 1.0], heading)
    u = np.linspace(0.0, 1.0, 2001)
    shape = np.sin(2 * np.pi * u) - 0.5 * np.sin(4 * np.pi * u)

    def path(amplitude: float) -> np.ndarray:
        return anchor + np.outer(u, tail - anchor) + np.outer(amplitude * shape, side)

    def arc(points: np.ndarray) -> np.ndarray:
        return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])

    target, low, high = (1.0 + tether.slack_fraction) * arc(path(0.0))[-1], 0.0, tether.length_m
    for _ in range(60 if tether.slack_fraction > 0 else 0):
        low, high = ((low + high) / 2, high) if arc(path((low + high) / 2))[-1] < target else (low, (low + high) / 2)
    points = path(low)
    s = arc(points)
    stations = np.linspace(0.0, s[-1], tether.links + 1)
    joints = np.column_stack([np.interp(stations, s, points[:, i]) for i in range(3)])
    # Every link lies on the floor, the last one rises to the tail's axis: the laid shape is where gravity
    # leaves it, so the tubes push nothing at rest.
    joints[:-1, 2] = tether.radius_m
    joints[-1] = tail
    return joints


def _link_frame(along: np.ndarray) -> np.ndarray:
    """Rotation whose z axis lies along ``along`` and whose x axis is horizontal (a link lying on the floor)."""
    z = along / np.linalg.norm(along)
    x = np.cross([0.0, 0.0, 1.0], z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])
