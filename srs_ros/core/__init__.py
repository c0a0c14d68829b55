"""Pure-Python core of srs_ros (no ROS imports), by domain.

- here, the foundation every domain shares: ``errors`` (the error tree), ``schema`` (the one schema of every
  config file, option table and node parameter: typed fields, one error format), ``robot`` (the robot
  description), ``rig`` (rig files), ``kinematics`` (paper eq. 1-2), ``validation`` (typed checks of array
  inputs), ``files`` (files written whole or not at all), ``ramp``;
- :mod:`srs_ros.core.gait`: the gait library, shape fitting, joint-space cycles, interpolation, playback;
- :mod:`srs_ros.core.actuation`: lengths to pressures and the one clamp, the hardware node's safety rules,
  muscle models, per-muscle calibration, lag compensation, identification;
- :mod:`srs_ros.core.vision`: ArUco, the camera's floor calibration, marker detection, tracking, view state.

Nodes wire these to topics and services. Modules that lived directly in ``srs_ros.core`` before the domain
folders (e.g. ``srs_ros.core.trajectory``) still import, with a DeprecationWarning naming the new path.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

#: Old module (``srs_ros.core.<name>``) -> where it lives now.
MOVED_MODULES = {
    "gaits": "srs_ros.core.gait.library",
    "fitting": "srs_ros.core.gait.fitting",
    "trajectory": "srs_ros.core.gait.trajectory",
    "interpolation": "srs_ros.core.gait.interpolation",
    "playback": "srs_ros.core.gait.playback",
    "actuation": "srs_ros.core.actuation.pressure",
    "safety": "srs_ros.core.actuation.safety",
    "muscle_model": "srs_ros.core.actuation.muscle_model",
    "muscle_calibration": "srs_ros.core.actuation.muscle_calibration",
    "compensation": "srs_ros.core.actuation.compensation",
    "identification": "srs_ros.core.actuation.identification",
    "aruco": "srs_ros.core.vision.aruco",
    "camera_calibration": "srs_ros.core.vision.camera_calibration",
    "tracking": "srs_ros.core.vision.tracking",
}


class _MovedModuleFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Imports an old ``srs_ros.core.<name>`` as the module at its new path, with a DeprecationWarning."""

    def find_spec(self, fullname, path=None, target=None):
        prefix, _, name = fullname.rpartition(".")
        if prefix != __name__ or name not in MOVED_MODULES or name == "actuation":
            return None  # ``srs_ros.core.actuation`` is a package now: its old names are re-exported there
        return importlib.util.spec_from_loader(fullname, self)

    def create_module(self, spec):
        new = MOVED_MODULES[spec.name.rpartition(".")[2]]
        warnings.warn(f"{spec.name} moved to {new}; import it from there", DeprecationWarning, stacklevel=3)
        return importlib.import_module(new)

    def exec_module(self, module):
        """The module is the new one, already executed."""


if not any(isinstance(finder, _MovedModuleFinder) for finder in sys.meta_path):
    sys.meta_path.insert(0, _MovedModuleFinder())


def lazy_exports(package: str, exports: dict[str, str]):
    """A module ``__getattr__`` for ``package`` that imports each public name from its submodule on first use.

    A package's face (``from srs_ros.core.gait import generate_cycle``) without importing every submodule
    (and SciPy, OpenCV ...) whenever one of them is used.
    """

    def __getattr__(name: str):
        if name not in exports:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        return getattr(importlib.import_module(f"{package}.{exports[name]}"), name)

    return __getattr__
