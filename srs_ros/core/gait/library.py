"""Gait library: each gait is a task-space shape over one cycle, registered by name (paper Sec. III).

A gait is one shape function here, registered with ``@gait("name")``, plus one block of typed
parameters with defaults and ranges in ``config/gaits.yaml``. A shape function maps phases ``(N,)``
in ``[0, 1)`` and arc lengths ``s_m`` ``(M,)`` to the target curve in the robot frame ``(N, M, 3)``:
the curve starts at the robot origin, leaves it along +Z (the unbent body's axis, docs/conventions.md),
and is parameterised by arc length (metres).

Body frame of a curve that lives in the world (serpentine, sidewinding): at the robot origin on the
curve, +Z is the curve tangent (the body leaves its base along +Z), +Y is the ground normal (world up)
made orthogonal to the tangent, and +X = Y x Z is the in-plane normal to the left of travel. This is
the paper's (tangent, normal, cross product) frame with its axes renamed so that the tangent is the
body's +Z, as the kinematics require.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from srs_ros.core.errors import ConfigurationError, InvalidInputError
from srs_ros.core.robot import RobotDescription, config_dir, read_yaml
from srs_ros.core.schema import Field, Table, check_known, refusal, section

ShapeFunction = Callable[[np.ndarray, np.ndarray, dict, RobotDescription], tuple[np.ndarray, dict]]

_TYPES: dict[str, type] = {"float": float, "int": int, "bool": bool}
#: Where a refused gait parameter value says it is (the key is ``<gait>.<parameter>``).
GAIT_PARAMETERS_WHERE = "gait parameters"
#: The block of one gait in ``config/gaits.yaml``.
GAIT_BLOCK = Table("gaits.<gait>", (
    Field("description", str, "", description="what the gait does"),
    Field("parameters", dict, None, description="parameter name: a block of GAIT_PARAMETER_BLOCK"),
), description="a mapping with description and parameters")
#: The block of one gait parameter in ``config/gaits.yaml`` (``type``, ``default`` and a range).
GAIT_PARAMETER_BLOCK = Table("gaits.<gait>.parameters.<parameter>", (
    Field("type", str, choices=tuple(_TYPES), description="the parameter's type"),
    Field("default", object, expected_text="a value of the parameter's type in its range"),
    Field("minimum", float, None, description="lowest value (inclusive); leave out for none"),
    Field("maximum", float, None, description="highest value (inclusive); leave out for none"),
    Field("unit", str, "", description="unit of the value"),
    Field("description", str, "", description="what the parameter does"),
    Field("amplitude", str, "", choices=("", "proportional", "inverse"),
          description="how the parameter follows the pressure amplitude (float parameters only)"),
), description="a mapping with type, default, minimum, maximum, unit, description")


@dataclass(frozen=True)
class GaitParameter:
    """One typed gait parameter with its default and allowed range (a ROS node declares it as is)."""

    name: str
    type: type
    default: Any
    minimum: float | None
    maximum: float | None
    unit: str
    description: str
    #: How the parameter follows the pressure amplitude: "" (not at all), "proportional" (it scales the body's
    #: bending, e.g. a serpenoid's angle) or "inverse" (a length that shrinks as the body bends more, e.g. a radius).
    amplitude: str = ""

    @property
    def field(self) -> Field:
        """The parameter as a field of the schema (type, range, unit, description, default)."""
        return Field(self.name, self.type, self.default, self.minimum, self.maximum, self.unit, self.description)

    def check(self, gait_name: str, value: Any) -> Any:
        """Return ``value`` converted to :attr:`type`, or raise :class:`InvalidInputError` saying why not.

        The error names the parameter as ``<gait>.<parameter>`` (the trajectory server's parameter name).
        """
        if self.type is int and isinstance(value, numbers.Real) and not isinstance(value, bool) \
                and float(value).is_integer():
            value = int(value)  # 3.0 is the integer 3 (YAML, a --param on the command line)
        return self.field.check(value, GAIT_PARAMETERS_WHERE, f"{gait_name}.{self.name}", InvalidInputError)

    def allowed_text(self) -> str:
        """Human text of the allowed values, e.g. ``a number in [0.08, 2] (m)``."""
        return self.field.expected


@dataclass(frozen=True)
class GaitSpec:
    """A registered gait: its name, a description and its typed parameters."""

    name: str
    description: str
    parameters: tuple[GaitParameter, ...]

    @property
    def defaults(self) -> dict[str, Any]:
        """Parameter name -> default value."""
        return {p.name: p.default for p in self.parameters}

    @property
    def amplitude_parameters(self) -> tuple[str, ...]:
        """Names of the parameters that follow the pressure amplitude (``amplitude:`` in gaits.yaml)."""
        return tuple(p.name for p in self.parameters if p.amplitude)

    def bent(self, values: Mapping[str, Any], factor: float) -> dict[str, Any]:
        """``values`` bent ``factor`` times as much: proportional parameters times it, inverse ones over it.

        Scaling every curvature of a curve by ``factor`` is what these parameters do (a serpenoid's angle,
        a helix's radius and pitch), so the result is the gait's shape bent ``factor`` times as much.
        """
        kinds = {p.name: p.amplitude for p in self.parameters}
        return {name: value * factor if kinds.get(name) == "proportional" else
                value / factor if kinds.get(name) == "inverse" else value for name, value in values.items()}

    def resolve(self, params: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """Defaults overlaid with ``params``, every value checked; unknown names raise :class:`InvalidInputError`."""
        params = dict(params or {})
        by_name = {p.name: p for p in self.parameters}
        check_known(params, by_name, GAIT_PARAMETERS_WHERE, self.name, InvalidInputError)
        return {name: p.check(self.name, params.get(name, p.default)) for name, p in by_name.items()}


_SHAPES: dict[str, ShapeFunction] = {}


def gait(name: str) -> Callable[[ShapeFunction], ShapeFunction]:
    """Register a shape function under ``name`` (its parameters come from ``config/gaits.yaml``)."""
    def register(function: ShapeFunction) -> ShapeFunction:
        _SHAPES[name] = function
        return function
    return register


def gaits_config_path() -> Path:
    """The package's ``config/gaits.yaml``."""
    return config_dir() / "gaits.yaml"


@lru_cache(maxsize=4)
def _load_config(path: str) -> dict:
    data = read_yaml(path)
    section(data, "gaits", path, what="a mapping of gait name: its block (one block per gait)")
    check_known(data, ("gaits", "fitting"), path)
    return dict(data)


def gaits_config(path: str | Path | None = None) -> dict:
    """The parsed gait configuration (``gaits:`` and ``fitting:`` sections), cached."""
    return _load_config(str(Path(path) if path else gaits_config_path()))


def _parameter_from_yaml(gait_name: str, name: str, block: Any, where: str) -> GaitParameter:
    table = GAIT_PARAMETER_BLOCK.at(f"gaits.{gait_name}.parameters.{name}")
    values = table.read(block, where)
    kind = _TYPES[values["type"]]
    if values["amplitude"] and kind is not float:
        raise refusal(where, table.key("amplitude"), values["amplitude"], "'' (only a float parameter follows "
                      "the amplitude)")
    parameter = GaitParameter(name=name, type=kind, **{k: v for k, v in values.items() if k != "type"})
    try:
        default = parameter.check(gait_name, values["default"])
    except InvalidInputError:
        raise refusal(where, table.key("default"), values["default"], parameter.allowed_text()) from None
    return dataclasses.replace(parameter, default=default)


def list_gaits(path: str | Path | None = None) -> dict[str, GaitSpec]:
    """Every registered gait that has a block in ``config/gaits.yaml``: name -> :class:`GaitSpec`.

    Raises :class:`ConfigurationError` if a registered gait has no YAML block, or the reverse.
    """
    where = str(path or gaits_config_path())
    blocks = gaits_config(path)["gaits"]
    missing, orphan = sorted(set(_SHAPES) - set(blocks)), sorted(set(blocks) - set(_SHAPES))
    if missing or orphan:
        raise ConfigurationError(
            f"{where}: gaits without a YAML block {missing}, YAML blocks without a shape function {orphan}; "
            "each gait needs both (a @gait function in srs_ros/core/gait/library.py and a block under 'gaits:').")
    specs = {}
    for name, block in blocks.items():
        values = GAIT_BLOCK.at(f"gaits.{name}").read(block or {}, where)
        specs[name] = GaitSpec(
            name=name, description=" ".join(values["description"].split()),
            parameters=tuple(_parameter_from_yaml(name, key, value, where)
                             for key, value in (values["parameters"] or {}).items()))
    if where not in _SHAPES_CHECKED:
        for spec in specs.values():
            _check_shape_reads(spec, where)
        _SHAPES_CHECKED.add(where)
    return specs


#: The gaits files whose parameter blocks were checked against what the shape functions read (once per process).
_SHAPES_CHECKED: set[str] = set()
#: Parameters of a gait's block that the cycle generator reads (srs_ros.core.gait.trajectory), not its shape.
GENERATOR_PARAMETERS = frozenset({"poor_fit_mm"})


class _ReadRecorder(dict):
    """A gait's parameters that remember which ones a shape function read."""

    def __init__(self, values: Mapping[str, Any]):
        super().__init__(values)
        self.read: set[str] = set()

    def __getitem__(self, key: str) -> Any:
        self.read.add(key)
        return super().__getitem__(key)


def _check_shape_reads(spec: GaitSpec, where: str) -> None:
    """The YAML block declares exactly what the shape function reads (and :data:`GENERATOR_PARAMETERS`).

    A misspelled parameter (``a_radx``) was a KeyError at the first cycle, and an unread one a setting with no
    effect. The shape is run once, on two phases.
    """
    from srs_ros.core.robot import default_robot  # the shape needs a body; any valid one shows what it reads

    params, robot = _ReadRecorder(spec.defaults), default_robot()
    key = f"gaits.{spec.name}.parameters"
    try:
        _SHAPES[spec.name](np.array([0.0, 0.5]), np.linspace(0.0, robot.module_count * robot.unactuated_length_m, 3),
                           params, robot)
    except KeyError as exc:
        raise ConfigurationError(f"{where}: {key} has no {exc.args[0]!r}, which the {spec.name} shape reads; "
                                 f"declared: {sorted(params)} (a misspelled name?)") from None
    unread = sorted(set(params) - params.read - GENERATOR_PARAMETERS)
    if unread:
        raise ConfigurationError(f"{where}: {key}.{unread[0]} is not read by the {spec.name} shape (a misspelled "
                                 f"name?); it reads {sorted(params.read)}")


def gait_spec(name: str) -> GaitSpec:
    """The :class:`GaitSpec` of ``name``; an unknown name raises :class:`InvalidInputError` listing the gaits."""
    specs = list_gaits()
    if name not in specs:
        raise InvalidInputError(f"gait: unknown gait {name!r}; expected one of {sorted(specs)}.")
    return specs[name]


def curve_length_m(robot: RobotDescription) -> float:
    """Arc length of every target curve: the longest the body can be (all actuators fully extended)."""
    return robot.module_count * (robot.unactuated_length_m + robot.max_extension_m)


def gait_curves(name: str, phase, robot: RobotDescription, params: Mapping[str, Any] | None = None,
                points: int = 401) -> tuple[np.ndarray, np.ndarray, dict]:
    """Target curves of gait ``name`` at ``phase`` (N,): ``(curves (N, M, 3) m, s_m (M,), parameters used)``.

    ``parameters used`` holds the resolved parameters plus what a shape derived (e.g. the serpentine
    scale in metres per curve unit).
    """
    return shape_curves(name, phase, robot, gait_spec(name).resolve(params), points)


def shape_curves(name: str, phase, robot: RobotDescription, resolved: Mapping[str, Any],
                 points: int = 401) -> tuple[np.ndarray, np.ndarray, dict]:
    """:func:`gait_curves` for a complete, already checked parameter set.

    E.g. one solved for an amplitude, which may lie outside the ranges a user may ask for.
    """
    phase = np.atleast_1d(np.asarray(phase, dtype=np.float64))
    s_m = np.linspace(0.0, curve_length_m(robot), points)
    curves, derived = _SHAPES[name](phase, s_m, dict(resolved), robot)
    return curves, s_m, {**resolved, **derived}


# --------------------------------------------------------------------------------------------
# Shapes
# --------------------------------------------------------------------------------------------
def _cumulative_trapezoid(values: np.ndarray, s_m: np.ndarray) -> np.ndarray:
    """Integral from s_m[0] of ``values`` (..., M, 3) along axis -2, same shape, 0 at the start."""
    steps = 0.5 * (values[..., 1:, :] + values[..., :-1, :]) * np.diff(s_m)[:, None]
    return np.concatenate([np.zeros_like(values[..., :1, :]), np.cumsum(steps, axis=-2)], axis=-2)


def _in_body_frame(curve: np.ndarray, tangent0: np.ndarray) -> np.ndarray:
    """Express world curves (N, M, 3) that start at the robot origin in the body frame there.

    +Z = the tangent at the origin, +Y = world up made orthogonal to it, +X = Y x Z (module docstring).
    """
    z_axis = tangent0 / np.linalg.norm(tangent0, axis=-1, keepdims=True)
    up = np.array([0.0, 0.0, 1.0])
    y_axis = up - (z_axis @ up)[..., None] * z_axis
    y_axis /= np.linalg.norm(y_axis, axis=-1, keepdims=True)
    x_axis = np.cross(y_axis, z_axis)
    frame = np.stack([x_axis, y_axis, z_axis], axis=-2)                    # rows: body axes in world
    return np.einsum("nij,nmj->nmi", frame, curve)


def _sliding_wave(phase, s_m, yaw_rad, pitch_rad, wavelength_m):
    """A curve given by its tangent angles, with the robot origin slid ``phase`` wavelengths along it.

    ``yaw_rad(sigma)`` and ``pitch_rad(sigma)`` are the tangent's heading and elevation at arc length
    ``sigma`` (m); the tangent is ``(cos p cos y, cos p sin y, sin p)``. Positions are the integral of
    the tangent from the origin (trapezoid rule on the M arc-length samples).
    """
    sigma = phase[:, None] * wavelength_m + s_m[None, :]                    # (N, M)
    yaw, pitch = yaw_rad(sigma), pitch_rad(sigma)
    tangent = np.stack([np.cos(pitch) * np.cos(yaw), np.cos(pitch) * np.sin(yaw), np.sin(pitch)], axis=-1)
    curve = _cumulative_trapezoid(tangent, s_m)
    return _in_body_frame(curve, tangent[:, 0, :])


def _serpenoid_units(robot: RobotDescription, b_rad_per_unit: float, body_wavelengths: float) -> tuple[float, float]:
    """(scale m per curve unit, wavelength m): the unbent body spans ``body_wavelengths`` wavelengths."""
    wavelength_units = 2.0 * math.pi / b_rad_per_unit
    body_m = robot.module_count * robot.unactuated_length_m
    scale = body_m / (body_wavelengths * wavelength_units)
    return scale, scale * wavelength_units


@gait("serpentine")
def serpentine(phase, s_m, params, robot):
    """Serpenoid of paper eq. 4, ``heading(sigma) = a cos(b sigma) + c sigma`` in curve units, z = 0.

    Scale: the curve unit is ``scale_m_per_unit = module_count * L0 / (body_wavelengths * 2 pi / b)``
    metres; with the defaults (b = pi/4: 8 units per wavelength, ``body_wavelengths`` = 0.75 of a
    wavelength on the 0.45 m body) it is 0.075 m per unit, whose largest curvature
    (|a| b / scale = 8.2 1/m) is within the bending a module reaches at 4 bar (one full wavelength
    on the body left actuators at their limit and 14 mm fit errors). The origin slides one
    wavelength per cycle.
    """
    scale, wavelength_m = _serpenoid_units(robot, params["b_rad_per_unit"], params["body_wavelengths"])
    a, b, c = params["a_rad"], params["b_rad_per_unit"], params["c_rad_per_unit"]
    curves = _sliding_wave(phase, s_m, lambda sg: a * np.cos(b * sg / scale) + c * sg / scale,
                           np.zeros_like, wavelength_m)
    return curves, {"scale_m_per_unit": scale, "wavelength_m": wavelength_m}


@gait("sidewinding")
def sidewinding(phase, s_m, params, robot):
    """Two orthogonal tangent-angle waves a quarter period apart (a 3-D serpenoid, helix-like body).

    ``heading = lateral cos(k sigma)``, ``elevation = vertical sin(k sigma)``, ``k = 2 pi / wavelength``;
    the wavelength is the unbent body length / ``body_wavelengths``; the origin slides one wavelength
    per cycle.
    """
    wavelength_m = robot.module_count * robot.unactuated_length_m / params["body_wavelengths"]
    k = 2.0 * math.pi / wavelength_m
    lateral, vertical = params["lateral_rad"], params["vertical_rad"]
    curves = _sliding_wave(phase, s_m, lambda sg: lateral * np.cos(k * sg),
                           lambda sg: vertical * np.sin(k * sg), wavelength_m)
    return curves, {"wavelength_m": wavelength_m}


def helix_curves(phase, s_m, radius_m: float, pitch_m: float, turns_per_cycle: float = 1.0) -> np.ndarray:
    """A helix leaving the origin along +Z, its bending plane turned ``2 pi turns_per_cycle phase`` about +Z.

    Curvature ``radius / (radius^2 + c^2)``, torsion ``c / (radius^2 + c^2)``, ``c = pitch / 2 pi``; at the
    origin the principal normal points along ``(cos psi, sin psi, 0)``. A pitch of 0 is the circular
    arc of radius ``radius_m`` of the rolling gaits (paper Sec. III).
    """
    c = pitch_m / (2.0 * math.pi)
    w = math.hypot(radius_m, c)
    t = s_m / w
    # In the (normal, binormal, tangent) frame at the origin of the standard helix.
    normal = radius_m * (1.0 - np.cos(t))
    binormal = c * radius_m * (t - np.sin(t)) / w
    along = (radius_m * radius_m * np.sin(t) + c * c * t) / w
    psi = 2.0 * math.pi * turns_per_cycle * np.asarray(phase)[:, None]
    cos_psi, sin_psi = np.cos(psi), np.sin(psi)
    return np.stack([normal * cos_psi - binormal * sin_psi, normal * sin_psi + binormal * cos_psi,
                     np.broadcast_to(along, psi.shape[:1] + along.shape)], axis=-1)


def _bend_rotations(direction_rad: np.ndarray, bend_rad: np.ndarray) -> np.ndarray:
    """Rotations (N, 3, 3) of a constant-curvature bend by ``bend_rad`` toward ``direction_rad`` (no twist about +Z).

    Rodrigues about the axis ``(-sin d, cos d, 0)``, the rotation of :mod:`srs_ros.core.kinematics`'s modules.
    """
    axis = np.stack([-np.sin(direction_rad), np.cos(direction_rad), np.zeros_like(direction_rad)], axis=-1)
    k = np.zeros(axis.shape[:-1] + (3, 3))
    k[..., 0, 2], k[..., 1, 2] = axis[..., 1], -axis[..., 0]
    k[..., 2, 0], k[..., 2, 1] = -axis[..., 1], axis[..., 0]
    sin, cos = np.sin(bend_rad)[..., None, None], np.cos(bend_rad)[..., None, None]
    return np.eye(3) + sin * k + (1.0 - cos) * (k @ k)


def rolling_module_bends(phase, radius_m: float, robot: RobotDescription, turns_per_cycle: float = 1.0,
                         turn_phase_rad: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each module's ``(plane in its actuator frame, reach m, bend phi)`` (N, M) of the rolling arc at ``phase``.

    Module ``i`` (0-based) bends toward ``psi + i turn_phase_rad`` in the chain's untwisted frame, i.e.
    ``psi + i (turn_phase_rad - sigma)`` in its own frame (``sigma`` the inter-module twist), with
    ``psi = 2 pi turns_per_cycle phase``; every module is an arc of radius ``radius_m``; with the
    least-extension lengths ``phi = L0 / (radius - r m)``, ``m = max_j cos(theta_j - plane)``.
    """
    phase = np.atleast_1d(np.asarray(phase, dtype=np.float64))
    psi = 2.0 * math.pi * turns_per_cycle * phase
    planes = psi[:, None] + np.arange(robot.module_count) * (turn_phase_rad - robot.module_twist_rad)   # (N, M)
    reach = np.cos(robot.actuator_angles_rad - planes[..., None]).max(axis=-1)
    bend = robot.unactuated_length_m / (radius_m - robot.actuator_radius_m * reach)
    return planes, reach, bend


def rolling_curves(phase, s_m, radius_m: float, robot: RobotDescription, turns_per_cycle: float = 1.0,
                   turn_phase_rad: float = 0.0) -> np.ndarray:
    """The rolling gait's target curves (N, M, 3): one arc of radius ``radius_m`` per module, chained.

    Module ``i`` spans its exact arc length ``phi_i radius`` and bends toward ``psi + i turn_phase_rad``
    (:func:`rolling_module_bends`); the last arc continues to the curve's end. With ``turn_phase_rad = 0``
    every module bends in one plane and the curve is the circle of :func:`helix_curves` (pitch 0); otherwise
    each module's plane leads the previous one's and the body is a twisted chain of arcs.
    """
    phase = np.atleast_1d(np.asarray(phase, dtype=np.float64))
    _, _, bend = rolling_module_bends(phase, radius_m, robot, turns_per_cycle, turn_phase_rad)
    psi = 2.0 * math.pi * turns_per_cycle * phase
    rotation = np.broadcast_to(np.eye(3), (len(phase), 3, 3))
    origin = np.zeros((len(phase), 3))
    start = np.zeros(len(phase))
    curves = np.empty((len(phase), len(s_m), 3))
    for i in range(robot.module_count):
        direction = psi + i * turn_phase_rad
        u = s_m[None, :] - start[:, None]                                    # arc length into module i
        angle = u / radius_m
        local = np.stack([radius_m * (1.0 - np.cos(angle)) * np.cos(direction)[:, None],
                          radius_m * (1.0 - np.cos(angle)) * np.sin(direction)[:, None],
                          radius_m * np.sin(angle)], axis=-1)
        points = origin[:, None, :] + np.einsum("nij,nsj->nsi", rotation, local)
        inside = u >= 0.0
        curves[inside] = points[inside]
        end = bend[:, i] * radius_m
        tip = radius_m * np.stack([(1.0 - np.cos(bend[:, i])) * np.cos(direction),
                                   (1.0 - np.cos(bend[:, i])) * np.sin(direction), np.sin(bend[:, i])], axis=-1)
        origin = origin + np.einsum("nij,nj->ni", rotation, tip)
        rotation = rotation @ _bend_rotations(direction, bend[:, i])
        start = start + end
    return curves


@gait("inward_rolling")
def inward_rolling(phase, s_m, params, robot):
    """Arcs of radius ``r_R`` turning one revolution about +Z per cycle, positive sense (Sec. III).

    Module planes are chained ``turn_phase_rad`` apart (0: the paper's planar arc).
    """
    return rolling_curves(phase, s_m, params["radius_m"], robot, 1.0, params["turn_phase_rad"]), {}


@gait("outward_rolling")
def outward_rolling(phase, s_m, params, robot):
    """The inward-rolling cycle reversed in time: its shape at phase p is the inward shape at -p."""
    return rolling_curves(phase, s_m, params["radius_m"], robot, -1.0, params["turn_phase_rad"]), {}


@gait("helical_rolling")
def helical_rolling(phase, s_m, params, robot):
    """A helix turning one revolution about the body's +Z per cycle (beyond the paper)."""
    return helix_curves(phase, s_m, params["helix_radius_m"], params["helix_pitch_m"], 1.0), {}


def rolling_arc_lengths(phase, radius_m: float, robot: RobotDescription, turns_per_cycle: float = 1.0,
                        turn_phase_rad: float = 0.0) -> np.ndarray:
    """Exact joint-space solution (N, 9) of the rolling arcs of radius ``radius_m`` at ``phase`` (N,).

    Every module is one arc of constant curvature ``1 / radius_m`` bent in its plane
    (:func:`rolling_module_bends`: module ``i`` sees the arc's plane at ``psi + i (turn_phase_rad - sigma)``,
    ``sigma`` the inter-module twist, ``psi = 2 pi turns_per_cycle phase``). With the least-extension
    lengths of docs/conventions.md, ``l_j = r phi (m - cos(theta_j - plane))``, ``m = max_j cos(theta_j - plane)``,
    and the bend ``phi = L / radius`` of the arc length ``L = L0 + r phi m``: ``phi = L0 / (radius - r m)``.
    """
    planes, reach, bend = rolling_module_bends(phase, radius_m, robot, turns_per_cycle, turn_phase_rad)
    varying = robot.actuator_radius_m * bend[..., None] * (
        reach[..., None] - np.cos(robot.actuator_angles_rad - planes[..., None]))
    return varying.reshape(len(planes), robot.joint_count)


#: Rolling gaits, whose every shape is one constant-curvature arc: turns of its bending plane per cycle.
ROLLING_TURNS = {"inward_rolling": 1.0, "outward_rolling": -1.0}


def played_gait(gait_name: str, reverse: bool) -> str:
    """What a player shows: a rolling cycle played backward in time is the other rolling gait."""
    if not reverse:
        return gait_name
    opposite = [name for name, turns in ROLLING_TURNS.items() if turns == -ROLLING_TURNS.get(gait_name, 0.0)]
    return opposite[0] if opposite else f"{gait_name} (played backward)"


def rolling_radius_for_peak(peak_length_m: float, phase, robot: RobotDescription,
                            turns_per_cycle: float = 1.0, turn_phase_rad: float = 0.0) -> float:
    """The rolling arc radius (m) whose exact cycle (:func:`rolling_arc_lengths` at ``phase``) peaks at the length.

    The peak falls monotonically as the radius grows (less bending), so a bracketing root search finds it
    to 1e-12 m; at 4 bar (0.04 m) the default robot's arc has a radius of 0.092 m (0.336 m at 1 bar).
    """
    from scipy.optimize import brentq

    def excess(radius_m: float) -> float:
        return float(rolling_arc_lengths(phase, radius_m, robot, turns_per_cycle, turn_phase_rad).max()) - peak_length_m

    if not peak_length_m > 0.0:
        raise InvalidInputError(f"peak length {peak_length_m!r} m; a rolling arc needs a positive extension.")
    low = robot.actuator_radius_m * (1.0 + 1e-9) + 1e-6
    high = 1.0
    while excess(high) > 0.0:
        high *= 10.0
    return float(brentq(excess, low, high, xtol=1e-12, rtol=1e-12))
