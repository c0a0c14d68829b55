"""How the simulated robot turns: turn rate and travel per cycle against a steering parameter (issue 20).

Every run starts a fresh :class:`~srs_ros.sim.world.SimWorld` at rest and plays the cycle through
:class:`~srs_ros.core.gait.playback.GaitPlayback` with its soft start, exactly as the navigator does
(:class:`srs_ros.sim.navigation.GaitDriver`); outward rolling is the inward cycle played backward. The
yaw (tail -> head, what the camera reports) is read at every cycle boundary; the first ``skip_cycles``
(the soft start and the body settling) are left out. A rolling body's yaw wobbles within a cycle, so
boundaries at the same phase give its turn per cycle. Re-run after any physics change:
``python -m srs_ros.tools.turning_cli`` prints the tables and writes the navigator's turn map.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import yaml

from srs_ros.core.actuation.pressure import lengths_to_pressures_bar
from srs_ros.core.gait.playback import GaitPlayback
from srs_ros.core.gait.trajectory import GaitCycle, generate_cycle
from srs_ros.core.navigation.commands import GaitCommand
from srs_ros.core.navigation.settings import STOP_PHASES, turning_map_from_dict
from srs_ros.core.rig import load_rig
from srs_ros.core.robot import RobotDescription, default_robot
from srs_ros.sim.config import SimConfig, load_sim_config
from srs_ros.sim.navigation import GaitDriver
from srs_ros.sim.world import SimWorld

#: Cycles played and measured by default, and the first ones left out.
DEFAULT_CYCLES = 8
DEFAULT_SKIP_CYCLES = 2
#: Start headings (rad) of the repeated runs: the turn must not depend on where the robot points.
DEFAULT_START_YAWS_RAD = (0.0, 2.0)


@dataclass(frozen=True)
class TurnMeasurement:
    """One run: turn per cycle (deg, counter-clockwise positive; mean and spread over cycles), travel per cycle."""

    label: str
    amplitude_bar: float
    frequency_hz: float
    value: float
    start_yaw_rad: float
    turn_deg_per_cycle: float
    turn_sd_deg: float
    travel_m_per_cycle: float

    @property
    def speed_m_s(self) -> float:
        """Travel per second."""
        return self.travel_m_per_cycle * self.frequency_hz


def play_cycle(cycle: GaitCycle, duration_s: float, config: SimConfig, robot: RobotDescription,
               reverse_at_s: Callable[[float], bool] | None = None, sample_every_s: float = 0.05,
               stop_at_s: float = math.inf, switch_to: tuple[float, GaitCycle] | None = None) -> np.ndarray:
    """Play ``cycle`` from rest with the gait player's soft start; rows ``(t, x_m, y_m, yaw_rad)`` every sample.

    ``reverse_at_s(t)`` says whether the cycle runs backward at ``t`` (default: never); at ``stop_at_s`` the
    player ramps out; ``switch_to`` ``(s, other)``: from ``s`` the player cross-fades to ``other``, as it takes a new
    cycle from trajectory_server (a change of turn level).
    """
    world = SimWorld(config, robot)
    playback = GaitPlayback(max_length_m=robot.max_extension_m)
    playback.load(cycle.lengths_m, cycle.frequency_hz)
    playback.set_reverse(bool(reverse_at_s and reverse_at_s(0.0)))
    playback.start()
    dt = 1.0 / load_rig(robot=robot).command_rate_hz
    every = max(1, int(round(sample_every_s / dt)))
    rows, steps = [], int(round(duration_s / dt))
    for k in range(steps + 1):
        t = k * dt
        if reverse_at_s is not None:
            playback.set_reverse(reverse_at_s(t))
        if t >= stop_at_s - 1e-9 and playback.state.value in ("starting", "running"):
            playback.stop()
        if switch_to is not None and t >= switch_to[0] - 1e-9:
            playback.load(switch_to[1].lengths_m, switch_to[1].frequency_hz)
            switch_to = None
        world.advance_to(t)
        world.command_pressures(lengths_to_pressures_bar(playback.step(dt).positions_m, robot))
        if k % every == 0 or k == steps:  # the end too: at 0.75 Hz the last cycle ended between samples and was lost
            rows.append((t, *world.state(with_contacts=False).pose))
    rows = np.array(rows)
    rows[:, 3] = np.unwrap(rows[:, 3])
    return rows


def per_cycle(rows: np.ndarray, period_s: float, skip_cycles: int) -> tuple[np.ndarray, np.ndarray]:
    """Turn (deg) and travel (m) of every whole cycle after the first ``skip_cycles``."""
    count = int(math.floor(rows[-1, 0] / period_s + 0.01))  # a run ends within a command step of its last cycle
    index = [int(np.argmin(np.abs(rows[:, 0] - k * period_s))) for k in range(skip_cycles, count + 1)]
    turns = np.degrees(np.diff(rows[index, 3]))
    travel = np.linalg.norm(np.diff(rows[index, 1:3], axis=0), axis=1)
    return turns, travel


def measure(label: str, cycle: GaitCycle, value: float, config: SimConfig | None = None,
            robot: RobotDescription | None = None, reverse: bool = False, cycles: int = DEFAULT_CYCLES,
            skip_cycles: int = DEFAULT_SKIP_CYCLES, start_yaw_rad: float = 0.0) -> TurnMeasurement:
    """Play ``cycle`` (backward if ``reverse``) for ``cycles`` cycles from rest and measure its turn and travel."""
    robot = robot or default_robot()
    config = (config or load_sim_config(robot=robot)).replace("start", yaw_rad=float(start_yaw_rad))
    period = 1.0 / cycle.frequency_hz
    rows = play_cycle(cycle, cycles * period, config, robot, (lambda t: True) if reverse else None)
    turns, travel = per_cycle(rows, period, skip_cycles)
    return TurnMeasurement(label, cycle.amplitude_bar, cycle.frequency_hz, float(value), float(start_yaw_rad),
                           float(np.mean(turns)), float(np.std(turns)), float(np.mean(travel)))


def rolling_cycle(amplitude_bar: float, frequency_hz: float, turn_phase_rad: float,
                  robot: RobotDescription | None = None) -> GaitCycle:
    """The navigator's cycle: inward rolling with ``turn_phase_rad`` (outward = played backward)."""
    return generate_cycle("inward_rolling", amplitude_bar, frequency_hz, robot=robot,
                          params={"turn_phase_rad": float(turn_phase_rad)})


