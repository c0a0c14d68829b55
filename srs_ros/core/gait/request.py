"""What a gait cycle is asked for: the gait, its pressure amplitude, its frequency and its samples per cycle.

Fields of the schema (:mod:`srs_ros.core.schema`), written once with their ranges, units and defaults:
:func:`~srs_ros.core.gait.trajectory.generate_cycle` checks its arguments with them, the trajectory
server declares its parameters from them, ``srs_bringup`` and ``launch/srs.launch.py`` take their
defaults from them, and the sweep grid and measured tables their ranges. Light on purpose (no SciPy):
the launch file imports it inside ``ros2 launch``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable

from srs_ros.core.robot import CYCLE_FREQUENCY_RANGE_HZ, amplitude_field
from srs_ros.core.schema import Field

__all__ = ["DEFAULT_GAIT", "FREQUENCY_FIELD", "MIN_SAMPLES", "SAMPLES_FIELD", "amplitude_field", "any_samples",
           "gait_field"]

#: The gait streamed when none is named.
DEFAULT_GAIT = "inward_rolling"
#: Fewest samples per cycle accepted (the periodic spline and the fit's warm starts need a few).
MIN_SAMPLES = 8
#: Most samples per cycle a trajectory_server parameter accepts (a remote request cannot ask for hours of fitting).
MAX_SERVED_SAMPLES = 1024

#: Cycle frequency (Hz): the paper plays 0.25-1 Hz.
FREQUENCY_FIELD = Field("frequency_hz", float, 1.0, *CYCLE_FREQUENCY_RANGE_HZ, unit="Hz",
                        description="cycle frequency")
#: Shapes fitted per cycle.
SAMPLES_FIELD = Field("samples", int, 64, MIN_SAMPLES, MAX_SERVED_SAMPLES, unit="samples per cycle",
                      description="shapes fitted per cycle")


def gait_field(gait_names: Iterable[str]) -> Field:
    """The gait, one of ``gait_names`` (default :data:`DEFAULT_GAIT`, else the first name)."""
    names = tuple(sorted(gait_names))
    return Field("gait", str, DEFAULT_GAIT if DEFAULT_GAIT in names else names[0], choices=names,
                 description="gait to fit")


#: Longest run of a gait an experiment may ask for (s): one hour. A simulated run holds all its commands and its
#: record in memory (1e12 s asked for petabytes); the paper's runs are 15 s.
MAX_RUN_S = 3600.0
#: Most samples per cycle a local caller may ask for (srs_trajectory, the library): 1e8 ended in a MemoryError, and
#: so did 20 000 rolling samples with 16 GB (their dense target curves take 48 kB a sample, several times over; a
#: review). 10 000 took 2.8 GB and 31 s.
MAX_LOCAL_SAMPLES = 10_000


def any_samples() -> Field:
    """:data:`SAMPLES_FIELD` with the local top (:data:`MAX_LOCAL_SAMPLES`), above what a remote request may ask."""
    return dataclasses.replace(SAMPLES_FIELD, maximum=MAX_LOCAL_SAMPLES)
