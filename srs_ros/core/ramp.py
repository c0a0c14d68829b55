"""Ramps shared by the gait player and the hardware node: a raised cosine and the default ramp time.

Whenever output (re)starts it rises from 0 along :func:`smoothstep` over a ramp time, so neither a
setpoint nor a pressure ever steps.
"""

from __future__ import annotations

import math

#: Default soft start/stop time (s) of the gait player, also the hardware node's ramp from 0 bar.
DEFAULT_RAMP_TIME_S = 1.0


def smoothstep(progress: float) -> float:
    """Raised cosine 0 -> 1 over progress 0 -> 1, flat at both ends (no step in value or slope)."""
    u = min(max(progress, 0.0), 1.0)
    return 0.5 - 0.5 * math.cos(math.pi * u)


def ramp_fraction(elapsed_s: float, ramp_time_s: float) -> float:
    """Raised-cosine ramp 0 -> 1 over ``ramp_time_s`` (0 = no ramp), flat at both ends."""
    return 1.0 if ramp_time_s <= 0.0 else smoothstep(elapsed_s / ramp_time_s)
