"""Kinematic stand-ins of the rolling robot for the navigation controller's tests (fast, no physics).

:class:`Roller` rolls across its body axis, turns at rates that are NOT those of the controller's turn map
(:data:`MAP`: by default 30 % less gain, biased by 6-8 deg per cycle), rests after a stop at a phase-dependent
offset 1-2 cm off the map's guess, and reports the gait phase. :class:`AmplitudeRoller` is made amplitude-aware as
the physics is (measured at 2 bar 0.25 Hz, docs/studies/navigation.md): at the fine amplitude it rolls square to its
body, hardly turns and rests 2 cm past where it stopped; at 4 bar it rests 12-20 cm ahead against the map's 5 cm.
:class:`AxisRoller` also moves along its axis by the serpentine. :func:`drive` and :func:`drive_to` play the loop
a navigator node plays: gait phase and pose in, a tick, the command to the stand-in, every 1/30 s; :func:`run` drives
one of :data:`GOALS` with the default settings (or the fine approach at another reach).
"""

import math

import numpy as np

from srs_ros.core.navigation import FloorArea, NavigationController, Pose2D, load_navigation_settings
from srs_ros.core.navigation.settings import DIRECTIONS, STOP_PHASES, DirectionMap, TurningMap

LEVELS = np.array([-0.5, -0.35, -0.2, 0.0, 0.2, 0.35, 0.5])
#: The map the controller is given: symmetric, +-20 deg per cycle.
MAP = TurningMap(4.0, 1.0, "test", {
    d: DirectionMap(LEVELS, -40.0 * LEVELS, np.full(len(LEVELS), 0.09),
                    np.tile([0.05, 0.0], (len(STOP_PHASES), 1))) for d in DIRECTIONS})
AREA = FloorArea(np.array([[-1.4, -1.0], [1.4, -1.0], [1.4, 1.0], [-1.4, 1.0]]), 0.25, "test area")
FRAME_S = 1.0 / 30.0


class Roller:
    """A kinematic rolling robot: travels across its yaw, turns per level (its own rates), rests after a stop."""

    def __init__(self, bias_deg=6.0, scale=0.7, rest_m=(0.06, 0.07, 0.04, 0.05), travel_sign=1.0, axis_step_m=0.0,
                 turn_deg=None):
        self.x = self.y = self.yaw = self.phase = 0.0
        self.turn_deg = turn_deg  # (direction, turn_phase_rad) -> deg per cycle, instead of bias_deg and scale
        self.axis_step_m = axis_step_m  # per cycle of the serpentine, along the yaw (0: an isotropic floor)
        self.travel_sign = travel_sign  # -1: rolls the other way round (inward to the right of its yaw)
        self.bias_deg, self.scale, self.rest_m = bias_deg, scale, rest_m
        self.travel_m_per_cycle = 0.09
        self.rest: tuple[float, np.ndarray] | None = None
        self._moving = None  # the last moving command

    def step(self, command, now_s: float) -> None:
        if not command.moving and command.stop_phase is not None and self.rest is None and self._moving is not None:
            before = self.phase  # a stop at a phase: the gait plays on until it passes the phase
            self._roll(self._moving)
            step = (before - self.phase) % 1.0 if self._moving.reverse else (self.phase - before) % 1.0
            if 0.0 < (command.stop_phase - before if not self._moving.reverse else before - command.stop_phase) % 1.0 \
                    <= step:
                self._moving = None
            return
        if not command.moving:
            if self.rest is None and hasattr(self, "_heading"):
                rest_m = np.interp(self.phase, [*STOP_PHASES, 1.0], [*self.rest_m, self.rest_m[0]])  # by phase
                offset = getattr(self, "rest_scale", 1.0) * rest_m * np.array([math.cos(self._heading),
                                                                                math.sin(self._heading)])
                self.rest = (now_s + 0.8, np.array([self.x, self.y]) + offset)
            if self.rest is not None and now_s >= self.rest[0]:
                self.x, self.y = self.rest[1]
            return
        self.rest = None
        self._moving = command
        self._roll(command)

    def _roll(self, command) -> None:
        if command.along_axis:  # the serpentine: along the body's axis, no turn, no rest offset
            step = self.axis_step_m * command.frequency_hz * FRAME_S * (-1.0 if command.reverse else 1.0)
            self.x, self.y = self.x + step * math.cos(self.yaw), self.y + step * math.sin(self.yaw)
            self.phase = (self.phase + (-1.0 if command.reverse else 1.0) * command.frequency_hz * FRAME_S) % 1.0
            self._heading = self.yaw + (math.pi if command.reverse else 0.0)
            self.rest_scale = 0.0
            return
        self.rest_scale = 1.0
        sign = 1.0 if command.direction == "inward_rolling" else -1.0
        rate_deg = self.scale * (-40.0 * command.turn_phase_rad) + self.bias_deg if self.turn_deg is None else \
            self.turn_deg(command.direction, command.turn_phase_rad)
        self.yaw += math.radians(rate_deg) * command.frequency_hz * FRAME_S
        self._heading = self.yaw + sign * self.travel_sign * math.pi / 2
        travel = self.travel_m_per_cycle * command.frequency_hz * FRAME_S
        self.x += travel * math.cos(self._heading)
        self.y += travel * math.sin(self._heading)
        self.phase = (self.phase + sign * command.frequency_hz * FRAME_S) % 1.0

    def moving_or_settling(self, now_s: float) -> bool:
        return self._moving is not None or (self.rest is not None and now_s < self.rest[0])

    def pose(self, now_s: float) -> Pose2D:
        return Pose2D(self.x, self.y, self.yaw, now_s)


