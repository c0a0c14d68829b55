"""Keeping the robot in the camera's view: the controller's edge guard (``edge_guard_m``), mixed into the controller.

Near the edge of the camera's calibrated floor area and seen moving out of it over the last cycle, the cruise gait
rolls back in, or, moving along the edge, turns its travel inward (docs/navigation.md, "Keeping the robot in view";
the study: docs/studies/navigation.md, "The robot stuck along the edge").
"""

from __future__ import annotations

import math

import numpy as np

from srs_ros.core.navigation.commands import GaitCommand
from srs_ros.core.navigation.motion import SETTLE_CYCLES, Pose2D
from srs_ros.core.navigation.settings import other_direction

#: Near the view's edge, the tracked point came at least this much closer to it over the last cycle (m): moving out.
EDGE_APPROACH_M = 0.02
#: Cycles the other direction is played once the robot was seen moving out of view (past its change-over).
EDGE_HOLD_CYCLES = 2.5
#: A robot moving out of view within this angle of the edge's line (deg) moves along the edge: it turns, not reverses.
EDGE_ALONG_DEG = 30.0


class EdgeGuard:
    """The edge guard's decisions, mixed into the controller (its state: ``self._edge_until_s``)."""

    def _keep_in_view(self, pose: Pose2D) -> bool:
        """Near the edge of the camera's floor area and moving out of it: roll the other way; True while it does.

        Judged on the camera's own track (the tracked point came closer to the edge over the last cycle), not on
        the learned travel heading, so it holds however wrong the model is (a physics that rolls the other way
        round, a three-point turn backing out of view); not when the goal lies as near the edge. The cruise gait
        only, once a direction has played past its change-over (:data:`SETTLE_CYCLES`). The other direction, at
        the turn level learned to turn least (the most predictable travel), is played for :data:`EDGE_HOLD_CYCLES`,
        and turned round again if the track shows that it too moves out; then the controller chooses again.
        """
        command, settings = self._command, self.settings
        cruising = command.moving and command.amplitude_bar == settings.amplitude_bar and \
            command.frequency_hz in (settings.cruise_frequency_hz, settings.approach_frequency_hz)
        holding = pose.time_s < self._edge_until_s
        if math.isfinite(self._edge_until_s) and not (holding and cruising and settings.edge_guard_m > 0.0):
            self._edge_until_s, holding = -math.inf, False  # the hold is over, or the guard switched off
            self._message = self._driving_message()
        if self.area is None or settings.edge_guard_m <= 0.0 or not cruising:
            return False
        period_s = 1.0 / command.frequency_hz
        if pose.time_s - self._direction_since_s < (1.0 + SETTLE_CYCLES) * period_s:
            return holding
        inside_m = self.area.leaving_by_m(self.history.window(period_s), settings.edge_guard_m, EDGE_APPROACH_M)
        if inside_m is None or self.area.inside_distance_m(*self.goal) <= inside_m + EDGE_APPROACH_M:
            return holding  # not leaving, or leaving toward a goal that lies as near the edge
        direction, level, action = self._away_from_edge(period_s)
        self._backing_from = None
        self._message = (f"{max(inside_m, 0.0):.2f} m from the edge of the camera's view and moving out of it: "
                         f"{action} ({direction.replace('_', ' ')}) for {EDGE_HOLD_CYCLES:g} cycles")
        self._set_command(pose.time_s, GaitCommand(direction, float(settings.turn_levels_rad[level]),
                                                   settings.amplitude_bar, command.frequency_hz, self._message), level)
        self._edge_until_s = pose.time_s + EDGE_HOLD_CYCLES * period_s
        return True

    def _heads_out_of_view(self, direction: str) -> bool:
        """True when the robot lies within ``edge_guard_m`` of the view's edge and ``direction`` travels out of it.

        Judged on the learned travel heading, before the direction plays: the track-based guard above judges a
        direction only after its change-over and a cycle, and a three-point turn started at rest a few cm from the
        edge backed out of view before that (over DDS the camera then lost the robot: docs/studies/navigation.md,
        "A three-point turn backed out of view").
        """
        last = self.history.window(0.0)
        if self.area is None or self.settings.edge_guard_m <= 0.0 or not len(last):
            return False
        x_m, y_m = float(last[-1, 1]), float(last[-1, 2])
        if self.area.inside_distance_m(x_m, y_m) > self.settings.edge_guard_m:
            return False
        heading = self._travel_heading_rad(direction)
        return float(np.array([math.cos(heading), math.sin(heading)]) @ self.area.inward_normal(x_m, y_m)) < 0.0

    def _away_from_edge(self, period_s: float) -> tuple[str, int, str]:
        """Direction, turn level and what it does, for a robot seen moving out of the view over the last cycle.

        Moving mostly out (the track more than :data:`EDGE_ALONG_DEG` away from the edge's line): the other
        direction, at the level learned to turn least. Moving mostly along the edge (a body whose axis points at
        the edge rolls along it, and rolling the other way only drifts along it too): the same direction, at
        the level learned to turn its travel fastest toward the inside, so the body turns its end off the edge.
        """
        command = self._command
        track = self.history.window(period_s)
        moved = track[-1, 1:3] - track[0, 1:3]
        inward = self.area.inward_normal(track[-1, 1], track[-1, 2])
        out_angle = math.degrees(math.acos(max(-1.0, min(1.0, float(-moved @ inward) / max(np.hypot(*moved), 1e-9)))))
        if out_angle < 90.0 - EDGE_ALONG_DEG:
            direction = other_direction(command.direction)
            return direction, self.turns.choose(direction, 0.0, None), "rolling back"
        sign = 1 if moved[0] * inward[1] - moved[1] * inward[0] > 0.0 else -1  # rotate the travel toward inside
        level, _ = self.turns.fastest_deg(command.direction, sign)
        return command.direction, level, "turning its travel inward"
