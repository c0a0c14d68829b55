"""One offline experiment on the simulated robot, measured like the paper's Table I (Sec. IV).

:func:`run_experiment` fits the gait's joint-space cycle (:func:`srs_ros.core.gait.trajectory.generate_cycle`),
samples its pressures ``P = 100 l`` at the command rate, sends them to a fresh :class:`SimWorld` and
records the tracked reference point at the camera's frame rate and at the run's end. The traveling velocity is
the paper's: X and Y displacement of the reference point divided by the run time, in cm/s, floor frame
(:func:`srs_ros.core.vision.tracking.traveling_velocity`). The run starts from rest with the cycle at phase 0
and is deterministic for a given configuration. A sweep calls this function once per run.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from srs_ros.core.actuation.pressure import lengths_to_pressures_bar
from srs_ros.core.errors import InvalidInputError
from srs_ros.core.gait.request import MAX_RUN_S, SAMPLES_FIELD
from srs_ros.core.gait.trajectory import GaitCycle, generate_cycle
from srs_ros.core.rig import load_rig
from srs_ros.core.robot import RobotDescription, default_robot
from srs_ros.core.vision.tracking import TravelingVelocity, traveling_velocity
from srs_ros.sim.config import SimConfig, load_sim_config
from srs_ros.sim.world import SimState, SimWorld

#: Frame rate of the recorded track (the overhead camera's, Hz).
DEFAULT_RECORD_RATE_HZ = 30.0


@dataclass(frozen=True)
class ExperimentResult:
    """One run: the track of the reference point, its traveling velocity and how the run went.

    ``track`` is ``(n, 4)``: ``time_s, x_m, y_m, yaw_rad`` (floor frame), one row per recorded frame.
    ``peak_target_bend_rad`` / ``peak_body_bend_rad``: the largest total bending angle (sum over the
    modules) that the kinematic model gave for the muscles' lengths / that the simulated body reached.
    """

    gait: str
    amplitude_bar: float
    frequency_hz: float
    duration_s: float
    friction: str
    track: np.ndarray
    velocity: TravelingVelocity
    wall_time_s: float
    peak_target_bend_rad: float
    peak_body_bend_rad: float
    final_state: SimState

    @property
    def realtime_factor(self) -> float:
        """Simulated seconds per wall-clock second."""
        return self.duration_s / self.wall_time_s if self.wall_time_s > 0 else math.inf

    def summary(self) -> str:
        """Lines for people: velocity as Table I prints it, signed displacement, bend, speed of the run."""
        v = self.velocity
        return (f"{self.gait}, {self.amplitude_bar:g} bar, {self.frequency_hz:g} Hz, {self.duration_s:g} s, "
                f"{self.friction}\n"
                f"traveling velocity v_x / v_y: {v.vx_cm_s:+.2f} / {v.vy_cm_s:+.2f} cm/s "
                f"(Table I magnitudes {v.table_text()}, net {v.speed_cm_s:.2f} cm/s)\n"
                f"displacement: x {100 * v.displacement_x_m:+.2f} cm, y {100 * v.displacement_y_m:+.2f} cm "
                f"over {v.duration_s:.2f} s\n"
                f"largest bend (sum of the modules): commanded {math.degrees(self.peak_target_bend_rad):.0f} deg, "
                f"simulated body {math.degrees(self.peak_body_bend_rad):.0f} deg\n"
                f"real-time factor: {self.realtime_factor:.1f}x ({self.wall_time_s:.2f} s wall clock)")


def check_record_rate(record_rate_hz: float, config: SimConfig, name: str = "record_rate_hz") -> None:
    """Refuse a record rate that is not a number > 0 or is above the physics' rate (InvalidInputError).

    Above ``1 / time_step_s`` frames repeat the same step (a CSV of pairs of equal times); a rate of 1e12 Hz asked
    for a 109 TiB array (a helper's review).
    """
    limit_hz = 1.0 / config.physics.time_step_s
    value = record_rate_hz
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value) and value > 0):
        raise InvalidInputError(f"{name}: expected a number > 0, got {value!r}.")
    if value > limit_hz * (1 + 1e-9):
        raise InvalidInputError(f"{name}: {value:g} Hz is above the physics' rate, {limit_hz:g} Hz (1 / "
                                f"sim.physics.time_step_s): no state changes between its frames; use at most that.")


def command_pressures_bar(cycle: GaitCycle, times_s: np.ndarray) -> np.ndarray:
    """The cycle's commanded pressures ``(n, 9)`` (bar, through the one clamp) at ``times_s`` (phase ``f t``)."""
    return lengths_to_pressures_bar(cycle.lengths_at(np.asarray(times_s) * cycle.frequency_hz), cycle.robot)


def run_experiment(gait: str, amplitude_bar: float, frequency_hz: float, duration_s: float,
                   config: SimConfig | None = None, robot: RobotDescription | None = None,
                   command_rate_hz: float | None = None, record_rate_hz: float = DEFAULT_RECORD_RATE_HZ,
                   samples: int = SAMPLES_FIELD.default, gait_params: Mapping[str, Any] | None = None,
                   end_window_s: float = 0.0,
                   on_frame: Callable[[SimState], None] | None = None,
                   progress: Callable[[float, float], None] | None = None,
                   cycle: GaitCycle | None = None) -> ExperimentResult:
    """Run ``gait`` at ``amplitude_bar`` and ``frequency_hz`` for ``duration_s`` on a fresh simulated robot.

    ``command_rate_hz`` defaults to the default rig's (``config/rigs/mock.yaml``); ``on_frame(state)`` is
    called at every recorded frame (e.g. to render video); ``progress(sim_s, duration_s)`` about once a
    simulated second. ``cycle`` skips the fit (it must match the gait, amplitude and frequency). Raises
    :class:`InvalidInputError` for bad arguments and :class:`~srs_ros.core.errors.SimulationError` if
    the physics diverges.
    """
    robot = robot or default_robot()
    config = config or load_sim_config(robot=robot)
    if isinstance(duration_s, bool) or not isinstance(duration_s, (int, float)) or not (
            math.isfinite(duration_s) and duration_s > 0):
        raise InvalidInputError(f"duration_s: expected a number > 0, got {duration_s!r}.")
    check_record_rate(record_rate_hz, config)
    if duration_s > MAX_RUN_S:
        raise InvalidInputError(f"duration_s: {duration_s:g} s is longer than a run may be ({MAX_RUN_S:g} s: its "
                                "commands and record are held in memory); run it in parts.")
    rate = float(command_rate_hz) if command_rate_hz is not None else load_rig(robot=robot).command_rate_hz
    if not (math.isfinite(rate) and rate > 0):
        raise InvalidInputError(f"command_rate_hz: expected a rate > 0 Hz, got {command_rate_hz!r}.")
    cycle = cycle or generate_cycle(gait, amplitude_bar, frequency_hz, samples, robot, gait_params)

    started = time.perf_counter()
    world = SimWorld(config, robot)
    command_count = int(math.floor(duration_s * rate + 1e-9)) + 1
    pressures = command_pressures_bar(cycle, np.arange(command_count) / rate)
    record_times_s = np.arange(int(math.floor(duration_s * record_rate_hz + 1e-9)) + 1) / record_rate_hz
    if record_times_s[-1] < duration_s - 1e-9:  # the rate does not divide the run: its end is recorded too
        record_times_s = np.append(record_times_s, float(duration_s))
    record_count = len(record_times_s)
    rows = np.empty((record_count, 4))
    peak_target = peak_body = 0.0
    next_command = next_record = 0
    next_progress_s = 1.0
    while next_record < record_count:
        t_command = next_command / rate if next_command < command_count else math.inf
        t_record = record_times_s[next_record]
        now = min(t_command, t_record)
        world.advance_to(now)
        if t_command <= now:
            world.command_pressures(pressures[next_command])
            next_command += 1
        if t_record <= now:
            if on_frame is not None:
                on_frame(world.state())
            pose, target, body = world.track_sample()
            rows[next_record] = (world.time_s, *pose)
            peak_target, peak_body = max(peak_target, target), max(peak_body, body)
            next_record += 1
        if progress is not None and now >= next_progress_s:
            progress(now, float(duration_s))
            next_progress_s += 1.0
    final_state = world.state()
    wall = time.perf_counter() - started
    velocity = traveling_velocity(rows[:, 0], rows[:, 1], rows[:, 2], end_window_s)
    return ExperimentResult(gait=cycle.gait, amplitude_bar=float(amplitude_bar), frequency_hz=float(frequency_hz),
                            duration_s=float(duration_s), friction=config.contact.describe(), track=rows,
                            velocity=velocity, wall_time_s=wall, peak_target_bend_rad=peak_target,
                            peak_body_bend_rad=peak_body, final_state=final_state)
