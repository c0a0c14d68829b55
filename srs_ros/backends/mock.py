"""The ``mock`` backend: nine simulated muscles (:mod:`srs_ros.core.actuation.muscle_model`) instead of regulators.

Options (``backend_options`` of a rig file, each validated with the key named on error):

- ``pressure_time_constant_s``: first-order lag of regulator + muscle, in [0, 10] s;
- ``transport_delay_s``: supply-line delay, in [0, 2] s;
- ``max_pressure_rate_bar_per_s``: fastest filling or venting (a flow-limited supply), in [0, 1000] bar/s, 0 = no
  limit (defaults of these three: :data:`srs_ros.core.actuation.muscle_model.MUSCLE_OPTION_DEFAULTS`);
- ``deadzone_bar`` (default: the robot's ``deadzone_bar``): no extension below this pressure;
- ``max_extension_m`` (default: the robot's ``max_extension_m``): extension reached at the robot's
  ``max_pressure_bar`` and never exceeded;
- ``per_muscle``: muscles that differ from the others, ``{joint name: {option: value}}`` with the options
  above (e.g. ``{m2_pma1: {deadzone_bar: 1.3, transport_delay_s: 0.05}}``), as the muscles of a real
  robot do (``srs_identify`` tells them apart);
- fault injection, for tests only: ``fail_after_writes`` (int >= 0, default off): every write after
  the first N since ``open()`` raises :class:`~srs_ros.core.errors.HardwareError`, as a dead bus would;
  ``fail_on_open`` (bool): ``open()`` raises :class:`~srs_ros.core.errors.HardwareError`;
- observation, for tests and benchmarks only: ``record_file`` (path, default off): every command the
  backend is given (vents included) is appended to this file as it is written, one line
  ``<time.monotonic() s> <p1> ... <p9>`` (bar, full precision), plus ``# open <s>`` / ``# close <s>``
  lines; each line is one unbuffered ``os.write``, so another process sees it at once and a SIGKILL
  loses nothing. :func:`read_record` parses it (also while it grows). The file must be a regular file
  (or not exist yet).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from srs_ros.backends.base import ActuatorBackend
from srs_ros.core.actuation.muscle_model import (
    MUSCLE_OPTIONS,
    MuscleModel,
    MuscleParameters,
    muscle_parameters_from_options,
)
from srs_ros.core.errors import HardwareError
from srs_ros.core.robot import RobotDescription
from srs_ros.core.schema import Field, Table, check_known, mapping, refusal

#: Where an option error says it is.
WHERE = "mock backend_options"
#: The mock's own options beside the muscle options (:data:`~srs_ros.core.actuation.muscle_model.MUSCLE_OPTIONS`).
MOCK_OPTIONS = Table("", (
    Field("per_muscle", dict, None, description="muscles that differ from the others: {joint name: {option: value}}"),
    Field("fail_after_writes", int, None, minimum=0, unit="writes",
          description="fault injection (tests): every write after the first N since open() raises HardwareError"),
    Field("fail_on_open", bool, False, description="fault injection (tests): open() raises HardwareError"),
    Field("record_file", str, None, nonempty=True,
          description="tests and benchmarks: every command is appended to this file (read_record parses it)"),
), description="a mapping of option: value")


class MockBackend(ActuatorBackend):
    """Simulated rig: commands drive a :class:`MuscleModel`; ``read_state`` reports its pressures and lengths.

    ``clock`` (seconds, default ``time.monotonic``) can be replaced in unit tests to step time by hand.
    """

    name = "mock"
    drives_real_hardware = False
    measures_pressure = True
    measures_length = True

    def __init__(self, robot: RobotDescription | None = None, options: Mapping[str, Any] | None = None,
                 clock: Callable[[], float] = time.monotonic):
        """Validate the options (``ConfigurationError`` naming the key); the simulation starts at ``open()``."""
        super().__init__(robot, options)
        self.clock = clock
        self.params = muscle_parameters_from_options(self.options, self.robot, WHERE, extra_keys=MOCK_OPTIONS.names)
        own = MOCK_OPTIONS.read(self.options, WHERE, extra=MUSCLE_OPTIONS.names)
        self.muscle_params = _per_muscle_parameters(self.options, own["per_muscle"] or {}, self.robot)
        self.fail_after_writes: int | None = own["fail_after_writes"]
        self.fail_on_open: bool = own["fail_on_open"]
        self.record_path = _record_path(own["record_file"])
        self._record_fd: int | None = None
        self.write_count = 0
        self.models: list[tuple[list[int], MuscleModel]] = []  # (joint indices, their muscles), per parameter set

    def _open(self) -> None:
        if self.fail_on_open:
            raise HardwareError("mock backend: open failed (fault injection option 'fail_on_open' is set).")
        self.write_count = 0
        groups: dict[MuscleParameters, list[int]] = {}
        for joint, params in enumerate(self.muscle_params):
            groups.setdefault(params, []).append(joint)
        self.models = [(joints, MuscleModel(params, len(joints), start_s=self.clock()))
                       for params, joints in groups.items()]
        if self.record_path is not None:
            try:
                self._record_fd = os.open(self.record_path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NONBLOCK,
                                          0o644)
            except OSError as exc:
                raise HardwareError(f"mock backend: cannot open 'record_file' {self.record_path} ({exc}).") from exc
            self._record(f"# open {time.monotonic():.6f}")

    def _write(self, pressure_bar: np.ndarray, command_v: np.ndarray) -> None:
        if self.fail_after_writes is not None and self.write_count >= self.fail_after_writes:
            raise HardwareError(f"mock backend: write {self.write_count + 1} failed (fault injection option "
                                f"'fail_after_writes' is {self.fail_after_writes}); reconfigure to reopen.")
        now_s = self.clock()
        for joints, model in self.models:
            model.command(pressure_bar[joints], now_s)
        self.write_count += 1
        if self._record_fd is not None:
            self._record(f"{time.monotonic():.6f} " + " ".join(format(float(v), ".17g") for v in pressure_bar))

    def _close(self) -> None:
        self.models = []
        if self._record_fd is not None:
            self._record(f"# close {time.monotonic():.6f}")
            os.close(self._record_fd)
            self._record_fd = None

    def _record(self, line: str) -> None:
        os.write(self._record_fd, (line + "\n").encode())

    def _measure(self) -> dict[str, Any]:
        now_s = self.clock()
        pressure_bar, length_m = np.empty(self.robot.joint_count), np.empty(self.robot.joint_count)
        for joints, model in self.models:
            pressure_bar[joints], length_m[joints] = model.state(now_s)
        return {"measured_pressure_bar": pressure_bar, "measured_length_m": length_m,
                "details": {"simulated": True, "writes": self.write_count}}


def _per_muscle_parameters(options: Mapping[str, Any], per_muscle: Mapping[str, Any],
                           robot: RobotDescription) -> list[MuscleParameters]:
    """Each joint's muscle parameters: the shared options, overridden by its ``per_muscle`` entry."""
    check_known(per_muscle, robot.joint_names, WHERE, "per_muscle")
    shared = {key: value for key, value in options.items() if key in MUSCLE_OPTIONS}
    params = []
    for name in robot.joint_names:
        own = mapping(per_muscle.get(name) or {}, WHERE, f"per_muscle.{name}", "a mapping of option: value")
        params.append(muscle_parameters_from_options({**shared, **own}, robot, WHERE, path=f"per_muscle.{name}"))
    return params


def _record_path(value: str | None) -> Path | None:
    if value is None:
        return None
    path = Path(value)
    if not path.parent.is_dir() or (path.exists() and not path.is_file()):
        raise refusal(WHERE, "record_file", value, "the path of a regular file (or of a new file) in an existing "
                                                   "folder, or leave it out")
    return path


def read_record(path: str | Path, offset: int = 0) -> tuple[np.ndarray, np.ndarray, int]:
    """The commands a ``record_file`` holds from byte ``offset`` on: times, pressures and the next offset.

    Times are ``time.monotonic()`` seconds, shape (n,); pressures are bar, shape (n, 9); read on from the
    returned offset next time. A line still being written (no newline yet) is left for the next read;
    ``#`` lines are skipped.
    """
    with open(path, "rb") as stream:
        stream.seek(offset)
        data = stream.read()
    complete = data[:data.rfind(b"\n") + 1]
    rows = [[float(v) for v in line.split()] for line in complete.decode().splitlines()
            if line and not line.startswith("#")]
    table = np.array(rows, dtype=np.float64).reshape(len(rows), -1) if rows else np.zeros((0, 1))
    return table[:, 0], table[:, 1:], offset + len(complete)