def measure_turn_phase(direction: str, amplitude_bar: float, frequency_hz: float, turn_phase_rad: float,
                       config: SimConfig | None = None, robot: RobotDescription | None = None,
                       start_yaws_rad: Sequence[float] = DEFAULT_START_YAWS_RAD, **kwargs) -> list[TurnMeasurement]:
    """The rolling gait ``direction`` with ``turn_phase_rad``, one run per start heading."""
    cycle = rolling_cycle(amplitude_bar, frequency_hz, turn_phase_rad, robot)
    return [measure(direction, cycle, turn_phase_rad, config, robot, direction == "outward_rolling",
                    start_yaw_rad=yaw, **kwargs) for yaw in start_yaws_rad]


def scaled_module_cycle(cycle: GaitCycle, scales: Sequence[float]) -> GaitCycle:
    """``cycle`` with each module's lengths scaled (a bend growing or shrinking along the body); a candidate only."""
    modules = len(scales)
    lengths = (cycle.lengths_m.reshape(len(cycle.lengths_m), modules, -1) *
               np.asarray(scales, dtype=np.float64)[None, :, None]).reshape(cycle.lengths_m.shape)
    return GaitCycle(cycle.gait, cycle.amplitude_bar, cycle.frequency_hz, lengths, cycle.fit_error_mm,
                     cycle.poor_samples, dict(cycle.parameters), cycle.joint_names, cycle.robot)


def cone_scales(taper: float, modules: int = 3) -> tuple[float, ...]:
    """Module bend scales growing linearly tail -> head by ``taper`` (negative: shrinking), the largest 1."""
    xi = np.linspace(-1.0, 1.0, modules)
    scales = 1.0 + 0.5 * taper * xi
    return tuple(float(v) for v in scales / scales.max())


