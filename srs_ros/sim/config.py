"""The simulated world's configuration: :class:`SimConfig`, loaded and validated from ``config/sim.yaml``.

Every key is a field of the one schema (:data:`SIM_TABLES`, :mod:`srs_ros.core.schema`: type, range, unit);
a bad value or an unknown key raises :class:`~srs_ros.core.errors.ConfigurationError` naming the file, the
key, the value and what is expected, as every config of the package does. The robot itself (geometry,
mass, muscle limits) comes from the robot description; the muscles' lag and delay from
:func:`srs_ros.core.actuation.muscle_model.muscle_parameters_from_options`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from srs_ros.core.actuation.muscle_model import MuscleParameters, muscle_parameters_from_options
from srs_ros.core.errors import ConfigurationError
from srs_ros.core.robot import RobotDescription, config_dir, default_robot, read_yaml
from srs_ros.core.schema import Field, Table, check_known, document, refusal, section

#: Name of the default file in ``config/``.
DEFAULT_SIM_FILE = "sim.yaml"
#: The friction models of the floor.
FRICTION_MODES = ("isotropic", "anisotropic")
#: What drives the body's shape: servos on every joint, or one spring-like muscle per actuator (tendon).
DRIVES = ("joint_servos", "muscle_tendons")
#: What touches the floor: the segments' capsules, or spheres at discrete points (a penalty grid).
FLOOR_CONTACTS = ("capsules", "points")


@dataclass(frozen=True)
class BodyConfig:
    """How the body is discretised and where its markers sit."""

    segments_per_module: int
    skin_radius_m: float
    marker_offset_m: float
    mass_per_module_kg: float

    def mass_kg(self, robot: RobotDescription) -> float:
        """The simulated body's mass: ``mass_per_module_kg`` per module, or the robot description's when 0."""
        return self.mass_per_module_kg * robot.module_count if self.mass_per_module_kg > 0 else robot.mass_kg


@dataclass(frozen=True)
class ServoConfig:
    """Joint servos (the muscles) and the skin's passive stiffness, per module (each joint gets ``n`` x)."""

    bend_stiffness_nm_per_rad: float
    bend_damping_nms_per_rad: float
    axial_stiffness_n_per_m: float
    axial_damping_ns_per_m: float
    skin_bend_stiffness_nm_per_rad: float
    skin_axial_stiffness_n_per_m: float
    hinge_armature_kg_m2: float
    slide_armature_kg: float
    drive: str
    muscle_stiffness_n_per_m: float
    muscle_damping_ns_per_m: float
    twist_stiffness_nm_per_rad: float
    bend_moment_limit_nm: float


@dataclass(frozen=True)
class ContactConfig:
    """Floor friction (isotropic or along/across the body) and self-contact."""

    friction: str
    friction_coefficient: float
    friction_along_body: float
    friction_across_body: float
    torsional_friction_m: float
    rolling_friction_m: float
    roll_damping_nms_per_rad: float
    roll_stiffness_nm_per_rad: float
    self_contact: bool
    self_contact_min_separation_m: float
    contact_time_constant_s: float
    floor_contact: str
    points_per_segment: int
    points_around: int
    point_radius_m: float

    @property
    def along_across(self) -> tuple[float, float]:
        """Friction coefficients (along the body, across it) of the selected model."""
        if self.friction == "anisotropic":
            return self.friction_along_body, self.friction_across_body
        return self.friction_coefficient, self.friction_coefficient

    def describe(self) -> str:
        """One line for people, e.g. ``isotropic friction 0.8``."""
        if self.friction == "anisotropic":
            return f"anisotropic friction {self.friction_along_body:g} along / {self.friction_across_body:g} across"
        return f"isotropic friction {self.friction_coefficient:g}"


@dataclass(frozen=True)
class TetherConfig:
    """The nine supply tubes as one bundle from the tail to an anchor behind the robot (off by default).

    A chain of ``links`` capsules lying on the floor, from a clamp at the anchor (``length_m`` behind the
    tail along the robot's axis, the regulators) to the tail, where it is welded on; ``slack_fraction``
    longer than that distance, laid as an S, so the robot can move away from the anchor. Its joints bend and
    twist with the bundle's stiffness (``EI / l``, ``GJ / l`` per link of length ``l``), so the bundle's
    twist, and its torque on the tail, grows with the turns the body spins, whatever their rate.
    ``anchor_slip_torque_nm`` > 0 lets the clamp slip (Coulomb) above that torque: a torsional spring in
    series with a slip clutch.
    """

    enabled: bool
    length_m: float
    slack_fraction: float
    links: int
    radius_m: float
    mass_per_m_kg: float
    twist_stiffness_nm2: float
    bend_stiffness_nm2: float
    damping_nms_per_rad: float
    friction_coefficient: float
    anchor_slip_torque_nm: float