def settings(**overrides):
    return load_navigation_settings(overrides, turning_map=MAP)


def drive(controller, roller, until_s, start_s=0.0, lost_after_s=math.inf, each_frame=None, until_at_rest=False):
    """Drive until ``until_s`` or the controller stops; ``each_frame(now)`` after every frame.

    ``until_at_rest``: once the controller stops, drive on until the stand-in has landed on its resting point too.
    """
    now = start_s
    while now < until_s:
        controller.update_gait_phase(roller.phase)
        if now < lost_after_s:
            controller.update_pose(roller.pose(now))
        command = controller.tick(now)
        roller.step(command, now)
        if each_frame is not None:
            each_frame(now)
        now += FRAME_S
        if not controller.state.active and (not roller.moving_or_settling(now) if until_at_rest else
                                            now > start_s + 0.1):
            break
    return now


#: Where the 4-bar stand-in rests after a stop, per stop phase (m ahead): far from the map's 5 cm.
FAR_REST_M = (0.12, 0.20, 0.15, 0.18)
FINE_REST_M = 0.02


class AmplitudeRoller(Roller):
    """Roller whose gait at <= 2.5 bar bends little: 5 % of the turn, rests FINE_REST_M past the stop."""

    def __init__(self):
        super().__init__(rest_m=FAR_REST_M)
        self._far = FAR_REST_M

    def step(self, command, now_s):
        if command.moving:
            fine = command.amplitude_bar <= 2.5
            self.scale, self.bias_deg = (0.035, 0.3) if fine else (0.7, 6.0)
            self.rest_m = (FINE_REST_M,) * 4 if fine else self._far
        super().step(command, now_s)


class AxisRoller(AmplitudeRoller):
    """AmplitudeRoller on a floor where the straight serpentine moves the body along its axis (``axis_step_m`` per
    cycle, forward along its yaw: the anisotropic floor, about 4 cm; 0: an isotropic floor)."""

    def __init__(self, axis_step_m):
        super().__init__()
        self.axis_step_m = axis_step_m


def drive_to(controller, roller, goal, start_s=0.0, until_s=120.0):
    """Drive to ``goal`` until the stand-in rests; the commands played (moving ones) and the time it ended."""
    controller.set_goal(*goal, now_s=start_s)
    played = []

    def each_frame(_now):
        if controller.command.moving:
            played.append(controller.command)

    return played, drive(controller, roller, start_s + until_s, start_s, each_frame=each_frame, until_at_rest=True)


def run(fine_distance_m, goal, until_s=120.0, roller=None):
    """Drive to ``goal`` until the stand-in rests: the controller, the stand-in and the amplitudes played."""
    overrides = {} if fine_distance_m is None else {"fine_distance_m": fine_distance_m}  # None: the default
    settings = load_navigation_settings(overrides, turning_map=MAP)
    controller, roller = NavigationController(settings, AREA), roller or AmplitudeRoller()
    played, _ = drive_to(controller, roller, goal, until_s=until_s)
    return controller, roller, {command.amplitude_bar for command in played}


#: Goals in three directions from the start, for the fine approach's tests.
GOALS = [(0.0, 0.6), (0.5, 0.5), (-0.3, -0.6)]