def measure_pivot(turn_phase_inward_rad: float, turn_phase_outward_rad: float, amplitude_bar: float,
                  frequency_hz: float, stroke_cycles: float = 1.0, pairs: int = 5, config: SimConfig | None = None,
                  robot: RobotDescription | None = None) -> tuple[float, float, float]:
    """Alternate inward and outward strokes (a turn in place) as the navigator commands them.

    Returns (turn deg per stroke pair: mean, spread over pairs; drift m per pair). The first pair is left out.
    """
    robot = robot or default_robot()
    config = config or load_sim_config(robot=robot)
    world, driver = SimWorld(config, robot), GaitDriver(robot)
    stroke_s = stroke_cycles / frequency_hz
    levels = {"inward_rolling": turn_phase_inward_rad, "outward_rolling": turn_phase_outward_rad}
    dt = 1.0 / load_rig(robot=robot).command_rate_hz
    rows, last, steps = [], None, int(round((pairs + 1) * 2.0 * stroke_s / dt))
    for k in range(steps + 1):
        t = k * dt
        direction = ("inward_rolling", "outward_rolling")[int(t / stroke_s + 1e-9) % 2]
        command = GaitCommand(direction, levels[direction], amplitude_bar, frequency_hz)
        if command != last:
            driver.apply(command)
            last = command
        world.advance_to(t)
        world.command_pressures(driver.pressures_bar(dt))
        if k % 10 == 0 or k == steps:
            rows.append((t, *world.state(with_contacts=False).pose))
    rows = np.array(rows)
    rows[:, 3] = np.unwrap(rows[:, 3])
    turns, travel = per_cycle(rows, 2.0 * stroke_s, 1)
    return float(np.mean(turns)), float(np.std(turns)), float(np.mean(travel))


@dataclass(frozen=True)
class StopRest:
    """A gait stopped at a time and left to rest: where the robot rested from where the stop was commanded."""

    along_m: float  # along its travel: the direction of the last whole cycle before the stop
    across_m: float  # across it, left positive
    travel_m: float  # that cycle's travel
    turn_rad: float  # that cycle's turn (counter-clockwise positive)


def rest_after_stop(cycle: GaitCycle, stop_s: float, reverse: bool, settle_s: float, config: SimConfig,
                    robot: RobotDescription) -> StopRest:
    """Play ``cycle`` from rest (backward when ``reverse``), stop at ``stop_s``, rest ``settle_s``: the rest point.

    The travel direction is that of the last whole cycle before the stop, as the navigator learns it.
    """
    period = 1.0 / cycle.frequency_hz
    rows = play_cycle(cycle, stop_s + settle_s, config, robot, (lambda t: True) if reverse else None,
                      sample_every_s=0.01, stop_at_s=stop_s)
    at = int(np.argmin(np.abs(rows[:, 0] - stop_s)))
    before = int(np.argmin(np.abs(rows[:, 0] - (stop_s - period))))
    travel = rows[at, 1:3] - rows[before, 1:3]
    heading = math.atan2(travel[1], travel[0])
    moved = rows[-1, 1:3] - rows[at, 1:3]
    return StopRest(float(moved[0] * math.cos(heading) + moved[1] * math.sin(heading)),
                    float(-moved[0] * math.sin(heading) + moved[1] * math.cos(heading)),
                    float(np.linalg.norm(travel)), float(rows[at, 3] - rows[before, 3]))


def measure_stop_offsets(direction: str, amplitude_bar: float, frequency_hz: float, turn_phase_rad: float = 0.0,
                         run_cycles: int = 4, settle_s: float = 2.5, config: SimConfig | None = None,
                         robot: RobotDescription | None = None) -> np.ndarray:
    """Where the robot rests after a stop at each of STOP_PHASES: rows (along, across) its travel (m)."""
    robot = robot or default_robot()
    config = config or load_sim_config(robot=robot)
    cycle = rolling_cycle(amplitude_bar, frequency_hz, turn_phase_rad, robot)
    period = 1.0 / frequency_hz
    inward = direction == "inward_rolling"
    rests = [rest_after_stop(cycle, (run_cycles + (phase if inward else (1.0 - phase) % 1.0)) * period, not inward,
                             settle_s, config, robot) for phase in STOP_PHASES]
    return np.array([(r.along_m, r.across_m) for r in rests])


