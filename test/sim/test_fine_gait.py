"""The navigator's creep (its fine approach's gait) on the simulated robot: where the body rests after a stop.

The fine approach creeps back and forth along a line and stops where it predicts the body to rest on the goal
(srs_ros/core/navigation/fine.py). At the shipped fine amplitude the roll-on after a stop is the same whichever
way the robot creeps; at 2 bar (the default until stop 45) outward rolling rested 7-10 cm farther along than
inward rolling at the same stop phase, and a creep that passed the goal and reversed missed it again
(docs/navigation.md, "A creep just above the deadzone").
"""

import math

import numpy as np
import pytest

from srs_ros.core.navigation import load_navigation_settings
from srs_ros.core.robot import default_robot
from srs_ros.experiments.turning import play_cycle, rolling_cycle
from srs_ros.sim.config import load_sim_config


def rest_after_stop_cm(amplitude_bar: float, frequency_hz: float, outward: bool) -> tuple[float, float]:
    """Rolled 2 cycles from rest, stopped at phase 0, 3 s to rest: (along, across) its travel from the stop (cm)."""
    robot = default_robot()
    config = load_sim_config(robot=robot).replace("contact", friction="isotropic")
    period_s = 1.0 / frequency_hz
    stop_s = 2 * period_s
    rows = play_cycle(rolling_cycle(amplitude_bar, frequency_hz, 0.0, robot), stop_s + 3.0, config, robot,
                      (lambda t: True) if outward else None, sample_every_s=0.01, stop_at_s=stop_s)
    at = int(np.argmin(np.abs(rows[:, 0] - stop_s)))
    before = int(np.argmin(np.abs(rows[:, 0] - (stop_s - period_s))))
    travel = rows[at, 1:3] - rows[before, 1:3]
    heading = math.atan2(travel[1], travel[0])
    rest = rows[-1, 1:3] - rows[at, 1:3]
    return (100 * (rest[0] * math.cos(heading) + rest[1] * math.sin(heading)),
            100 * (-rest[0] * math.sin(heading) + rest[1] * math.cos(heading)))


@pytest.mark.slow(seconds=8)
def test_the_shipped_creep_rests_alike_whichever_way_it_creeps():
    settings = load_navigation_settings()
    inward = rest_after_stop_cm(settings.fine_amplitude_bar, settings.fine_frequency_hz, outward=False)
    outward = rest_after_stop_cm(settings.fine_amplitude_bar, settings.fine_frequency_hz, outward=True)
    print(f"creep at {settings.fine_amplitude_bar:g} bar {settings.fine_frequency_hz:g} Hz, stopped at phase 0, "
          f"rests (along, across) cm: inward {inward[0]:+.1f}, {inward[1]:+.2f}; outward {outward[0]:+.1f}, "
          f"{outward[1]:+.2f}")
    assert abs(inward[0] - outward[0]) < 2.0, (inward, outward)  # 2 bar: -1.5 and +6.6
    assert 0.0 < inward[0] < 6.0 and abs(inward[1]) < 0.3 and abs(outward[1]) < 0.3
