"""The navigator's creep (its fine approach's gait) on the simulated robot: where the body rests after a stop.

The fine approach creeps back and forth along a line and stops where it predicts the body to rest on the goal
(srs_ros/core/navigation/fine.py). At the shipped fine amplitude the roll-on after a stop is the same whichever
way the robot creeps; at 2 bar (the default until stop 45) outward rolling rested 7-10 cm farther along than
inward rolling at the same stop phase, and a creep that passed the goal and reversed missed it again
(docs/studies/navigation.md, "A creep just above the deadzone").
"""

import pytest

from srs_ros.core.navigation import load_navigation_settings
from srs_ros.core.robot import default_robot
from srs_ros.experiments.turning import rest_after_stop, rolling_cycle
from srs_ros.sim.config import load_sim_config


def rest_after_stop_cm(amplitude_bar: float, frequency_hz: float, outward: bool) -> tuple[float, float]:
    """Rolled 2 cycles from rest, stopped at phase 0, 3 s to rest: (along, across) its travel from the stop (cm)."""
    robot = default_robot()
    config = load_sim_config(robot=robot).replace("contact", friction="isotropic")
    rest = rest_after_stop(rolling_cycle(amplitude_bar, frequency_hz, 0.0, robot), 2.0 / frequency_hz, outward, 3.0,
                           config, robot)
    return 100 * rest.along_m, 100 * rest.across_m


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