def measure_serpentine(c_rad_per_unit: float, amplitude_bar: float, frequency_hz: float,
                       config: SimConfig | None = None, robot: RobotDescription | None = None,
                       start_yaws_rad: Sequence[float] = DEFAULT_START_YAWS_RAD, **kwargs) -> list[TurnMeasurement]:
    """The serpentine with its steady turning ``c`` (paper eq. 4), one run per start heading."""
    import warnings

    from srs_ros.core.gait.trajectory import PoorFitWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PoorFitWarning)
        cycle = generate_cycle("serpentine", amplitude_bar, frequency_hz, 32, robot,
                               {"c_rad_per_unit": float(c_rad_per_unit)})
    return [measure("serpentine", cycle, c_rad_per_unit, config, robot, start_yaw_rad=yaw, **kwargs)
            for yaw in start_yaws_rad]


def measure_sidewinding(lateral_rad: float, amplitude_bar: float, frequency_hz: float,
                        config: SimConfig | None = None, robot: RobotDescription | None = None,
                        start_yaws_rad: Sequence[float] = DEFAULT_START_YAWS_RAD, **kwargs) -> list[TurnMeasurement]:
    """Sidewinding with its horizontal wave's amplitude ``lateral_rad`` (negative: mirrored), one run per heading."""
    cycle = generate_cycle("sidewinding", amplitude_bar, frequency_hz, robot=robot,
                           params={"lateral_rad": float(lateral_rad)})
    return [measure("sidewinding", cycle, lateral_rad, config, robot, start_yaw_rad=yaw, **kwargs)
            for yaw in start_yaws_rad]


def turning_map_yaml(rows: dict[str, list[TurnMeasurement]], stops: dict[str, np.ndarray], amplitude_bar: float,
                     frequency_hz: float, conditions: str) -> str:
    """The navigator's turn map (config/turning_map.yaml) from measured runs: means over the start headings."""
    lines = ["# The navigator's first guess of how the robot turns (srs_ros.core.navigation.settings.TurningMap),",
             "# GENERATED by  python -m srs_ros.tools.turning_cli --write-map <this file>  on the simulated robot;",
             "# re-run it after a physics change. The navigator corrects every value online from the camera.",
             "turning_map:", f"  amplitude_bar: {amplitude_bar:g}", f"  frequency_hz: {frequency_hz:g}",
             f"  conditions: {conditions!r}"]
    for direction, runs in rows.items():
        levels = sorted({m.value for m in runs})
        turn = [float(np.mean([m.turn_deg_per_cycle for m in runs if m.value == v])) for v in levels]
        travel = [float(np.mean([m.travel_m_per_cycle for m in runs if m.value == v])) for v in levels]
        lines += [f"  {direction}:", f"    turn_phase_rad: {[round(v, 4) for v in levels]}",
                  f"    turn_rate_deg_per_cycle: {[round(v, 1) for v in turn]}",
                  f"    travel_m_per_cycle: {[round(v, 4) for v in travel]}",
                  f"    stop_offset_m: {[round(float(v), 4) for v in np.ravel(stops[direction])]}"]
    text = "\n".join(lines) + "\n"
    turning_map_from_dict(yaml.safe_load(text), source="the turn map to be written")  # never write what cannot be read
    return text


def table_markdown(runs: Sequence[TurnMeasurement], value_name: str) -> str:
    """Runs grouped by (label, amplitude, frequency, value): turn per cycle (mean, run-to-run spread), travel."""
    groups: dict[tuple, list[TurnMeasurement]] = {}
    for m in runs:
        groups.setdefault((m.label, m.amplitude_bar, m.frequency_hz, m.value), []).append(m)
    lines = [f"| gait | A (bar) | f (Hz) | {value_name} | turn (deg/cycle) | runs differ by (deg/cycle) | "
             "cycle-to-cycle sd (deg) | travel (cm/cycle) | speed (cm/s) |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for (label, amplitude, frequency, value), group in groups.items():
        turns = [m.turn_deg_per_cycle for m in group]
        travel = float(np.mean([m.travel_m_per_cycle for m in group]))
        lines.append(f"| {label} | {amplitude:g} | {frequency:g} | {value:+.2f} | {np.mean(turns):+.1f} | "
                     f"{np.ptp(turns):.1f} | {np.mean([m.turn_sd_deg for m in group]):.1f} | {100 * travel:.1f} | "
                     f"{100 * travel * frequency:.1f} |")
    return "\n".join(lines)
