"""The simulated world's configuration: :class:`SimConfig`, loaded and validated from ``config/sim.yaml``.

Every key is checked against a table of its type and range; a bad value raises
:class:`~srs_ros.core.errors.ConfigurationError` naming the file, the key, the value and what is
expected, as :mod:`srs_ros.core.robot` and :mod:`srs_ros.core.rig` do. The robot itself (geometry, mass,
muscle limits) comes from the robot description; the muscles' lag and delay from
:func:`srs_ros.core.actuation.muscle_model.muscle_parameters_from_options`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from srs_ros.core.actuation.muscle_model import MuscleParameters, muscle_parameters_from_options
from srs_ros.core.errors import ConfigurationError
from srs_ros.core.robot import RobotDescription, config_dir, default_robot, read_yaml

#: Name of the default file in ``config/``.
DEFAULT_SIM_FILE = "sim.yaml"
#: The friction models of the floor.
FRICTION_MODES = ("isotropic", "anisotropic")


@dataclass(frozen=True)
class BodyConfig:
    """How the body is discretised and where its markers sit."""

    segments_per_module: int
    skin_radius_m: float
    marker_offset_m: float


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


@dataclass(frozen=True)
class ContactConfig:
    """Floor friction (isotropic or along/across the body) and self-contact."""

    friction: str
    friction_coefficient: float
    friction_along_body: float
    friction_across_body: float
    torsional_friction_m: float
    rolling_friction_m: float
    self_contact: bool
    self_contact_min_separation_m: float
    contact_time_constant_s: float

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
    """Where the straight robot starts on the floor: reference point (m) and heading (rad)."""

    x_m: float
    y_m: float
    yaw_rad: float


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
    physics: PhysicsConfig
    start: StartConfig
    muscles: MuscleParameters
    camera: CameraConfig
    source: str = dataclasses.field(default="<dict>", compare=False)

    def replace(self, section: str, **changes: Any) -> SimConfig:
        """A copy with ``changes`` in one section, validated again, e.g. ``replace("start", yaw_rad=1.0)``."""
        data = to_dict(self)
        if section not in data or section == "muscles":
            raise ConfigurationError(f"SimConfig.replace: unknown section {section!r}; expected one of "
                                     f"{[s for s in _SPEC if s != 'muscles']}.")
        data[section].update(changes)
        source = self.source if self.source.endswith(" (modified)") else self.source + " (modified)"
        return _build(data, source, robot=None, muscles=self.muscles)


# (kind, low, high, expected text); low/high inclusive, None = unbounded.
_Spec = tuple[type, float | None, float | None, str]
_SPEC: dict[str, dict[str, _Spec]] = {
    "body": {
        "segments_per_module": (int, 1, 20, "an integer in [1, 20]"),
        "skin_radius_m": (float, 0.002, 0.2, "a radius in [0.002, 0.2] m"),
        "marker_offset_m": (float, 0.0, 0.2, "a distance in [0, 0.2] m from each end"),
    },
    "servo": {
        "bend_stiffness_nm_per_rad": (float, 1e-4, 1e4, "a stiffness in [1e-4, 1e4] N m/rad"),
        "bend_damping_nms_per_rad": (float, 0.0, 1e3, "a damping in [0, 1e3] N m s/rad"),
        "axial_stiffness_n_per_m": (float, 1e-2, 1e6, "a stiffness in [0.01, 1e6] N/m"),
        "axial_damping_ns_per_m": (float, 0.0, 1e4, "a damping in [0, 1e4] N s/m"),
        "skin_bend_stiffness_nm_per_rad": (float, 0.0, 1e4, "a stiffness in [0, 1e4] N m/rad"),
        "skin_axial_stiffness_n_per_m": (float, 0.0, 1e6, "a stiffness in [0, 1e6] N/m"),
        "hinge_armature_kg_m2": (float, 0.0, 1.0, "an inertia in [0, 1] kg m^2"),
        "slide_armature_kg": (float, 0.0, 100.0, "a mass in [0, 100] kg"),
    },
    "contact": {
        "friction": (str, None, None, f"one of {list(FRICTION_MODES)}"),
        "friction_coefficient": (float, 0.0, 10.0, "a Coulomb coefficient in [0, 10]"),
        "friction_along_body": (float, 0.0, 10.0, "a Coulomb coefficient in [0, 10]"),
        "friction_across_body": (float, 0.0, 10.0, "a Coulomb coefficient in [0, 10]"),
        "torsional_friction_m": (float, 0.0, 0.1, "a length in [0, 0.1] m"),
        "rolling_friction_m": (float, 0.0, 0.1, "a length in [0, 0.1] m"),
        "self_contact": (bool, None, None, "true or false"),
        "self_contact_min_separation_m": (float, 0.0, 10.0, "a distance in [0, 10] m along the body"),
        "contact_time_constant_s": (float, 1e-4, 1.0, "a time constant in [1e-4, 1] s"),
    },
    "physics": {
        "time_step_s": (float, 1e-5, 0.02, "a time step in [1e-5, 0.02] s"),
        "control_period_s": (float, 1e-5, 0.1, "a period in [1e-5, 0.1] s, a whole number of time steps"),
        "gravity_m_s2": (float, 0.0, 100.0, "an acceleration in [0, 100] m/s^2"),
        "solver_iterations": (int, 1, 1000, "an integer in [1, 1000]"),
        "divergence_speed_m_s": (float, 0.01, 1e4, "a speed in [0.01, 1e4] m/s"),
    },
    "start": {
        "x_m": (float, -1e3, 1e3, "a floor coordinate in [-1000, 1000] m"),
        "y_m": (float, -1e3, 1e3, "a floor coordinate in [-1000, 1000] m"),
        "yaw_rad": (float, -10.0, 10.0, "a heading in [-10, 10] rad"),
    },
    "camera": {
        "calibration_file": (str, None, None, "a path to a calibration YAML, or empty for the package's"),
        "focal_length_px": (float, 0.0, 1e5, "0 (derive it) or a focal length in pixels up to 1e5"),
        "band_length_m": (float, 0.002, 0.2, "a length in [0.002, 0.2] m"),
        "tail_band_bgr": (tuple, 0, 255, "three integers 0-255 (B, G, R)"),
        "head_band_bgr": (tuple, 0, 255, "three integers 0-255 (B, G, R)"),
        "body_bgr": (tuple, 0, 255, "three integers 0-255 (B, G, R)"),
        "floor_seed": (int, 0, 2**31 - 1, "an integer seed >= 0"),
        "noise_sigma": (float, 0.0, 50.0, "a noise level in [0, 50] grey levels"),
    },
    "muscles": {},
}
_SECTION_TYPES = {"body": BodyConfig, "servo": ServoConfig, "contact": ContactConfig, "physics": PhysicsConfig,
                  "start": StartConfig, "camera": CameraConfig}


def _value(section: Mapping[str, Any], key: str, spec: _Spec, where: str) -> Any:
    kind, low, high, expected = spec
    if key not in section:
        raise ConfigurationError(f"{where}: missing key '{key}' (expected {expected}).")
    value = section[key]
    bad = ConfigurationError(f"{where}: '{key}' is {value!r}; expected {expected}.")
    if kind is bool:
        if not isinstance(value, bool):
            raise bad
        return value
    if kind is str:
        if not isinstance(value, str):
            raise bad
        return value
    if kind is tuple:
        if not (isinstance(value, (list, tuple)) and len(value) == 3
                and all(isinstance(v, int) and not isinstance(v, bool) and low <= v <= high for v in value)):
            raise bad
        return tuple(int(v) for v in value)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise bad
    if kind is int and not isinstance(value, int):
        raise bad
    if not math.isfinite(value) or (low is not None and value < low) or (high is not None and value > high):
        raise bad
    return kind(value)


def _build(data: Mapping[str, Any], source: str, robot: RobotDescription | None,
           muscles: MuscleParameters | None = None) -> SimConfig:
    sections = {}
    for name, spec in _SPEC.items():
        section = data.get(name)
        if not isinstance(section, Mapping):
            raise ConfigurationError(f"{source}: missing section 'sim.{name}:' (a mapping of keys to values).")
        if name == "muscles":
            continue
        where = f"{source} [sim.{name}]"
        unknown = sorted(set(section) - set(spec))
        if unknown:
            raise ConfigurationError(f"{where}: unknown key {unknown[0]!r}; expected some of {sorted(spec)}.")
        sections[name] = _SECTION_TYPES[name](**{key: _value(section, key, s, where) for key, s in spec.items()})
    unknown = sorted(set(data) - set(_SPEC))
    if unknown:
        raise ConfigurationError(f"{source} [sim]: unknown section {unknown[0]!r}; expected {sorted(_SPEC)}.")
    _cross_checks(sections, source)
    if muscles is None:
        muscles = muscle_parameters_from_options(data["muscles"], robot or default_robot(), f"{source} [sim.muscles]")
    return SimConfig(muscles=muscles, source=source, **sections)


def _cross_checks(sections: Mapping[str, Any], source: str) -> None:
    contact, physics = sections["contact"], sections["physics"]
    if contact.friction not in FRICTION_MODES:
        raise ConfigurationError(f"{source} [sim.contact]: 'friction' is {contact.friction!r}; "
                                 f"expected one of {list(FRICTION_MODES)}.")
    steps = physics.control_period_s / physics.time_step_s
    if steps < 1.0 - 1e-9 or abs(steps - round(steps)) > 1e-6:
        raise ConfigurationError(
            f"{source} [sim.physics]: 'control_period_s' is {physics.control_period_s!r}; expected a whole "
            f"number (>= 1) of time_step_s = {physics.time_step_s} s.")


def sim_config_from_dict(data: Mapping[str, Any], robot: RobotDescription | None = None,
                         source: str = "<dict>") -> SimConfig:
    """Validate the parsed YAML (with its top-level ``sim:`` key) into a :class:`SimConfig`."""
    section = data.get("sim") if isinstance(data, Mapping) else None
    if not isinstance(section, Mapping):
        raise ConfigurationError(f"{source}: missing section 'sim:' (body, servo, contact, physics, start, "
                                 "muscles, camera).")
    return _build(section, source, robot)


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
