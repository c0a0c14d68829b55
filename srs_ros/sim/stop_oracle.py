"""A bound for studies, not a controller: the navigator's cruise with each stop decided by a copy of the world.

The cruise gait (4 bar 1 Hz) rolls on 10-35 cm after a stop, so reaching a goal at cruise speed needs the
resting point predicted to a few cm; the navigator predicts it from offsets learned per direction, turn level
and stop phase (:mod:`srs_ros.core.navigation.stopping`). :func:`run_oracle_navigation` drives the same
controller, but while it cruises near the goal it copies the world and the gait player every few frames, stops
the copy at once and lets it rest: when the copy rests within ``within_m`` of the goal, the real robot is
stopped there. The copy is stepped on the loop's own command grid, so it rests exactly where the robot will. It
answers "how fast could this controller's cruise reach goals if it knew where every stop rests?"
(docs/studies/navigation.md, "Where the time target is lost").
"""

from __future__ import annotations

import copy
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from srs_ros.core.gait.playback import PlaybackState
from srs_ros.core.navigation.commands import NavigationState
from srs_ros.core.navigation.controller import NavigationController
from srs_ros.core.navigation.settings import NavigationSettings
from srs_ros.core.rig import load_rig
from srs_ros.core.robot import default_robot
from srs_ros.sim.config import SimConfig
from srs_ros.sim.navigation import FRESH_WORLD_GAP_S, GaitDriver, GoalOutcome, _Eyes, _Loop, default_area
from srs_ros.sim.world import SimWorld

#: How long a stopped copy is left to rest (s): the 1 s ramp-out and the body straightening.
REST_S = 3.0
#: The copy is tried every this many camera frames while cruising near the goal.
CHECK_EVERY_FRAMES = 3
#: ... within this distance of the goal (m).
CHECK_WITHIN_M = 0.45


@dataclass(frozen=True)
class OracleOutcome:
    """A goal driven with oracle stops: the outcome, and whether an oracle stop ended it."""

    outcome: GoalOutcome
    oracle_stop: bool
    copies: int  # stopped copies simulated for this goal


def rest_if_stopped(world: SimWorld, driver: GaitDriver, next_command_s: float, command_dt_s: float,
                    rest_s: float = REST_S) -> np.ndarray:
    """Where the robot's reference point rests (floor x, y, m) if the gait is stopped before the next command.

    A copy of the world and the driver, stepped as the loop steps them (a command at ``next_command_s`` and every
    ``command_dt_s`` after it) for ``rest_s``; the originals are not touched.
    """
    world, driver = copy.deepcopy(world), copy.deepcopy(driver)
    driver.playback.stop()
    command_s, end_s = next_command_s, world.time_s + rest_s
    while command_s <= end_s:
        world.advance_to(command_s)
        world.command_pressures(driver.pressures_bar(command_dt_s))
        command_s += command_dt_s
    world.advance_to(end_s)
    return world.state(with_contacts=False).reference_xy_m.copy()


class _OracleLoop(_Loop):
    """The navigation loop, with the robot stopped where a stopped copy of it rests within ``within_m``."""

    def __init__(self, *args, within_m: float, **kwargs):
        super().__init__(*args, **kwargs)
        self.within_m = within_m

    def drive_with_oracle(self, goal: tuple[float, float], timeout_s: float) -> OracleOutcome:
        start = self.world.state(with_contacts=False)
        start_xy, t0 = (float(start.reference_xy_m[0]), float(start.reference_xy_m[1])), self._clock(start)
        nav, frames, copies, stopped_s = self.controller, 0, 0, None
        nav.set_path([goal], t0)
        while True:
            state = self._frame(None, None)
            now, frames = self._clock(state), frames + 1
            if stopped_s is None and self._cruising() and frames % CHECK_EVERY_FRAMES == 0 and \
                    math.dist(state.reference_xy_m, goal) < CHECK_WITHIN_M:
                copies += 1
                rest = rest_if_stopped(self.world, self.driver, self._next_command_s, self.command_dt_s)
                if math.dist(rest, goal) <= self.within_m:
                    stopped_s = now
                    nav.cancel(now, "stopped by the oracle: a copy stopped here rested on the goal")
                    self.driver.playback.stop()
            if stopped_s is not None and now >= stopped_s + REST_S:
                break
            if stopped_s is None and not nav.state.active and self.driver.playback.state is PlaybackState.IDLE:
                break
            if now - t0 > timeout_s and nav.state.active:
                nav.cancel(now, f"gave up after {timeout_s:g} s (simulated)")
        error = float(math.dist(goal, state.reference_xy_m))
        if stopped_s is not None:  # as the controller would report it: settle_s after the stop
            state_, message = NavigationState.REACHED, "stopped by the oracle"
            elapsed = stopped_s + nav.settings.settle_s - t0
        else:
            state_, message, elapsed = nav.state, nav.progress(now).message, now - t0
        return OracleOutcome(GoalOutcome(goal, start_xy, state_, message, elapsed, error, math.nan),
                             stopped_s is not None, copies)

    def _cruising(self) -> bool:
        nav, command = self.controller, self.controller.command
        return (nav.state is NavigationState.DRIVING and command.moving and not command.along_axis
                and command.amplitude_bar == nav.settings.amplitude_bar and not nav.fine.pivot_sense)


def run_oracle_navigation(goals: Sequence[Sequence[float]], config: SimConfig, settings: NavigationSettings,
                          within_m: float, goal_timeout_s: float = 60.0) -> list[OracleOutcome]:
    """Each goal from the start on a fresh world (one controller kept, as ``run_navigation(from_start=True)``).

    ``within_m``: stop where a stopped copy rests this close to the goal (m). Path lengths are not measured (nan).
    """
    robot = default_robot()
    controller = NavigationController(settings, default_area(config, settings))
    eyes, rate_hz, clock_s, out = _Eyes(config, False, False), load_rig(robot=robot).command_rate_hz, 0.0, []
    for goal in goals:
        loop = _OracleLoop(SimWorld(config, robot), GaitDriver(robot), eyes, controller, rate_hz, clock_s,
                           within_m=within_m)
        out.append(loop.drive_with_oracle((float(goal[0]), float(goal[1])), goal_timeout_s))
        clock_s = loop.clock_offset_s + loop.world.time_s + FRESH_WORLD_GAP_S
    return out