@dataclass(frozen=True)
class PhysicsConfig:
    """Time step, control period, gravity, solver and the divergence limit."""

    time_step_s: float
    control_period_s: float
    gravity_m_s2: float
    solver_iterations: int
    divergence_speed_m_s: float

    @property
    def steps_per_control(self) -> int:
        """Physics steps per control period (the period is a whole number of steps)."""
        return max(1, int(round(self.control_period_s / self.time_step_s)))


@dataclass(frozen=True)
class StartConfig:
    """Where the straight robot starts on the floor: reference point (m), heading (rad), roll about its axis (rad)."""

    x_m: float
    y_m: float
    yaw_rad: float
    roll_rad: float


@dataclass(frozen=True)
class CameraConfig:
    """The overhead camera's calibration and what it draws."""

    calibration_file: str
    focal_length_px: float
    band_length_m: float
    tail_band_bgr: tuple[int, int, int]
    head_band_bgr: tuple[int, int, int]
    body_bgr: tuple[int, int, int]
    floor_seed: int
    noise_sigma: float


@dataclass(frozen=True)
class SimConfig:
    """Everything the simulated world needs beyond the robot description (``config/sim.yaml``)."""

    body: BodyConfig
    servo: ServoConfig
    contact: ContactConfig
    tether: TetherConfig
    physics: PhysicsConfig
    start: StartConfig
    muscles: MuscleParameters
    camera: CameraConfig
    source: str = dataclasses.field(default="<dict>", compare=False)

    def replace(self, section: str, **changes: Any) -> SimConfig:
        """A copy with ``changes`` in one section, validated again, e.g. ``replace("start", yaw_rad=1.0)``."""
        data = to_dict(self)
        if section not in SIM_TABLES:
            raise refusal("SimConfig.replace", "section", section, f"one of {list(SIM_TABLES)}")
        data[section].update(changes)
        source = self.source if self.source.endswith(" (modified)") else self.source + " (modified)"
        return _build(data, source, robot=None, muscles=self.muscles)


def _bgr(name: str, description: str) -> Field:
    return Field(name, list, item=int, length=3, minimum=0, maximum=255, unit="B, G, R", description=description)


