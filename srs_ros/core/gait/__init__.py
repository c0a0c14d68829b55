"""Gaits as data and their joint-space cycles (paper Sec. III), without ROS.

``library`` (each gait a registered shape function with typed parameters from config/gaits.yaml),
``fitting`` (backbone onto a target curve, paper eq. 3), ``request`` (what a cycle is asked for: gait,
amplitude, frequency, samples, with their ranges and defaults), ``trajectory`` (a gait's fitted cycle, scaled to
a pressure amplitude and timed), ``interpolation`` (periodic splines), ``playback`` (the gait player's logic).
"""

from srs_ros.core import lazy_exports

_EXPORTS = {
    "gait": "library", "gait_spec": "library", "list_gaits": "library", "GaitSpec": "library",
    "GaitParameter": "library", "fit_shapes": "fitting", "FitSettings": "fitting", "FitResult": "fitting",
    "GaitCycle": "trajectory", "generate_cycle": "trajectory", "PeriodicTrajectory": "interpolation",
    "GaitPlayback": "playback", "PlaybackState": "playback", "cycle_from_points": "playback",
    "DEFAULT_GAIT": "request", "FREQUENCY_FIELD": "request", "SAMPLES_FIELD": "request", "gait_field": "request",
}
__all__ = sorted(_EXPORTS)
__getattr__ = lazy_exports(__name__, _EXPORTS)
