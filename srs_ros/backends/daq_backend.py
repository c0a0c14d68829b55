"""NI-DAQmx backend: the nine regulator voltages as on-demand analog outputs through ``nidaqmx``.

One task holds one AO voltage channel per joint (0 V .. the regulator's full-scale command, 10 V);
every write is one sample per channel. Zero volts are written on open, vent and close, and after any
failed write before the error is raised, so no exit path leaves a regulator pressurised by us.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from srs_ros.backends.base import ActuatorBackend
from srs_ros.core.errors import BackendUnavailableError, ConfigurationError, HardwareError
from srs_ros.core.robot import RobotDescription

DRIVER_HINT = ("Install the NI-DAQmx driver (https://www.ni.com/en/support/downloads/drivers/download.ni-daq-mx.html, "
               "or `python -m nidaqmx installdriver`), or choose another backend (mock, can).")
_RANGE = re.compile(r"^(?P<prefix>.*?)(?P<first>\d+):(?P<last>\d+)$")
_KNOWN_OPTIONS = {"physical_channels"}
DEFAULT_PHYSICAL_CHANNELS = "Dev1/ao0:8"


def _fail(key: str, value: Any, expected: str) -> ConfigurationError:
    return ConfigurationError(f"daq backend_options: '{key}' is {value!r}; expected {expected}.")


def expand_physical_channels(spec: str | Sequence[str]) -> list[str]:
    """NI physical-channel names, one per channel: ``'Dev1/ao0:2'`` -> ``['Dev1/ao0', 'Dev1/ao1', 'Dev1/ao2']``.

    Accepts a string with comma-separated names or ranges (``'Dev1/ao0:3, Dev2/ao0:4'``; a range may
    count down) or a list of such strings.
    """
    if not isinstance(spec, (str, Sequence)):
        raise ValueError(f"{spec!r} is neither a channel string nor a list of them")
    items = [spec] if isinstance(spec, str) else list(spec)
    names: list[str] = []
    for item in items:
        if not isinstance(item, str):
            raise ValueError(f"{item!r} is not a channel name")
        for part in (p.strip() for p in item.split(",")):
            if not part:
                raise ValueError("empty channel name")
            match = _RANGE.match(part)
            if match is None:
                names.append(part)
                continue
            first, last = int(match["first"]), int(match["last"])
            step = 1 if last >= first else -1
            names += [f"{match['prefix']}{n}" for n in range(first, last + step, step)]
    return names


class DaqBackend(ActuatorBackend):
    """Nine NI-DAQmx analog outputs, one per regulator, written on demand.

    Options (``backend_options`` of the rig):

    - ``physical_channels``: the AO channels in joint order, as one NI string (``Dev1/ao0:8``,
      default) or a list of nine names (``[Dev1/ao0, ..., Dev2/ao0]``).

    The output range is 0 V .. the regulator's ``command_full_scale_v`` (10 V) from the robot description.
    """

    name = "daq"

    def __init__(self, robot: RobotDescription | None = None, options: Mapping[str, Any] | None = None):
        """Validate the options (ConfigurationError naming the key); nothing is opened yet."""
        super().__init__(robot, options)
        unknown = sorted(set(self.options) - _KNOWN_OPTIONS)
        if unknown:
            raise ConfigurationError(f"daq backend_options: unknown key(s) {unknown}; expected some of "
                                     f"{sorted(_KNOWN_OPTIONS)}.")
        spec = self.options.get("physical_channels", DEFAULT_PHYSICAL_CHANNELS)
        count = self.robot.joint_count
        expected = f"{count} distinct NI analog-output channels in joint order, e.g. 'Dev1/ao0:{count - 1}'"
        try:
            self.physical_channels = expand_physical_channels(spec)
        except ValueError as exc:
            raise _fail("physical_channels", spec, f"{expected} ({exc})") from exc
        if len(self.physical_channels) != count or len(set(self.physical_channels)) != count:
            raise _fail("physical_channels", spec, f"{expected}; it names {len(self.physical_channels)}")
        self._task = None
        self._nidaqmx = None

    def channel_labels(self) -> list[str]:
        """Per joint: the NI physical channel that drives it."""
        return list(self.physical_channels)

    # -- the contract -------------------------------------------------------------------------
    def _open(self) -> None:
        try:
            import nidaqmx
            import nidaqmx.errors
        except ImportError as exc:
            raise BackendUnavailableError(f"the Python package nidaqmx is not installed ({exc}); "
                                          f"`pip install nidaqmx`. {DRIVER_HINT}") from exc
        self._nidaqmx = nidaqmx
        try:
            task = nidaqmx.Task()
        except nidaqmx.errors.DaqNotFoundError as exc:
            raise BackendUnavailableError(f"NI-DAQmx driver not found: {_one_line(exc)} {DRIVER_HINT}") from exc
        except nidaqmx.errors.Error as exc:
            raise HardwareError(f"cannot create an NI-DAQmx task: {_one_line(exc)}") from exc
        try:
            for channel in self.physical_channels:
                task.ao_channels.add_ao_voltage_chan(
                    channel, min_val=0.0, max_val=self.robot.regulator.command_full_scale_v)
        except nidaqmx.errors.Error as exc:
            _close_quietly(task)
            spec = self.options.get("physical_channels", DEFAULT_PHYSICAL_CHANNELS)
            raise HardwareError(f"cannot add analog output {channel!r} (daq backend_options 'physical_channels' = "
                                f"{spec!r}): {_one_line(exc)}. Check the device name in NI MAX and that it has "
                                "enough AO channels.") from exc
        self._task = task
        try:
            self._output([0.0] * self.robot.joint_count)
        except BaseException:
            self._task = None
            _close_quietly(task)
            raise

    def _write(self, pressure_bar: np.ndarray, command_v: np.ndarray) -> None:
        self._output([float(v) for v in command_v])

    def _close(self) -> None:
        task, self._task = self._task, None
        if task is not None:
            _close_quietly(task)

    # -- output ---------------------------------------------------------------------------------
    def _output(self, volts: list[float]) -> None:
        """One sample per channel; on any failure try zero volts, then raise HardwareError."""
        if self._task is None:
            raise HardwareError("daq backend: no NI-DAQmx task is open; configure the hardware node again.")
        try:
            self._task.write(volts, auto_start=True)
        except BaseException as exc:
            zeroed = self._try_zero()
            if not isinstance(exc, Exception):
                raise  # KeyboardInterrupt and friends: outputs zeroed (if possible), then propagate
            state = "outputs set to 0 V" if zeroed else "could NOT set the outputs to 0 V: vent the supply by hand"
            raise HardwareError(f"NI-DAQmx write to {self.physical_channels[0]}.. failed: {_one_line(exc)} ({state}). "
                                "Check the device in NI MAX, then re-open the backend.") from exc

    def _try_zero(self) -> bool:
        try:
            self._task.write([0.0] * self.robot.joint_count, auto_start=True)
        except Exception:  # noqa: BLE001 - best effort on the failure path; the caller raises the first error
            return False
        return True


def _one_line(exc: BaseException) -> str:
    """NI's multi-line error text on one line (for logs and /diagnostics)."""
    return " ".join(str(exc).split())


def _close_quietly(task) -> None:
    try:
        task.close()
    except Exception:  # noqa: BLE001 - closing a failed task must not mask the error being raised
        pass