#: Every section of ``sim:`` but ``muscles`` (:data:`~srs_ros.core.actuation.muscle_model.MUSCLE_OPTIONS`).
SIM_TABLES: dict[str, Table] = {table.path.split(".")[1]: table for table in (
    Table("sim.body", (
        Field("segments_per_module", int, minimum=1, maximum=20, unit="segments",
              description="rigid segments per soft module"),
        Field("skin_radius_m", float, minimum=0.002, maximum=0.2, unit="m", description="outer radius of the body"),
        Field("marker_offset_m", float, minimum=0.0, maximum=0.2, unit="m",
              description="distance of each marker from its end"),
        Field("mass_per_module_kg", float, minimum=0.0, maximum=100.0, unit="kg",
              description="0 = the robot description's mass"),
    )),
    Table("sim.servo", (
        Field("bend_stiffness_nm_per_rad", float, minimum=1e-4, maximum=1e4, unit="N m/rad"),
        Field("bend_damping_nms_per_rad", float, minimum=0.0, maximum=1e3, unit="N m s/rad"),
        Field("axial_stiffness_n_per_m", float, minimum=1e-2, maximum=1e6, unit="N/m"),
        Field("axial_damping_ns_per_m", float, minimum=0.0, maximum=1e4, unit="N s/m"),
        Field("skin_bend_stiffness_nm_per_rad", float, minimum=0.0, maximum=1e4, unit="N m/rad"),
        Field("skin_axial_stiffness_n_per_m", float, minimum=0.0, maximum=1e6, unit="N/m"),
        Field("hinge_armature_kg_m2", float, minimum=0.0, maximum=1.0, unit="kg m^2"),
        Field("slide_armature_kg", float, minimum=0.0, maximum=100.0, unit="kg"),
        Field("drive", str, choices=DRIVES, description="what drives the shape"),
        Field("muscle_stiffness_n_per_m", float, minimum=1e-2, maximum=1e6, unit="N/m",
              description="one muscle's stiffness (drive muscle_tendons)"),
        Field("muscle_damping_ns_per_m", float, minimum=0.0, maximum=1e4, unit="N s/m",
              description="one muscle's damping (drive muscle_tendons)"),
        Field("twist_stiffness_nm_per_rad", float, minimum=0.0, maximum=1e4, unit="N m/rad",
              description="a module's torsional stiffness; 0 = rigid (no twist joint)"),
        Field("bend_moment_limit_nm", float, minimum=0.0, maximum=100.0, unit="N m",
              description="largest bending moment of a module's servos at max_pressure_bar, scaled by its "
                          "highest pressure; 0 = no limit"),
    )),
    Table("sim.contact", (
        Field("friction", str, choices=FRICTION_MODES, description="the friction model of the floor"),
        Field("friction_coefficient", float, minimum=0.0, maximum=10.0, description="isotropic Coulomb coefficient"),
        Field("friction_along_body", float, minimum=0.0, maximum=10.0, description="Coulomb coefficient along"),
        Field("friction_across_body", float, minimum=0.0, maximum=10.0, description="Coulomb coefficient across"),
        Field("torsional_friction_m", float, minimum=0.0, maximum=0.1, unit="m"),
        Field("rolling_friction_m", float, minimum=0.0, maximum=0.1, unit="m"),
        Field("roll_damping_nms_per_rad", float, minimum=0.0, maximum=10.0, unit="N m s/rad",
              description="viscous resistance to the body turning about its own axis"),
        Field("roll_stiffness_nm_per_rad", float, minimum=0.0, maximum=100.0, unit="N m/rad",
              description="a spring on the tail's accumulated spin about its own axis (the supply tubes' twist)"),
        Field("self_contact", bool, description="segments far apart along the body touch"),
        Field("self_contact_min_separation_m", float, minimum=0.0, maximum=10.0, unit="m",
              description="segments closer than this along the body never touch"),
        Field("contact_time_constant_s", float, minimum=1e-4, maximum=1.0, unit="s"),
        Field("floor_contact", str, choices=FLOOR_CONTACTS, description="what touches the floor"),
        Field("points_per_segment", int, minimum=1, maximum=10, unit="points",
              description="contact points along each segment (floor_contact points)"),
        Field("points_around", int, minimum=0, maximum=12, unit="points",
              description="0 = one sphere on the axis; >= 3 = that many on the skin around it"),
        Field("point_radius_m", float, minimum=0.001, maximum=0.1, unit="m",
              description="radius of an off-axis contact sphere"),
    )),
    Table("sim.tether", (
        Field("enabled", bool, description="model the supply tubes as a bundle from the tail to an anchor"),
        Field("length_m", float, minimum=0.05, maximum=10.0, unit="m",
              description="from the tail to the anchor (the regulators), along the robot's axis"),
        Field("slack_fraction", float, minimum=0.0, maximum=2.0, unit="-",
              description="the chain is this much longer than the anchor's distance, laid as an S on the floor"),
        Field("links", int, minimum=1, maximum=100, unit="links", description="capsules in the bundle's chain"),
        Field("radius_m", float, minimum=0.001, maximum=0.05, unit="m", description="the bundle's outer radius"),
        Field("mass_per_m_kg", float, minimum=1e-4, maximum=10.0, unit="kg/m", description="the bundle's mass"),
        Field("twist_stiffness_nm2", float, minimum=0.0, maximum=100.0, unit="N m^2",
              description="the bundle's torsional rigidity GJ"),
        Field("bend_stiffness_nm2", float, minimum=0.0, maximum=100.0, unit="N m^2",
              description="the bundle's bending rigidity EI"),
        Field("damping_nms_per_rad", float, minimum=0.0, maximum=10.0, unit="N m s/rad",
              description="damping of every joint of the chain"),
        Field("friction_coefficient", float, minimum=0.0, maximum=10.0, description="the tubes on the floor"),
        Field("anchor_slip_torque_nm", float, minimum=0.0, maximum=100.0, unit="N m",
              description="0 = clamped; > 0 = the bundle's twist slips at the anchor above this torque"),
    )),
    Table("sim.physics", (
        Field("time_step_s", float, minimum=1e-5, maximum=0.02, unit="s"),
        Field("control_period_s", float, minimum=1e-5, maximum=0.1, unit="s",
              description="a whole number of time steps"),
        Field("gravity_m_s2", float, minimum=0.0, maximum=100.0, unit="m/s^2"),
        Field("solver_iterations", int, minimum=1, maximum=1000, unit="iterations"),
        Field("divergence_speed_m_s", float, minimum=0.01, maximum=1e4, unit="m/s"),
    )),
    Table("sim.start", (
        Field("x_m", float, minimum=-1e3, maximum=1e3, unit="m"),
        Field("y_m", float, minimum=-1e3, maximum=1e3, unit="m"),
        Field("yaw_rad", float, minimum=-10.0, maximum=10.0, unit="rad"),
        Field("roll_rad", float, minimum=-10.0, maximum=10.0, unit="rad",
              description="the body turned about its axis: 0 = actuator 1 of module 1 level on the left, pi/2 on top"),
    )),
    Table("sim.camera", (
        Field("calibration_file", str, description="a calibration YAML, or empty for the package's"),
        Field("focal_length_px", float, minimum=0.0, maximum=1e5, unit="px", description="0 = derive it"),
        Field("band_length_m", float, minimum=0.002, maximum=0.2, unit="m"),
        _bgr("tail_band_bgr", "colour of the tail band"),
        _bgr("head_band_bgr", "colour of the head band"),
        _bgr("body_bgr", "colour of the body"),
        Field("floor_seed", int, minimum=0, maximum=2**31 - 1),
        Field("noise_sigma", float, minimum=0.0, maximum=50.0, unit="grey levels"),
    )),
)}
#: The sections of ``sim:``, in the file's order.
SECTIONS = (*SIM_TABLES, "muscles")
_SECTION_TYPES = {"body": BodyConfig, "servo": ServoConfig, "contact": ContactConfig, "tether": TetherConfig,
                  "physics": PhysicsConfig,
                  "start": StartConfig, "camera": CameraConfig}


