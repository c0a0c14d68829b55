"""The simulated world: the snake's MuJoCo body on a floor, driven by simulated muscles.

:class:`SimWorld` is the one API for both uses. A ROS node calls :meth:`SimWorld.command_pressures` when a
command arrives and :meth:`SimWorld.advance_to` with its clock (real time); an offline experiment calls
:meth:`SimWorld.step` as fast as it can. Both run the same fixed-step physics, so a given configuration
and command sequence always gives the same motion. Commands go through the one clamp
(:func:`srs_ros.core.actuation.pressure.clamp_pressures_bar`) into the muscle model
(:class:`srs_ros.core.actuation.muscle_model.MuscleModel`: deadzone, lag, transport delay, saturation); every
control period the muscles' actual lengths set the joint servos' targets
(:func:`srs_ros.sim.model.joint_targets`). :meth:`SimWorld.state` reports what a node publishes and an
experiment measures. A diverged simulation raises :class:`~srs_ros.core.errors.SimulationError` and
never returns a pose.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from srs_ros.core.actuation.muscle_model import MuscleModel
from srs_ros.core.actuation.pressure import clamp_pressures_bar
from srs_ros.core.errors import InvalidInputError, SimulationError
from srs_ros.core.kinematics import lengths_to_bend
from srs_ros.core.robot import RobotDescription, default_robot
from srs_ros.sim.config import SimConfig, load_sim_config
from srs_ros.sim.model import BodyLayout, ShapeTargets, build_model, spin_dof
from srs_ros.sim.moment_limit import BendMomentLimit


@dataclass(frozen=True)
class Contacts:
    """The contacts of one instant: ``k`` points (floor frame, m), normal forces (N), which segments touch.

    ``segments[i] = (a, b)``: segment indices (tail = 0); ``a = -1`` for the floor.
    """

    position_m: np.ndarray
    normal_force_n: np.ndarray
    segments: np.ndarray

    @property
    def floor_count(self) -> int:
        """Contacts between the body and the floor."""
        return int(np.sum(self.segments[:, 0] < 0))

    @property
    def self_count(self) -> int:
        """Contacts between two segments of the body."""
        return int(np.sum(self.segments[:, 0] >= 0))


#: A body whose middle lies closer than this to the midpoint of its ends (m) has no opening to speak of.
OPENING_MIN_M = 1e-3


@dataclass(frozen=True)
class SimState:
    """The world at one instant; floor frame (x, y on the floor, z up), metres, radians, seconds.

    ``base_pose`` is the paper's floating base ``q_b = [x, y, z, roll, pitch, yaw]`` of the tail segment
    (its +Z along the first chord). ``reference_xy_m`` is the point the camera tracker reports, the
    midpoint of the tail and head markers, on the floor; ``heading_rad`` the direction tail -> head
    marker; ``reference_velocity_m_s`` its floor velocity. ``target_bend_rad`` is each module's bending
    angle that the kinematic model gives for the muscles' lengths, ``body_bend_rad`` the simulated
    body's (from the turning of its chords).
    """

    time_s: float
    base_pose: np.ndarray
    base_quaternion_wxyz: np.ndarray
    backbone_m: np.ndarray
    nodes_m: np.ndarray
    tail_marker_m: np.ndarray
    head_marker_m: np.ndarray
    reference_xy_m: np.ndarray
    heading_rad: float
    reference_velocity_m_s: np.ndarray
    commanded_pressure_bar: np.ndarray
    pressure_bar: np.ndarray
    length_m: np.ndarray
    target_bend_rad: np.ndarray
    body_bend_rad: np.ndarray
    contacts: Contacts | None

    @property
    def pose(self) -> np.ndarray:
        """``(x_m, y_m, yaw_rad)`` of the reference point, as the camera tracker gives it."""
        return np.array([self.reference_xy_m[0], self.reference_xy_m[1], self.heading_rad])

    @property
    def opening_speed_m_s(self) -> float:
        """How fast the reference point moves toward the body's opening (m/s; negative: away from it).

        A bent body opens from its middle node toward the midpoint of its ends (the reference point), on the
        floor. The paper's inward rolling moves toward the opening and outward rolling away from it (Sec.
        IV-C/D). Averaged over a run it says so while the bend stays put in the world (a body spinning freely
        about its axis); one whose shape turns with it averages about 0. NaN when the body is too straight for
        an opening (its middle within 1 mm of the reference).
        """
        opening = self.reference_xy_m - self.nodes_m[len(self.nodes_m) // 2, :2]
        size = float(np.linalg.norm(opening))
        return float(self.reference_velocity_m_s @ opening) / size if size > OPENING_MIN_M else math.nan


class SimWorld:
    """The snake on a floor, stepped at a fixed time step; see the module docstring.

    >>> world = SimWorld()
    >>> _ = world.command_pressures(np.full(9, 2.0))
    >>> world.step(0.5)
    >>> round(world.time_s, 3)
    0.5
    """

    def __init__(self, config: SimConfig | None = None, robot: RobotDescription | None = None):
        """Build and compile the model (``config`` default: ``config/sim.yaml``; robot: the package's)."""
        self.robot = robot or default_robot()
        self.config = config or load_sim_config(robot=self.robot)
        self.model, self.layout = build_model(self.config, self.robot)
        self.shape = ShapeTargets(self.layout, self.robot)
        self._spin_dof = spin_dof(self.model)  # the tail's spin about its own axis
        self._moment_limit = BendMomentLimit(self.model, self.layout, self.config.servo.bend_moment_limit_nm,
                                             self.robot.module_count, self.robot.max_pressure_bar)
        self.data = mujoco.MjData(self.model)
        physics = self.config.physics
        self._dt_s = physics.time_step_s
        self._steps_per_control = physics.steps_per_control
        self._body_ids = self.layout.node_body
        # No body point is farther from the tree's centre of mass than the longest body the muscles make.
        robot = self.robot
        self._body_span_m = robot.module_count * (robot.unactuated_length_m + self.config.muscles.max_extension_m)
        self._root_id = int(self.model.body_rootid[self.layout.segment_body[0]])
        self.reset()

    # ------------------------------------------------------------------ time and commands
    @property
    def time_s(self) -> float:
        """World time (s) since the start or the last :meth:`reset`."""
        return self._step_count * self._dt_s

    @property
    def time_step_s(self) -> float:
        """The physics time step (s); :meth:`step` and :meth:`advance_to` move in whole steps."""
        return self._dt_s

    def reset(self) -> None:
        """Back to the start: straight robot at the configured pose, vented muscles, time 0."""
        mujoco.mj_resetData(self.model, self.data)
        self.muscles = MuscleModel(self.config.muscles, self.robot.joint_count, start_s=0.0)
        self._commanded_bar = np.zeros(self.robot.joint_count)
        self._last_command_s = 0.0
        self._step_count = 0
        self._diverged: str | None = None
        self._bad_qacc = 0
        self._spin_rad = 0.0  # the tail's accumulated spin about its own axis (contact.roll_stiffness_nm_per_rad)
        mujoco.mj_forward(self.model, self.data)

    def command_pressures(self, pressure_bar, now_s: float | None = None) -> np.ndarray:
        """Set the nine regulators' pressures (bar) at ``now_s`` (default: the world's time); returns them clamped.

        Every value goes through :func:`~srs_ros.core.actuation.pressure.clamp_pressures_bar` (NaN or a wrong size
        raises :class:`InvalidInputError` and changes nothing). The command reaches the muscles after the
        supply line's delay. ``now_s`` must not go back before the previous command nor lie more than one
        control period ahead of the world.
        """
        pressure = clamp_pressures_bar(pressure_bar, self.robot)
        when = self.time_s if now_s is None else float(now_s)
        ahead_s = self._steps_per_control * self._dt_s
        if not (math.isfinite(when) and self._last_command_s <= when <= self.time_s + ahead_s):
            raise InvalidInputError(
                f"now_s: a command at {now_s!r} s; expected a time from the previous command "
                f"({self._last_command_s:.6f} s) up to the world's time + one control period "
                f"({self.time_s + ahead_s:.6f} s).")
        self._raise_if_diverged()
        self.muscles.command(pressure, when)
        self._commanded_bar = pressure
        self._last_command_s = when
        return pressure.copy()

    def step(self, duration_s: float) -> None:
        """Advance the physics by ``duration_s`` (rounded to whole time steps); raises on divergence."""
        duration = float(duration_s)
        if not (math.isfinite(duration) and duration >= 0.0):
            raise InvalidInputError(f"duration_s: expected a finite time >= 0 s, got {duration_s!r}.")
        self._run(int(round(duration / self._dt_s)))

    def advance_to(self, time_s: float) -> None:
        """Advance to the last whole time step at or before ``time_s`` (a real-time clock); no-op if behind."""
        target = float(time_s)
        if not math.isfinite(target):
            raise InvalidInputError(f"time_s: expected a finite time, got {time_s!r}.")
        self._run(max(0, int(math.floor(target / self._dt_s + 1e-9)) - self._step_count))

    def _run(self, steps: int) -> None:
        self._raise_if_diverged()
        per_control = self._steps_per_control
        while steps > 0:
            into = self._step_count % per_control
            if into == 0:
                self._set_servo_targets()
                self._wind_supply_tubes(per_control * self._dt_s)
            chunk = min(per_control - into, steps)
            mujoco.mj_step(self.model, self.data, nstep=chunk)
            self._step_count += chunk
            steps -= chunk
            self._check_divergence()

    def _wind_supply_tubes(self, period_s: float) -> None:
        """The supply tubes' twist: a torque against the tail's spin since the start (``roll_stiffness``).

        Set once per control period; the spin is summed from the tail's spin rate at each period's start.
        """
        stiffness = self.config.contact.roll_stiffness_nm_per_rad
        if stiffness > 0.0:
            self._spin_rad += float(self.data.qvel[self._spin_dof]) * period_s
            self.data.qfrc_applied[self._spin_dof] = -stiffness * self._spin_rad

    def _set_servo_targets(self) -> None:
        pressure_bar, length_m = self.muscles.state(self.time_s)
        self._moment_limit.update(self.data, pressure_bar)
        ctrl, layout = self.data.ctrl, self.layout
        angles, slides = self.shape.joint_targets(length_m)
        if layout.muscle_actuator.size:
            ctrl[layout.muscle_actuator] = layout.muscle_piece_map @ np.concatenate([angles.ravel(), slides])
            return
        ctrl[layout.hinge_actuator.ravel()] = angles.ravel()
        ctrl[layout.slide_actuator] = slides

    # ------------------------------------------------------------------ divergence
    def _check_divergence(self) -> None:
        data = self.data
        bad_qacc = int(data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number)
        qpos_ok = np.isfinite(data.qpos).all()
        qvel = data.qvel
        reason = None
        if not (qpos_ok and np.isfinite(qvel).all()):
            reason = "non-finite position or velocity"
        elif bad_qacc > self._bad_qacc:
            reason = "MuJoCo reported a bad acceleration (NaN, inf or huge)"
        else:
            # Cheap bound first (|v| <= |v_c| + |w| * body length, per component); exact speeds only above it.
            cvel = data.cvel
            limit = self.config.physics.divergence_speed_m_s
            bound = 1.7321 * (np.abs(cvel[:, 3:]).max() + np.abs(cvel[:, :3]).max() * self._body_span_m)
            speed = bound if bound <= limit else float(np.sqrt(np.max(np.einsum(
                "ij,ij->i", *(2 * [self._body_speeds()])))))
            if speed > limit:
                reason = (f"a body point moves at about {speed:.3g} m/s, above divergence_speed_m_s = "
                          f"{self.config.physics.divergence_speed_m_s:g} m/s")
        if reason:
            self._diverged = (f"the simulation diverged at t = {self.time_s:.4f} s: {reason}. Lower "
                              "sim.physics.time_step_s or the servo gains, or raise sim.physics.divergence_speed_m_s "
                              "if the body truly moves that fast (the sim config file)")
            raise SimulationError(self._diverged)

    def _body_speeds(self) -> np.ndarray:
        """Linear velocities (m/s) of the nodes (body frame origins), from MuJoCo's com-based velocities.

        ``cvel`` is the spatial velocity at the tree's centre of mass (``subtree_com`` of its root); a point
        ``p`` moves at ``v + w x (p - c)``. (``mj_objectVelocity`` would give the segments' centres of mass.)
        """
        data = self.data
        cvel = data.cvel[self._body_ids]
        offset = data.xpos[self._body_ids] - data.subtree_com[self._root_id]
        return cvel[:, 3:] + np.cross(cvel[:, :3], offset)

    def _raise_if_diverged(self) -> None:
        if self._diverged:
            raise SimulationError(self._diverged)

    # ------------------------------------------------------------------ state
    def node_positions_m(self) -> np.ndarray:
        """The simulated body's nodes (chord ends), tail to head: ``(N + 1, 3)`` m, floor frame."""
        self._raise_if_diverged()
        return self.data.xpos[self.layout.node_body].copy()

    def tracked_pose(self) -> tuple[np.ndarray, float]:
        """What the camera tracks, as in :meth:`state`: ``(reference_xy_m, heading_rad)``, a sixth of its cost.

        For a node that publishes the pose far more often than the rest of the state.
        """
        self._raise_if_diverged()
        _, _, tail, head = self._markers(self.data.xpos[self.layout.node_body])
        return 0.5 * (tail[:2] + head[:2]), _heading_rad(tail, head)

    def _markers(self, nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The tail and head marker centres, ``marker_offset_m`` from each end: their node weights and positions."""
        tail_w = _point_at_distance(nodes, self.config.body.marker_offset_m)
        head_w = _point_at_distance(nodes[::-1], self.config.body.marker_offset_m)[::-1]
        return tail_w, head_w, tail_w @ nodes, head_w @ nodes

    def state(self, with_contacts: bool = True) -> SimState:
        """The world now (see :class:`SimState`); raises :class:`SimulationError` after a divergence.

        ``with_contacts=False`` leaves ``contacts`` as None (a third of the cost, for a real-time node).
        """
        self._raise_if_diverged()
        data, layout, robot = self.data, self.layout, self.robot
        nodes = data.xpos[layout.node_body].copy()
        velocity = self._body_speeds()
        tail_w, head_w, tail, head = self._markers(nodes)
        reference_velocity = 0.5 * (tail_w + head_w) @ velocity
        pressure, length = self.muscles.state(self.time_s)
        base = data.qpos[:7]
        backbone = np.stack([np.interp(robot.backbone_xi, layout.node_xi, nodes[:, i]) for i in range(3)], axis=-1)
        return SimState(
            time_s=self.time_s,
            base_pose=np.concatenate([base[:3], _quat_to_rpy(base[3:7])]),
            base_quaternion_wxyz=base[3:7].copy(),
            backbone_m=backbone,
            nodes_m=nodes,
            tail_marker_m=tail,
            head_marker_m=head,
            reference_xy_m=0.5 * (tail[:2] + head[:2]),
            heading_rad=_heading_rad(tail, head),
            reference_velocity_m_s=reference_velocity[:2],
            commanded_pressure_bar=self._commanded_bar.copy(),
            pressure_bar=pressure,
            length_m=length,
            target_bend_rad=lengths_to_bend(length.reshape(robot.module_count, -1), robot)[0],
            body_bend_rad=_module_bends(nodes, layout),
            contacts=self._contacts() if with_contacts else None,
        )

    def track_sample(self) -> tuple[np.ndarray, float, float]:
        """What an offline run records per frame, at a third of :meth:`state`'s cost (the same values).

        ``(pose, target_bend_rad, body_bend_rad)``: the tracked ``(x_m, y_m, yaw_rad)`` as :attr:`SimState.pose`,
        and the sums over the modules of :attr:`SimState.target_bend_rad` and of :attr:`SimState.body_bend_rad`
        (NaN left out).
        """
        self._raise_if_diverged()
        nodes = self.data.xpos[self.layout.node_body]
        _, _, tail, head = self._markers(nodes)
        reference = 0.5 * (tail[:2] + head[:2])
        _, length = self.muscles.state(self.time_s)
        target = lengths_to_bend(length.reshape(self.robot.module_count, -1), self.robot)[0]
        pose = np.array([reference[0], reference[1], _heading_rad(tail, head)])
        return pose, float(target.sum()), float(np.nansum(_module_bends(nodes, self.layout)))

    def _contacts(self) -> Contacts:
        data, layout = self.data, self.layout
        count = data.ncon
        segment_of = {int(g): k for k, g in enumerate(layout.segment_geom)}
        segment_of.update(layout.floor_geom_segment)
        position = np.empty((count, 3))
        force = np.empty(count)
        segments = np.empty((count, 2), dtype=int)
        wrench = np.zeros(6)
        for i in range(count):
            contact = data.contact[i]
            position[i] = contact.pos
            mujoco.mj_contactForce(self.model, data, i, wrench)
            force[i] = wrench[0]
            pair = sorted(segment_of.get(int(g), -1) for g in contact.geom)
            segments[i] = pair
        body = segments[:, 1] >= 0              # not the tether's links on the floor (tether.enabled)
        return Contacts(position[body], force[body], segments[body])


def _heading_rad(tail: np.ndarray, head: np.ndarray) -> float:
    """The heading of the tail -> head marker line on the floor (rad), what the camera reports."""
    return math.atan2(head[1] - tail[1], head[0] - tail[0])


def _point_at_distance(nodes: np.ndarray, distance_m: float) -> np.ndarray:
    """Weights ``(N + 1,)`` that give the point ``distance_m`` along the polyline ``nodes`` from its start."""
    lengths = np.linalg.norm(np.diff(nodes, axis=0), axis=1)
    ends = np.cumsum(lengths)
    k = min(int(np.searchsorted(ends, distance_m)), len(lengths) - 1)
    start = ends[k] - lengths[k]
    w = min(max((distance_m - start) / lengths[k], 0.0), 1.0) if lengths[k] > 0 else 0.0
    weights = np.zeros(len(nodes))
    weights[k], weights[k + 1] = 1.0 - w, w
    return weights


def _module_bends(nodes: np.ndarray, layout: BodyLayout) -> np.ndarray:
    """Each module's bending angle (rad) from its inner joints: ``n x`` their mean chord-to-chord turning."""
    n = layout.segments_per_module
    modules = layout.segment_count // n
    if n < 2:
        return np.full(modules, np.nan)
    chords = np.diff(nodes, axis=0)
    chords /= np.linalg.norm(chords, axis=1, keepdims=True)
    turning = np.arccos(np.clip(np.einsum("ij,ij->i", chords[:-1], chords[1:]), -1.0, 1.0))   # at nodes 1..N-1
    inner = np.array([turning[m * n:(m + 1) * n - 1] for m in range(modules)])             # (M, n - 1)
    return n * inner.mean(axis=1)


def _quat_to_rpy(quat_wxyz: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw (rad) of a quaternion, ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (the q_b convention)."""
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, quat_wxyz)
    r = mat.reshape(3, 3)
    return np.array([math.atan2(r[2, 1], r[2, 2]), math.asin(max(-1.0, min(1.0, -r[2, 0]))),
                     math.atan2(r[1, 0], r[0, 0])])
