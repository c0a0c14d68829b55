"""The MuJoCo model of the soft robotic snake on a floor, built in code with ``mujoco.MjSpec``.

Each soft module is a chain of ``n`` rigid segments, the chords of its constant-curvature arc (paper
eq. 1): a capsule of the skin radius. Segment ``k + 1`` hangs off the end of segment ``k`` by three joints
at the node between them, in this order: an axial slide along segment ``k`` (the chord's extension), then
two hinges about the segment's x and y axes (bending about two axes, no twist: the real modules cannot
twist). A small head cap on a slide carries the last chord's extension. The tail segment floats (free
joint). Position servos act on every hinge and slide; :func:`joint_targets` gives their set-points for
the muscles' lengths from the kinematic model, so the body takes the shape that
:func:`srs_ros.core.kinematics.backbone_points` gives wherever gravity and contacts let it.

The floor is a plane; every segment touches it through an explicit contact pair whose friction is
(along the segment, across it): MuJoCo orients a capsule-plane contact frame along the capsule, so one
mechanism gives isotropic and anisotropic friction. Segments closer than
``self_contact_min_separation_m`` along the body never touch; the others do (self-contact).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from srs_ros.core.kinematics import bending_vectors, shape_functions
from srs_ros.core.robot import RobotDescription
from srs_ros.sim.config import SimConfig
from srs_ros.sim.tether import add_tether


@dataclass(frozen=True)
class BodyLayout:
    """Where the body's parts sit in the compiled model (indices into ``MjModel`` / ``MjData`` arrays).

    ``N = module_count * segments_per_module`` segments; node ``k`` (0..N) joins segment ``k - 1`` to
    segment ``k``; node 0 is the tail, node N the head. Hinges sit at nodes 1..N-1, slides at nodes 1..N.
    """

    segment_count: int
    segments_per_module: int
    rest_chord_m: float
    node_xi: np.ndarray            # (N + 1,) body coordinate of every node (0 .. module_count)
    segment_body: np.ndarray       # (N,) body ids of the segments, tail first
    head_body: int                 # body id of the head cap (node N)
    node_body: np.ndarray          # (N + 1,) body whose frame origin is node k (segments, then the head cap)
    segment_geom: np.ndarray       # (N,) capsule geom ids
    floor_geom: int
    hinge_qpos: np.ndarray         # (N - 1, 2) qpos addresses of the (x, y) hinges at nodes 1..N-1
    slide_qpos: np.ndarray         # (N,) qpos addresses of the slides at nodes 1..N
    hinge_actuator: np.ndarray     # (N - 1, 2) actuator ids of the hinge servos (empty: drive muscle_tendons)
    slide_actuator: np.ndarray     # (N,) actuator ids of the slide servos (empty: drive muscle_tendons)
    muscle_actuator: np.ndarray    # (joints * n,) actuators of the muscles' pieces, one per chord (empty: servos)
    muscle_piece_map: np.ndarray   # (joints * n, 3N - 2): piece lengths = map @ [hinge angles (x, y)..., slides]
    floor_geom_segment: dict       # geom id -> segment index of every geom that touches the floor


def _start_frame(config: SimConfig, robot: RobotDescription) -> tuple[np.ndarray, np.ndarray]:
    """Tail position (3,) and orientation quaternion (w, x, y, z) of the straight robot at the start pose.

    The robot frame's +Z points along the heading on the floor and, at ``roll_rad`` 0, its +Y up (the body frame
    of the gaits, :func:`srs_ros.core.gait.library._in_body_frame`), so planar gaits bend in the floor plane and
    actuator 1 of module 1 (on +X) lies level on the left; ``roll_rad`` turns the body about +Z (pi/2: +X up).
    """
    start = config.start
    heading = np.array([math.cos(start.yaw_rad), math.sin(start.yaw_rad), 0.0])
    up = np.array([0.0, 0.0, 1.0])
    left = np.cross(up, heading)
    c, s = math.cos(start.roll_rad), math.sin(start.roll_rad)
    rotation = np.column_stack([c * left + s * up, c * up - s * left, heading])
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, rotation.ravel())
    length_m = robot.module_count * robot.unactuated_length_m + (robot.module_count - 1) * robot.mounting_offset_m
    tail = np.array([start.x_m, start.y_m, config.body.skin_radius_m]) - 0.5 * length_m * heading
    return tail, quat


@dataclass(frozen=True)
class _Chain:
    """Sizes of the body chain: segments per module and in all, rest chord, capsule length, masses, radius."""

    per_module: int
    count: int
    rest_chord_m: float
    geom_chord_m: float
    segment_mass_kg: float
    radius_m: float

    @classmethod
    def of(cls, config: SimConfig, robot: RobotDescription) -> _Chain:
        n = config.body.segments_per_module
        count = robot.module_count * n
        rest_chord = robot.unactuated_length_m / n
        # Capsules span the chord at half the largest extension: the caps cover the joint gaps at either end.
        geom_chord = rest_chord * (1.0 + 0.5 * config.muscles.max_extension_m / robot.unactuated_length_m)
        # The head cap (an end plate) carries half a segment's share of the mass.
        return cls(n, count, rest_chord, geom_chord, config.body.mass_kg(robot) / (count + 0.5),
                   config.body.skin_radius_m)


def build_spec(config: SimConfig, robot: RobotDescription) -> mujoco.MjSpec:
    """The model as an :class:`mujoco.MjSpec` (not compiled): floor, body chain, servos, contact pairs."""
    chain = _Chain.of(config, robot)
    spec = mujoco.MjSpec()
    spec.modelname = f"{robot.name}_sim"
    _set_options(spec, config)
    solref = [config.contact.contact_time_constant_s, 1.0]
    floor = spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[10.0, 10.0, 0.1],
                                    contype=0, conaffinity=0, rgba=[0.6, 0.6, 0.6, 1.0])
    floor.solref = solref
    _add_body(spec, config, robot, chain, solref)
    _add_contacts(spec, config, robot, chain, solref)
    if config.servo.drive == "muscle_tendons":
        _add_muscle_tendons(spec, config, robot, chain)
    if config.tether.enabled:
        add_tether(spec, config.tether, *_start_frame(config, robot), solref, config.physics.time_step_s)
    return spec


def _set_options(spec: mujoco.MjSpec, config: SimConfig) -> None:
    """Time step, gravity, integrator, friction cone and solver."""
    physics = config.physics
    opt = spec.option
    opt.timestep = physics.time_step_s
    opt.gravity = [0.0, 0.0, -physics.gravity_m_s2]
    opt.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    opt.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    opt.solver = mujoco.mjtSolver.mjSOL_NEWTON
    opt.jacobian = mujoco.mjtJacobian.mjJAC_SPARSE   # measured faster than dense for this chain in contact
    opt.iterations = physics.solver_iterations
    # Divergence is reported as an error by the world, never hidden by MuJoCo's automatic reset.
    opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)


def _add_body(spec: mujoco.MjSpec, config: SimConfig, robot: RobotDescription, chain: _Chain,
              solref: list[float]) -> None:
    """The chain of capsule segments from the floating tail, with node joints and servos, and the head cap."""
    servo, contact, smoothing_s = config.servo, config.contact, config.physics.control_period_s
    tail_pos, tail_quat = _start_frame(config, robot)
    parent = spec.worldbody
    for k in range(chain.count):
        if k == 0:
            body = parent.add_body(name="segment_0", pos=tail_pos, quat=tail_quat)
            body.add_freejoint(name="base")
        else:
            # The servo targets come from the kinematic model's node positions, so the twist sigma and the
            # offset delta between modules are in them (chord directions and slide lengths): no joint twists.
            body = parent.add_body(name=f"segment_{k}", pos=[0.0, 0.0, chain.rest_chord_m])
            _add_node_joints(body, k, with_hinges=True, servo=servo, n=chain.per_module, spec=spec,
                             smoothing_s=smoothing_s)
        geom = body.add_geom(name=f"skin_{k}", type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                             fromto=[0.0, 0.0, 0.0, 0.0, 0.0, chain.geom_chord_m], size=[chain.radius_m, 0.0, 0.0],
                             mass=chain.segment_mass_kg, rgba=[0.3, 0.3, 0.32, 1.0])
        geom.friction = [contact.friction_coefficient, contact.torsional_friction_m, contact.rolling_friction_m]
        geom.solref = solref
        geom.contype = geom.conaffinity = 1 if contact.self_contact else 0
        geom.condim = 3
        parent = body
    head = parent.add_body(name="head", pos=[0.0, 0.0, chain.rest_chord_m])
    head.mass = 0.5 * chain.segment_mass_kg
    head.inertia = [0.4 * head.mass * chain.radius_m**2] * 3
    head.explicitinertial = True
    _add_node_joints(head, chain.count, with_hinges=False, servo=servo, n=chain.per_module, spec=spec,
                     smoothing_s=smoothing_s)


def _add_contacts(spec: mujoco.MjSpec, config: SimConfig, robot: RobotDescription, chain: _Chain,
                  solref: list[float]) -> None:
    """Floor contact pairs (friction along / across the segment), and self-contact beyond the separation.

    ``floor_contact: capsules``: one pair per segment capsule. ``points``: spheres at discrete points of
    every segment (:func:`_contact_points`), each paired with the floor; the capsules then only touch
    each other.
    """
    contact = config.contact
    along, across = contact.along_across
    condim = 6 if contact.rolling_friction_m > 0 else (4 if contact.torsional_friction_m > 0 else 3)
    for k in range(chain.count):
        names = [f"skin_{k}"]
        if contact.floor_contact == "points":
            body = spec.body(f"segment_{k}")
            names = []
            for i, (position, radius) in enumerate(_contact_points(config, robot, chain, k)):
                name = f"point_{k}_{i}"
                # Massless (the capsule carries the segment's mass); touches only the floor, through its pair.
                body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_SPHERE, pos=position, size=[radius, 0.0, 0.0],
                              mass=0.0, contype=0, conaffinity=0, group=3, rgba=[0.8, 0.2, 0.2, 1.0])
                names.append(name)
        for name in names:
            spec.add_pair(name=f"floor_{name}", geomname1="floor", geomname2=name, condim=condim,
                          friction=[along, across, contact.torsional_friction_m, contact.rolling_friction_m,
                                    contact.rolling_friction_m], solref=solref)
    if contact.self_contact:
        for i in range(chain.count):
            for j in range(i + 1, chain.count):
                if (j - i) * chain.rest_chord_m < contact.self_contact_min_separation_m or j == i + 1:
                    spec.add_exclude(bodyname1=f"segment_{i}", bodyname2=f"segment_{j}")


def _contact_points(config: SimConfig, robot: RobotDescription, chain: _Chain, k: int) -> list:
    """Centres (segment frame) and radii of segment ``k``'s floor contact spheres (``floor_contact: points``).

    ``points_per_segment`` stations along the rest chord; at each, one sphere of the skin radius on the axis
    (``points_around`` 0) or ``points_around`` spheres of ``point_radius_m`` touching the skin from inside,
    the first at actuator 1's angle of the segment's module (twisted by sigma per module), so three of them
    sit where the muscles are.
    """
    contact = config.contact
    stations = (np.arange(contact.points_per_segment) + 0.5) / contact.points_per_segment * chain.rest_chord_m
    if contact.points_around == 0:
        return [([0.0, 0.0, float(z)], chain.radius_m) for z in stations]
    radius = min(contact.point_radius_m, chain.radius_m)
    start = float(robot.actuator_angles_rad[0]) + (k // chain.per_module) * robot.module_twist_rad
    angles = start + 2.0 * math.pi * np.arange(contact.points_around) / contact.points_around
    ring = chain.radius_m - radius
    return [([ring * math.cos(a), ring * math.sin(a), float(z)], radius) for z in stations for a in angles]


def _add_muscle_tendons(spec: mujoco.MjSpec, config: SimConfig, robot: RobotDescription, chain: _Chain) -> None:
    """``drive: muscle_tendons``: every muscle is ``n`` springs in series, one per chord, on its lengths.

    The piece of muscle ``j`` of module ``m`` along chord ``k`` is a fixed tendon: the chord's slide plus
    ``r (sin phi a - cos phi b)`` for half the rotation ``(a, b)`` of each hinge at the chord's ends (paper
    eq. 1 to first order; ``phi`` is actuator ``j``'s angle plus ``m`` sigma in the chain's frames, as the
    modules are mounted twisted). A chord at a free end of the body counts its one hinge fully. A position
    actuator of ``n`` times the muscle's stiffness (``n`` springs in series make the muscle's) pulls each
    piece toward its length in the kinematic model's shape for the muscles' lengths (the world sets
    ``ctrl`` through :attr:`BodyLayout.muscle_piece_map`), so the body's bending and axial stiffness come
    from the muscles' stiffness and geometry (``1.5 k r^2`` per module in bending, ``3 k`` axially), as in
    the authors' dynamic model, instead of from per-joint servo gains.
    """
    servo, r, n = config.servo, robot.actuator_radius_m, chain.per_module
    for m in range(robot.module_count):
        for j, theta in enumerate(robot.actuator_angles_rad):
            phi = float(theta) + m * robot.module_twist_rad
            for k in range(m * n, (m + 1) * n):
                name = f"muscle_{m + 1}_{j + 1}_chord_{k}"
                tendon = spec.add_tendon(name=name)
                tendon.wrap_joint(f"slide_{k + 1}", 1.0)
                hinges = [h for h in (k, k + 1) if 0 < h < chain.count]
                for h in hinges:
                    share = 1.0 / len(hinges) if len(hinges) == 1 else 0.5
                    tendon.wrap_joint(f"bend_x_{h}", share * r * math.sin(phi))
                    tendon.wrap_joint(f"bend_y_{h}", -share * r * math.cos(phi))
                actuator = spec.add_actuator(name=f"drive_{name}", target=name, trntype=mujoco.mjtTrn.mjTRN_TENDON)
                actuator.set_to_position(kp=n * servo.muscle_stiffness_n_per_m, kv=n * servo.muscle_damping_ns_per_m,
                                         timeconst=config.physics.control_period_s)


def _add_node_joints(body, k: int, with_hinges: bool, servo, n: int, spec: mujoco.MjSpec, smoothing_s: float) -> None:
    """Slide along the parent chord, then (optionally) hinges about x and y, each with a position servo.

    The servo follows its set-point through a first-order filter of ``smoothing_s`` (the control period),
    so set-points that change once per control period move the joints smoothly, not in steps. With
    ``drive: muscle_tendons`` the joints have no servo: the damping is the joint's own, the muscles
    (tendons) move them. With ``bend_moment_limit_nm`` > 0 the hinges' damping is the joint's too
    (:mod:`srs_ros.sim.moment_limit`). ``twist_stiffness_nm_per_rad > 0`` adds a passive twist hinge about the chord.
    """
    servos = servo.drive == "joint_servos"
    joints = [(f"slide_{k}", mujoco.mjtJoint.mjJNT_SLIDE, [0.0, 0.0, 1.0], servo.slide_armature_kg,
               servo.axial_stiffness_n_per_m * n, servo.axial_damping_ns_per_m * n,
               servo.skin_axial_stiffness_n_per_m * n)]
    if with_hinges:
        for axis_name, axis in (("x", [1.0, 0.0, 0.0]), ("y", [0.0, 1.0, 0.0])):
            joints.append((f"bend_{axis_name}_{k}", mujoco.mjtJoint.mjJNT_HINGE, axis, servo.hinge_armature_kg_m2,
                           servo.bend_stiffness_nm_per_rad * n, servo.bend_damping_nms_per_rad * n,
                           servo.skin_bend_stiffness_nm_per_rad * n))
    limited = servo.bend_moment_limit_nm > 0.0  # a force-limited servo's damping moves onto its joint
    for name, kind, axis, armature, kp, kv, skin in joints:
        on_joint = not servos or (limited and kind == mujoco.mjtJoint.mjJNT_HINGE)
        # The skin is a passive spring toward the straight, unextended module (spring reference 0).
        body.add_joint(name=name, type=kind, axis=axis, armature=armature, stiffness=skin,
                       damping=kv if on_joint else 0.0)
        if servos:
            actuator = spec.add_actuator(name=f"servo_{name}", target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
            actuator.set_to_position(kp=kp, kv=0.0 if on_joint else kv, timeconst=smoothing_s)
            if limited and kind == mujoco.mjtJoint.mjJNT_HINGE:  # the range is set each control period
                actuator.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
                actuator.forcerange = [-servo.bend_moment_limit_nm, servo.bend_moment_limit_nm]
    if with_hinges and servo.twist_stiffness_nm_per_rad > 0:
        body.add_joint(name=f"twist_{k}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0.0, 0.0, 1.0],
                       armature=servo.hinge_armature_kg_m2, stiffness=servo.twist_stiffness_nm_per_rad * n,
                       damping=servo.bend_damping_nms_per_rad * n)


def build_model(config: SimConfig, robot: RobotDescription) -> tuple[mujoco.MjModel, BodyLayout]:
    """Compile the model and return it with the :class:`BodyLayout` that indexes it."""
    model = build_spec(config, robot).compile()
    _set_roll_damping(model, config.contact.roll_damping_nms_per_rad)
    n = config.body.segments_per_module
    count = robot.module_count * n

    def body_id(name: str) -> int:
        return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)

    def qpos(name: str) -> int:
        return int(model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)])

    def actuator(name: str) -> int:
        return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, name)

    def geom(name: str) -> int:
        return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name)

    segments = np.array([body_id(f"segment_{k}") for k in range(count)])
    head = body_id("head")
    hinge_names = [[f"bend_{a}_{k}" for a in "xy"] for k in range(1, count)]
    slide_names = [f"slide_{k}" for k in range(1, count + 1)]
    servos = config.servo.drive == "joint_servos"
    pieces = [(m * robot.actuators_per_module + j, f"drive_muscle_{m + 1}_{j + 1}_chord_{k}")
              for m in range(robot.module_count) for j in range(robot.actuators_per_module)
              for k in range(m * n, (m + 1) * n)]
    floor_geoms = {}
    for k in range(count):
        names = [f"skin_{k}"] if config.contact.floor_contact == "capsules" else [
            model.geom(g).name for g in range(model.ngeom) if model.geom(g).name.startswith(f"point_{k}_")]
        floor_geoms.update({geom(name): k for name in names})
    layout = BodyLayout(
        segment_count=count, segments_per_module=n, rest_chord_m=robot.unactuated_length_m / n,
        node_xi=np.linspace(0.0, robot.body_length_xi, count + 1),
        segment_body=segments, head_body=head, node_body=np.append(segments, head),
        segment_geom=np.array([geom(f"skin_{k}") for k in range(count)]),
        floor_geom=geom("floor"),
        hinge_qpos=np.array([[qpos(x) for x in pair] for pair in hinge_names], dtype=int).reshape(-1, 2),
        slide_qpos=np.array([qpos(s) for s in slide_names], dtype=int),
        hinge_actuator=np.array([[actuator(f"servo_{x}") for x in pair] for pair in hinge_names] if servos else [],
                                dtype=int).reshape(-1, 2),
        slide_actuator=np.array([actuator(f"servo_{s}") for s in slide_names] if servos else [], dtype=int),
        muscle_actuator=np.array([] if servos else [actuator(a) for _, a in pieces], dtype=int),
        muscle_piece_map=_piece_map(model, [actuator(a) for _, a in pieces] if not servos else [],
                                    [qpos(x) for pair in hinge_names for x in pair] + [qpos(s) for s in slide_names]),
        floor_geom_segment=floor_geoms,
    )
    return model, layout


def _piece_map(model: mujoco.MjModel, actuators: list[int], columns: list[int]) -> np.ndarray:
    """Coefficients of the fixed tendons behind ``actuators`` over the qpos addresses ``columns``."""
    matrix = np.zeros((len(actuators), len(columns)))
    where = {address: i for i, address in enumerate(columns)}
    for row, actuator in enumerate(actuators):
        tendon = int(model.actuator_trnid[actuator, 0])
        for w in range(model.tendon_adr[tendon], model.tendon_adr[tendon] + model.tendon_num[tendon]):
            matrix[row, where[int(model.jnt_qposadr[model.wrap_objid[w]])]] += model.wrap_prm[w]
    return matrix


def spin_dof(model: mujoco.MjModel) -> int:
    """The dof of the tail's spin about its own axis: the free joint ``base``'s local z rotation (its dof 5)."""
    return int(model.jnt_dofadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "base")]) + 5


def _set_roll_damping(model: mujoco.MjModel, damping_nms_per_rad: float) -> None:
    """Viscous damping of the tail's spin about its own axis (the free joint's local z rotation, dof 5).

    The body cannot twist, so this resists the whole body rolling about its axis; turning on the floor
    and translation stay free. MuJoCo applies joint damping implicitly (stable at any value).
    """
    model.dof_damping[spin_dof(model)] = damping_nms_per_rad


class ShapeTargets:
    """The kinematic model's shape as servo set-points, for one layout (constants precomputed once).

    Called every control period, so it is written for one configuration and few points.
    """

    def __init__(self, layout: BodyLayout, robot: RobotDescription):
        """Precompute the bending map, the node coordinates and the mounting frame of ``robot``."""
        self.layout, self.robot = layout, robot
        n = layout.segments_per_module
        # u = lengths @ bend_map: the bending vectors of unit lengths (paper eq. 1, srs_ros.core.kinematics).
        self.bend_map = bending_vectors(np.eye(robot.actuators_per_module), robot)          # (3, 2)
        self.xi = np.arange(n + 1) / n                                                    # local nodes + tip
        c, s = math.cos(robot.module_twist_rad), math.sin(robot.module_twist_rad)
        self.mount = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        self.offset = np.array([0.0, 0.0, robot.mounting_offset_m])

    def nodes(self, lengths_m: np.ndarray) -> np.ndarray:
        """The backbone (paper eq. 2) at the nodes ``xi = k / n``: ``(N + 1, 3)`` m, tail module frame.

        The same values as :func:`srs_ros.core.kinematics.backbone_points` at ``layout.node_xi`` (tested).
        """
        robot, n, xi = self.robot, self.layout.segments_per_module, self.xi
        lengths = np.asarray(lengths_m, dtype=np.float64).reshape(robot.module_count, robot.actuators_per_module)
        u = lengths @ self.bend_map                                                        # (M, 2)
        arc = robot.unactuated_length_m + lengths.mean(axis=1)                             # (M,)
        f, g = shape_functions(np.outer(u[:, 0] ** 2 + u[:, 1] ** 2, xi * xi))             # (M, n + 1)
        scale = np.outer(arc, xi * xi)                                                     # xi L * xi (a = xi u)
        local = np.empty(f.shape + (3,))
        local[..., 0] = scale * u[:, 0:1] * f
        local[..., 1] = scale * u[:, 1:2] * f
        local[..., 2] = np.outer(arc, xi) * g
        nodes = np.empty((robot.module_count * n + 1, 3))
        rot, pos = np.eye(3), np.zeros(3)
        for m in range(robot.module_count):
            nodes[m * n:(m + 1) * n + 1] = pos + local[m] @ rot.T
            tip_rot = _swing_by(u[m], f[m, -1], g[m, -1])
            rot = rot @ tip_rot
            pos = nodes[(m + 1) * n] + rot @ self.offset
            rot = rot @ self.mount
        return nodes

    def joint_targets(self, lengths_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Servo set-points for muscle lengths ``(9,)``: hinge angles ``(N - 1, 2)`` (rad), slides ``(N,)`` (m).

        The nodes (:meth:`nodes`) give the chords. A slide is its chord's length minus the rest chord.
        The hinges are found tail to head: with the chain's frame ``R`` of chord ``k`` (built from the
        hinge angles already chosen, so the universal joints' small twist never accumulates), the next
        chord's direction in that frame ``t = R^T d`` gives the x then y rotation ``Rx(a) Ry(b) e_z = t``:
        ``b = asin(t_x)``, ``a = atan2(-t_y, t_z)``.
        """
        chords = np.diff(self.nodes(lengths_m), axis=0)
        length = np.sqrt(np.einsum("ij,ij->i", chords, chords))
        slides = length - self.layout.rest_chord_m
        direction = (chords / length[:, None]).tolist()
        # Frame of the first chord: the swing taking +Z onto it (the arc's own frame at the chord's middle).
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = _swing(direction[0]).ravel().tolist()
        angles = []
        asin, atan2, cos, sin = math.asin, math.atan2, math.cos, math.sin
        for dx, dy, dz in direction[1:]:
            tx = r00 * dx + r10 * dy + r20 * dz           # t = R^T d
            ty = r01 * dx + r11 * dy + r21 * dz
            tz = r02 * dx + r12 * dy + r22 * dz
            b = asin(min(1.0, max(-1.0, tx)))
            a = atan2(-ty, tz)
            angles.append((a, b))
            ca, sa, cb, sb = cos(a), sin(a), cos(b), sin(b)
            # R <- R Rx(a) Ry(b), with Rx(a) Ry(b) = [[cb, 0, sb], [sa sb, ca, -sa cb], [-ca sb, sa, ca cb]]
            r00, r01, r02 = (r00 * cb + r01 * sa * sb - r02 * ca * sb, r01 * ca + r02 * sa,
                             r00 * sb - r01 * sa * cb + r02 * ca * cb)
            r10, r11, r12 = (r10 * cb + r11 * sa * sb - r12 * ca * sb, r11 * ca + r12 * sa,
                             r10 * sb - r11 * sa * cb + r12 * ca * cb)
            r20, r21, r22 = (r20 * cb + r21 * sa * sb - r22 * ca * sb, r21 * ca + r22 * sa,
                             r20 * sb - r21 * sa * cb + r22 * ca * cb)
        return np.array(angles).reshape(-1, 2), slides


def _swing_by(u: np.ndarray, f: float, g: float) -> np.ndarray:
    """The module's tip rotation ``I + g A + f A^2``, ``A = skew(-uy, ux, 0)`` (as kinematics._module_pose)."""
    ax, ay = u
    s = ax * ax + ay * ay
    return np.array([[1.0 - f * ax * ax, -f * ax * ay, g * ax],
                     [-f * ax * ay, 1.0 - f * ay * ay, g * ay],
                     [-g * ax, -g * ay, 1.0 - f * s]])


def _swing(direction) -> np.ndarray:
    """Rotation about an axis in the xy plane that takes +Z onto the unit vector ``direction``."""
    x, y, z = direction
    if z < -1.0 + 1e-12:
        return np.diag([1.0, -1.0, -1.0])
    k = 1.0 / (1.0 + z)
    return np.array([[1.0 - k * x * x, -k * x * y, x], [-k * x * y, 1.0 - k * y * y, y], [-x, -y, z]])