def _build(data: Mapping[str, Any], source: str, robot: RobotDescription | None,
           muscles: MuscleParameters | None = None) -> SimConfig:
    check_known(data, SECTIONS, source, "sim")
    what = "a mapping of key: value"
    sections = {name: _SECTION_TYPES[name](**table.read(section(data, name, source, "sim", what), source))
                for name, table in SIM_TABLES.items()}
    muscle_options = section(data, "muscles", source, "sim", what)
    _check_control_period(sections["physics"], source)
    if sections["contact"].points_around in (1, 2):
        raise refusal(source, "sim.contact.points_around", sections["contact"].points_around,
                      "0 (one sphere on the axis) or 3 to 12 (spheres around the skin)")
    if muscles is None:
        muscles = muscle_parameters_from_options(muscle_options, robot or default_robot(), source, path="sim.muscles")
    return SimConfig(muscles=muscles, source=source, **sections)


def _check_control_period(physics: PhysicsConfig, source: str) -> None:
    steps = physics.control_period_s / physics.time_step_s
    if steps < 1.0 - 1e-9 or abs(steps - round(steps)) > 1e-6:
        raise refusal(source, "sim.physics.control_period_s", physics.control_period_s,
                      f"a whole number (>= 1) of time_step_s = {physics.time_step_s:g} s")


def sim_config_from_dict(data: Mapping[str, Any], robot: RobotDescription | None = None,
                         source: str = "<dict>") -> SimConfig:
    """Validate the parsed YAML (with its top-level ``sim:`` key) into a :class:`SimConfig`."""
    return _build(document(data, "sim", source, what=f"a mapping of the sections {list(SECTIONS)}", sections=SECTIONS),
                  source, robot)


def default_sim_config_path() -> Path:
    """The package's ``config/sim.yaml``."""
    return config_dir() / DEFAULT_SIM_FILE


def load_sim_config(path: str | Path | None = None, robot: RobotDescription | None = None) -> SimConfig:
    """Read and validate ``config/sim.yaml`` (or ``path``) for ``robot`` (default: the package's robot)."""
    path = Path(path) if path else default_sim_config_path()
    return sim_config_from_dict(read_yaml(path), robot, source=str(path))


def to_dict(config: SimConfig) -> dict[str, dict[str, Any]]:
    """The sections of ``config`` as plain mappings (the ``sim:`` block of the YAML, muscles included)."""
    data = {name: dataclasses.asdict(getattr(config, name)) for name in _SECTION_TYPES}
    muscles = dataclasses.asdict(config.muscles)
    muscles.pop("full_extension_pressure_bar")
    data["muscles"] = muscles
    return data


def changed_values(config: SimConfig, base: SimConfig) -> dict[str, Any]:
    """``{"section.key": value}`` of ``config`` wherever it differs from ``base`` (e.g. a named file from sim.yaml)."""
    changed, reference = to_dict(config), to_dict(base)
    return {f"{name}.{key}": value for name, values in changed.items() for key, value in values.items()
            if value != reference[name][key]}


def with_friction(config: SimConfig, text: str) -> SimConfig:
    """``config`` with the floor friction set from a short text (the ``srs_sim --friction`` argument).

    ``isotropic`` or ``anisotropic``: that model with the file's coefficients; ``0.8``: isotropic with that
    coefficient; ``0.3,0.9``: anisotropic, along then across the body. Raises :class:`ConfigurationError`.
    """
    text = str(text).strip()
    if text in FRICTION_MODES:
        return config.replace("contact", friction=text)
    parts = [p.strip() for p in text.split(",")]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        values = []
    if len(values) == 1:
        return config.replace("contact", friction="isotropic", friction_coefficient=values[0])
    if len(values) == 2:
        return config.replace("contact", friction="anisotropic", friction_along_body=values[0],
                              friction_across_body=values[1])
    raise ConfigurationError(f"friction is {text!r}; expected 'isotropic', 'anisotropic', one coefficient "
                             "(e.g. 0.8) or two (along,across the body, e.g. 0.3,0.9).")
