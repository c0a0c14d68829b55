"""Actuator backends, chosen by name like python-can's interfaces: ``create_backend('mock')``."""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import Any

from srs_ros.backends.base import ActuatorBackend, ActuatorState
from srs_ros.core.errors import ConfigurationError
from srs_ros.core.robot import RobotDescription

#: backend name -> "module:Class"; imported only when chosen, so a missing driver hurts only its user.
BACKENDS: dict[str, str] = {
    "mock": "srs_ros.backends.mock:MockBackend",
    "can": "srs_ros.backends.can_backend:CanBackend",
    "daq": "srs_ros.backends.daq_backend:DaqBackend",
    "sim": "srs_ros.backends.sim_backend:SimBackend",
}


def backend_class(name: str, source: str = "") -> type[ActuatorBackend]:
    """The class of the backend called ``name`` (its module imported now); ``source`` as in create_backend."""
    if name not in BACKENDS:
        key = f"{source}: rig.backend" if source else "backend"
        raise ConfigurationError(f"{key}: unknown backend {name!r}; expected one of {sorted(BACKENDS)}.")
    module_name, class_name = BACKENDS[name].split(":")
    return getattr(importlib.import_module(module_name), class_name)


def create_backend(name: str, robot: RobotDescription | None = None,
                   options: Mapping[str, Any] | None = None, source: str = "") -> ActuatorBackend:
    """Instantiate the backend called ``name`` (not yet opened).

    ``source``: the rig file the name and options came from, named in a refusal of them.
    """
    chosen = backend_class(name, source)  # an unknown name is refused naming the file once
    try:
        return chosen(robot=robot, options=options)
    except ConfigurationError as exc:
        if not source:
            raise
        raise ConfigurationError(f"{source}: {exc}") from None


__all__ = ["ActuatorBackend", "ActuatorState", "BACKENDS", "backend_class", "create_backend"]
