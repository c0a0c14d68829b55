"""The navigator's settings and the identified turn map, each checked by the one schema.

:data:`NAVIGATION_TABLE` holds every setting with its default, range and unit (the one place they live: a
ROS node declares its parameters from these fields, :func:`load_navigation_settings` overlays a caller's
values). :class:`TurningMap` is what ``srs_turning --write-map`` measured on the simulated robot
(``config/turning_map.yaml``): for each rolling direction, the turn rate per cycle at each ``turn_phase_rad``.
It is only the controller's first guess; the controller corrects it online from the camera.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from srs_ros.core.errors import ConfigurationError
from srs_ros.core.robot import config_file, read_yaml
from srs_ros.core.schema import Field, Table, check_known, document, refusal, section

#: The two rolling directions the navigator drives (the robot rolls roughly across its body axis).
DIRECTIONS = ("inward_rolling", "outward_rolling")


def other_direction(direction: str) -> str:
    """The other rolling direction."""
    return DIRECTIONS[1 - DIRECTIONS.index(direction)]


#: Where the model's robot rolls inward, seen along its tail -> head heading (square_rad's sign).
MODEL_INWARD_SIDE = "left"


def square_rad(direction: str) -> float:
    """Where a nearly straight body travels in ``direction``, from its yaw: inward rolling square to the left (rad)."""
    return math.pi / 2 if direction == DIRECTIONS[0] else -math.pi / 2


#: Gait phases at which the navigator stops the robot: stopped at one phase, it comes to rest at the same
#: place relative to its pose every time (within millimetres); stopped anywhere, within +-10 cm.
STOP_PHASES = (0.0, 0.25, 0.5, 0.75)
#: Where a stopped robot is first assumed to rest, (along, across) its travel from the stop (m), at each stop
#: phase: it rolls on while the gait ramps out and its reference point moves as the curled body straightens.
DEFAULT_STOP_OFFSET_M = (0.1, 0.0) * len(STOP_PHASES)
#: Default turning map file (``config/``).
DEFAULT_TURNING_MAP_FILE = "turning_map.yaml"

NAVIGATION_TABLE = Table("navigation", (
    Field("goal_tolerance_m", float, 0.05, 0.005, 1.0, "m",
          "a goal is reached when the tracked point rests this close to it"),
    Field("waypoint_tolerance_m", float, 0.15, 0.005, 1.0, "m",
          "a path's waypoint before its last is passed when the tracked point comes this close (without stopping)"),
    Field("pose_timeout_s", float, 1.0, 0.05, 60.0, "s",
          "no pose from the camera this long: stop, state pose_lost"),
    Field("view_margin_m", float, 0.25, 0.0, 2.0, "m",
          "goals must lie this far inside the camera's calibrated floor area (the 0.45 m body stays in view)"),
    Field("edge_guard_m", float, 0.35, 0.0, 2.0, "m",
          "the cruise gait keeps the robot in view: its tracked point this close to the edge of the camera's "
          "calibrated floor area and seen moving toward it over the last cycle, the robot rolls the other way "
          "for 2.5 cycles (the cruise gait only); 0: off"),
    Field("amplitude_bar", float, 4.0, 0.5, 4.0, "bar", "pressure amplitude of the rolling gaits"),
    Field("cruise_frequency_hz", float, 1.0, 0.1, 2.0, "Hz", "cycle frequency away from the goal"),
    Field("approach_frequency_hz", float, 1.0, 0.1, 2.0, "Hz", "cycle frequency within approach_distance_m"),
    Field("approach_distance_m", float, 0.2, 0.0, 5.0, "m",
          "closer than this the gait slows to approach_frequency_hz and a rolling direction is held a whole cycle"),
    Field("fine_distance_m", float, 0.35, 0.0, 5.0, "m",
          "the fine approach: at rest within this distance of the last goal, the robot creeps at fine_amplitude_bar "
          "along the line square to its body when the goal lies on it (else moves along its axis onto the line, or "
          "turns on the spot toward it) and stops at the next stop phase; the cruise gait also stops where it will "
          "rest on the goal's line; 0: off"),
    Field("fine_amplitude_bar", float, 1.5, 0.5, 4.0, "bar",
          "first amplitude of the fine approach: just above the muscles' deadzone the body bends little, so it "
          "rests within a few cm of where it stopped (at 4 bar: 10-35 cm); set it above your robot's deadzone (the "
          "calibrated simulation's is 1.35 bar). A creep seen to move the robot under 4 cm in a whole cycle goes "
          "on 0.5 bar higher for the rest of the run, at most 1 bar over this and never over amplitude_bar"),
    Field("fine_frequency_hz", float, 0.25, 0.1, 2.0, "Hz",
          "cycle frequency of the fine approach (slow: the 1 s ramp-out is a quarter cycle of roll-on)"),
    Field("axis_move_max_cycles", int, 3, 0, 10, "cycles",
          "the fine approach: at rest near the goal but off the creeping line, move along the body's axis first (the "
          "straight serpentine, forward or backward, up to this many cycles at amplitude_bar and "
          "cruise_frequency_hz; learned per floor and given up where it does not move the body); 0: off"),
    Field("pursuit_gain", float, 1.5, 0.2, 5.0, "",
          "turn rate asked = this x the rate of the arc through the goal (pure pursuit)"),
    Field("max_turn_rate_deg_per_cycle", float, 30.0, 1.0, 180.0, "deg per cycle", "largest turn rate asked"),
    Field("turn_levels_rad", list, (-0.5, -0.35, -0.2, 0.0, 0.2, 0.35, 0.5), -0.6, 0.6, "rad",
          "the turn_phase_rad values the controller chooses from", item=float, nonempty=True),
    Field("min_hold_cycles", float, 0.5, 0.0, 10.0, "cycles",
          "a gait direction or turn level is kept at least this long"),
    Field("reach_margin", float, 1.3, 1.0, 5.0, "",
          "a goal closer to the side than the tightest turn can reach (times this) is first backed away from"),
    Field("direction_hysteresis_rad", float, 0.35, 0.0, 1.5, "rad",
          "the other rolling direction is taken when its heading error is smaller by this much"),
    Field("learning_rate", float, 0.5, 0.0, 1.0, "",
          "weight of a new per-cycle measurement in the online turn-rate and travel-direction estimates"),
    Field("settle_s", float, 1.5, 0.0, 30.0, "s",
          "after a stop near the goal, wait this long for the robot to rest before checking the tolerance "
          "(a creep's stop ends sooner, once the pose is seen at rest)"),
    Field("stop_cycle_ahead", bool, True,
          description="stop one cycle ahead at a set gait phase (the gait player ramps out as it passes the phase, "
                      "however late the stop arrived); false: ramp out at once as the gait passes the phase"),
    Field("stall_timeout_s", float, 60.0, 1.0, 3600.0, "s",
          "the distance to go has not shrunk by stall_distance_m for this long: stop, state failed"),
    Field("stall_distance_m", float, 0.03, 0.001, 1.0, "m", "progress that resets the stall timer"),
    Field("turning_map_file", str, DEFAULT_TURNING_MAP_FILE,
          description="the identified turn rates (srs_turning --write-map); relative: the working directory, "
                      "then the package's config/"),
), description="a mapping of navigation setting: value")


@dataclass(frozen=True)
class DirectionMap:
    """Turn rate (deg per cycle, counter-clockwise positive, seen from above) and travel per cycle vs turn_phase_rad."""

    turn_phase_rad: np.ndarray
    turn_rate_deg_per_cycle: np.ndarray
    travel_m_per_cycle: np.ndarray
    #: Where the robot rests after a stop at each of :data:`STOP_PHASES` (rows), from where the stop was
    #: commanded: (along, across) its travel (m); shape (phases, 2) for every turn level, or
    #: (turn levels, phases, 2), one block per ``turn_phase_rad`` (a turning body rolls on elsewhere: in
    #: config/turning_map.yaml inward rolling rests 5-10 cm to the left of its travel at -0.5 rad, 9-18 cm to the
    #: right at +0.5 rad).
    stop_offset_m: np.ndarray = dataclasses.field(
        default_factory=lambda: np.reshape(DEFAULT_STOP_OFFSET_M, (len(STOP_PHASES), 2)))

    def stop_offset_at(self, turn_phase_rad) -> np.ndarray:
        """The rest offsets (levels, phases, 2) at each of ``turn_phase_rad`` (linear between mapped levels)."""
        levels = np.atleast_1d(np.asarray(turn_phase_rad, dtype=np.float64))
        offsets = np.asarray(self.stop_offset_m, dtype=np.float64)
        if offsets.ndim == 2:
            return np.repeat(offsets[None], len(levels), axis=0)
        flat = offsets.reshape(len(self.turn_phase_rad), -1)
        columns = [np.interp(levels, self.turn_phase_rad, flat[:, j]) for j in range(flat.shape[1])]
        return np.stack(columns, axis=1).reshape(len(levels), *offsets.shape[1:])

    def rate_at(self, turn_phase_rad) -> np.ndarray:
        """The mapped turn rate (deg per cycle) at ``turn_phase_rad`` (linear between points, flat outside)."""
        return np.interp(turn_phase_rad, self.turn_phase_rad, self.turn_rate_deg_per_cycle)

    def travel_at(self, turn_phase_rad) -> np.ndarray:
        """The mapped travel per cycle (m) at ``turn_phase_rad``."""
        return np.interp(turn_phase_rad, self.turn_phase_rad, self.travel_m_per_cycle)


@dataclass(frozen=True)
class TurningMap:
    """Per rolling direction, what ``turn_phase_rad`` did on the robot (``config/turning_map.yaml``)."""

    amplitude_bar: float
    frequency_hz: float
    conditions: str
    directions: dict[str, DirectionMap]
    source: str = "<memory>"

    def __getitem__(self, direction: str) -> DirectionMap:
        return self.directions[direction]


_MAP_TABLE = Table("turning_map", (
    Field("amplitude_bar", float, minimum=0.0, maximum=10.0, unit="bar"),
    Field("frequency_hz", float, minimum=0.0, maximum=10.0, unit="Hz"),
    Field("conditions", str, "", description="where it was measured (physics, friction, command)"),
))
_DIRECTION_TABLE = Table("turning_map.<direction>", (
    Field("turn_phase_rad", list, item=float, minimum=-math.pi, maximum=math.pi, unit="rad", nonempty=True),
    Field("turn_rate_deg_per_cycle", list, item=float, minimum=-360.0, maximum=360.0, unit="deg per cycle",
          nonempty=True),
    Field("travel_m_per_cycle", list, item=float, minimum=0.0, maximum=10.0, unit="m", nonempty=True),
    Field("stop_offset_m", list, DEFAULT_STOP_OFFSET_M, -1.0, 1.0, "m",
          f"rest point after a stop at each gait phase {list(STOP_PHASES)}: along, across the travel, in turn; "
          f"{2 * len(STOP_PHASES)} values for every turn level, or that many per turn_phase_rad, one after the other",
          item=float, nonempty=True),
))


#: Every key of the turning_map block.
_MAP_KEYS = (*_MAP_TABLE.names, *DIRECTIONS)


def turning_map_from_dict(data: Any, source: str = "<dict>") -> TurningMap:
    """Validate a parsed turning map (its top-level ``turning_map:`` key) into a :class:`TurningMap`."""
    block = document(data, "turning_map", source, what="a mapping with amplitude_bar, frequency_hz and one block "
                                                       f"per direction {list(DIRECTIONS)}",
                     sections=_MAP_KEYS)
    check_known(block, _MAP_KEYS, source, "turning_map")
    head = _MAP_TABLE.read({k: v for k, v in block.items() if k in _MAP_TABLE}, source)
    directions = {}
    for direction in DIRECTIONS:
        table = _DIRECTION_TABLE.at(f"turning_map.{direction}")
        values = table.read(section(block, direction, source, "turning_map"), source)
        phases = np.asarray(values["turn_phase_rad"], dtype=np.float64)
        if np.any(np.diff(phases) <= 0.0):
            raise refusal(source, table.key("turn_phase_rad"), list(values["turn_phase_rad"]), "increasing values")
        for name in ("turn_rate_deg_per_cycle", "travel_m_per_cycle"):
            if len(values[name]) != len(phases):
                raise refusal(source, table.key(name), list(values[name]),
                              f"{len(phases)} values, one per turn_phase_rad")
        per_level = 2 * len(STOP_PHASES)
        stops = list(values["stop_offset_m"])
        if len(stops) not in (per_level, per_level * len(phases)):
            raise refusal(source, table.key("stop_offset_m"), stops,
                          f"{per_level} values (every turn level) or {per_level * len(phases)} "
                          f"({per_level} per turn_phase_rad)")
        shape = (len(STOP_PHASES), 2) if len(stops) == per_level else (len(phases), len(STOP_PHASES), 2)
        directions[direction] = DirectionMap(phases, np.asarray(values["turn_rate_deg_per_cycle"], dtype=np.float64),
                                             np.asarray(values["travel_m_per_cycle"], dtype=np.float64),
                                             np.reshape(stops, shape))
    return TurningMap(head["amplitude_bar"], head["frequency_hz"], head["conditions"], directions, source)


def load_turning_map(path: str | Path | None = None) -> TurningMap:
    """Read ``config/turning_map.yaml`` (or ``path``: the working directory, then the package's config/)."""
    resolved = config_file(path or DEFAULT_TURNING_MAP_FILE)
    return turning_map_from_dict(read_yaml(resolved), str(resolved))


@dataclass(frozen=True)
class NavigationSettings:
    """Every setting of :data:`NAVIGATION_TABLE` (see its fields for units and meaning) and the turn map."""

    goal_tolerance_m: float
    waypoint_tolerance_m: float
    pose_timeout_s: float
    view_margin_m: float
    edge_guard_m: float
    amplitude_bar: float
    cruise_frequency_hz: float
    approach_frequency_hz: float
    approach_distance_m: float
    fine_distance_m: float
    fine_amplitude_bar: float
    fine_frequency_hz: float
    axis_move_max_cycles: int
    pursuit_gain: float
    max_turn_rate_deg_per_cycle: float
    turn_levels_rad: tuple[float, ...]
    min_hold_cycles: float
    reach_margin: float
    direction_hysteresis_rad: float
    learning_rate: float
    settle_s: float
    stop_cycle_ahead: bool
    stall_timeout_s: float
    stall_distance_m: float
    turning_map_file: str
    turning_map: TurningMap

    def values(self) -> dict[str, Any]:
        """The settings of :data:`NAVIGATION_TABLE` as a plain mapping (the turn map left out)."""
        return {f.name: getattr(self, f.name) for f in fields(self) if f.name != "turning_map"}


def load_navigation_settings(overrides: Mapping[str, Any] | None = None, where: str = "navigation settings",
                             turning_map: TurningMap | None = None) -> NavigationSettings:
    """The defaults of :data:`NAVIGATION_TABLE` overlaid with ``overrides``, checked; the turn map loaded.

    Raises :class:`ConfigurationError` naming ``where``, the key, the value and what is expected.
    """
    values = NAVIGATION_TABLE.read(dict(overrides or {}), where)
    levels = values["turn_levels_rad"]
    if list(levels) != sorted(set(levels)):
        raise refusal(where, NAVIGATION_TABLE.key("turn_levels_rad"), list(levels), "increasing values")
    try:
        mapped = turning_map or load_turning_map(values["turning_map_file"])
    except ConfigurationError as exc:
        raise ConfigurationError(f"{exc} Fix the file, or write a new one with `python -m srs_ros.tools.turning_cli "
                                 "--write-map FILE`.") from None
    return NavigationSettings(**values, turning_map=mapped)
