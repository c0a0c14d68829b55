"""NI-DAQmx backend: the nine regulator voltages as on-demand analog outputs through ``nidaqmx``.

One task holds one AO voltage channel per joint (0 V .. the regulator's full-scale command, 10 V);
every write is one sample per channel. Zero volts are written on open, vent and close, and after any
failed write before the error is raised, so no exit path of this process leaves a regulator pressurised.

When the process itself dies (SIGKILL, segfault, a lost USB/Ethernet cable), an analog output holds its
last voltage. Against that, the backend runs NI-DAQmx's watchdog timer task (``nidaqmx.system.WatchdogTask``)
on the device (a C Series module's CompactDAQ chassis) with expiration state 0 V on every channel of the
rig and resets it on every write: if the writes stop for ``watchdog_timeout_s``, the device itself sets the
outputs to 0 V. A device without an analog-output watchdog is reported (warning, or refused with
``require_watchdog``); an expired watchdog is reported on the next write (``docs/daq.md``).
"""

from __future__ import annotations

import logging
import re
from collections.abc import Mapping, Sequence
from functools import partial
from typing import Any

import numpy as np

from srs_ros.backends.base import ActuatorBackend
from srs_ros.core.errors import BackendUnavailableError, HardwareError
from srs_ros.core.robot import RobotDescription
from srs_ros.core.schema import Field, Table, refusal

DRIVER_HINT = ("Install the NI-DAQmx driver (https://www.ni.com/en/support/downloads/drivers/download.ni-daq-mx.html, "
               "or `python -m nidaqmx installdriver`), or choose another backend (mock, can).")
_RANGE = re.compile(r"^(?P<prefix>.*?)(?P<first>\d+):(?P<last>\d+)$")
DEFAULT_PHYSICAL_CHANNELS = "Dev1/ao0:8"
#: Outputs go to 0 V by themselves when the host has not written for this long (s); 0 disables the watchdog.
DEFAULT_WATCHDOG_TIMEOUT_S = 0.1
WATCHDOG_TIMEOUT_RANGE_S = (0.01, 10.0)
WATCHDOG_HINT = ("If this host dies (SIGKILL, crash, cable), those outputs HOLD their last voltage and the regulators "
                 "keep their pressure. Put an external safety on the air supply (a normally-closed dump valve or relay "
                 "that opens without a heartbeat or on e-stop), or use a device whose watchdog timer supports "
                 "analog-output expiration states (e.g. AO modules in a CompactDAQ chassis); `require_watchdog: true` "
                 "refuses such a device.")
#: NI-DAQmx errors that mean "the watchdog has expired" (``nidaqmx.error_codes.DAQmxErrors`` member names).
_EXPIRED_ERRORS = ("WRITE_FAILED_BECAUSE_WATCHDOG_EXPIRED", "CANT_RESET_EXPIRED_WATCHDOG",
                   "CHASSIS_WATCHDOG_TIMER_EXPIRED")
_LOG = logging.getLogger(__name__)


#: Where an option error says it is.
WHERE = "daq backend_options"
#: The options of the daq backend (``backend_options`` of a rig file; see :class:`DaqBackend`).
DAQ_OPTIONS = Table("", (
    Field("physical_channels", object, DEFAULT_PHYSICAL_CHANNELS, description="the AO channels in joint order",
          expected_text="distinct NI analog-output channels in joint order, e.g. 'Dev1/ao0:8'"),
    Field("watchdog_timeout_s", float, DEFAULT_WATCHDOG_TIMEOUT_S, 0.0, WATCHDOG_TIMEOUT_RANGE_S[1], "",
          "the device zeroes its outputs when no write came for this long; 0 disables it",
          expected_text=f"0 (no watchdog) or seconds in [{WATCHDOG_TIMEOUT_RANGE_S[0]:g}, "
                        f"{WATCHDOG_TIMEOUT_RANGE_S[1]:g}], at least a few command periods, e.g. 0.1"),
    Field("require_watchdog", bool, False, description="refuse a device without an analog-output watchdog"),
), description="a mapping of option: value")
#: Raise what it returns: the one error format with this backend's place.
_refuse = partial(refusal, WHERE)


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
    - ``watchdog_timeout_s``: the device sets every output to 0 V by itself when no write came for this
      long (default 0.1 s; at least a few command periods; 0 disables it, with a warning).
    - ``require_watchdog``: refuse to open when a device has no analog-output watchdog (default false:
      a warning that names the device and what it means).

    The output range is 0 V .. the regulator's ``command_full_scale_v`` (10 V) from the robot description.
    After open, ``host_loss_timeout_s`` is the watchdog timeout when every channel is covered, else None.
    """

    name = "daq"

    def __init__(self, robot: RobotDescription | None = None, options: Mapping[str, Any] | None = None):
        """Validate the options (ConfigurationError naming the key); nothing is opened yet."""
        super().__init__(robot, options)
        options = DAQ_OPTIONS.read(self.options, WHERE)
        spec = options["physical_channels"]
        count = self.robot.joint_count
        expected = f"{count} distinct NI analog-output channels in joint order, e.g. 'Dev1/ao0:{count - 1}'"
        try:
            self.physical_channels = expand_physical_channels(spec)
        except ValueError as exc:
            raise _refuse("physical_channels", spec, f"{expected} ({exc})") from exc
        if len(self.physical_channels) != count or len(set(self.physical_channels)) != count:
            raise _refuse("physical_channels", spec, f"{expected}; it names {len(self.physical_channels)}")
        self.watchdog_timeout_s: float = options["watchdog_timeout_s"]
        low_s, high_s = WATCHDOG_TIMEOUT_RANGE_S
        if 0.0 < self.watchdog_timeout_s < low_s:
            raise _refuse("watchdog_timeout_s", self.watchdog_timeout_s, DAQ_OPTIONS["watchdog_timeout_s"].expected)
        self.require_watchdog: bool = options["require_watchdog"]
        if self.require_watchdog and self.watchdog_timeout_s == 0:
            raise _refuse("watchdog_timeout_s", 0, f"seconds in [{low_s:g}, {high_s:g}] since require_watchdog is true")
        self._task = None
        self._nidaqmx = None
        self._watchdogs: list[tuple[str, Any]] = []  # (watchdog device, nidaqmx.system.WatchdogTask)
        self._expired = ""  # why the outputs are locked at 0 V by an expired watchdog, until re-opened
        self.watchdog_status = "not open"
        self.host_loss_timeout_s: float | None = None

    def channel_labels(self) -> list[str]:
        """Per joint: the NI physical channel that drives it."""
        return list(self.physical_channels)

    # -- the contract -------------------------------------------------------------------------
    def _open(self) -> None:
        try:
            import nidaqmx
            import nidaqmx.constants
            import nidaqmx.error_codes
            import nidaqmx.errors
            import nidaqmx.system
        except ImportError as exc:
            raise BackendUnavailableError(f"the Python package nidaqmx is not installed ({exc}); "
                                          f"`pip install nidaqmx`. {DRIVER_HINT}") from exc
        self._nidaqmx = nidaqmx
        self._expired = ""
        self._start_watchdogs()  # before the AO task: a CompactDAQ chassis refuses it once other tasks run
        try:
            self._open_task()
        except BaseException:
            self._close_watchdogs()
            raise

    def _open_task(self) -> None:
        nidaqmx = self._nidaqmx
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
            spec = self.options.get("physical_channels", DAQ_OPTIONS["physical_channels"].default)
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
        self._close_watchdogs()

    def _measure(self) -> dict[str, Any]:
        return {"details": {"watchdog": self.watchdog_status}}

    # -- the watchdog timer -----------------------------------------------------------------------
    def _start_watchdogs(self) -> None:
        """One started watchdog task per device with 0 V expiration states; warn or refuse where there is none."""
        nidaqmx = self._nidaqmx
        if self.watchdog_timeout_s == 0:
            self.watchdog_status, self.host_loss_timeout_s = "disabled (watchdog_timeout_s: 0)", None
            _LOG.warning("daq backend: the NI-DAQmx watchdog is disabled (watchdog_timeout_s: 0). %s", WATCHDOG_HINT)
            return
        groups: dict[str, list[str]] = {}
        for channel in self.physical_channels:
            groups.setdefault(self._watchdog_device(channel.partition("/")[0]), []).append(channel)
        missing = []
        for device, channels in groups.items():
            try:
                watchdog = nidaqmx.system.WatchdogTask(device, timeout=self.watchdog_timeout_s)
            except nidaqmx.errors.DaqNotFoundError as exc:
                self._close_watchdogs()
                raise BackendUnavailableError(f"NI-DAQmx driver not found: {_one_line(exc)} {DRIVER_HINT}") from exc
            except nidaqmx.errors.Error as exc:
                missing.append((device, channels, exc))
                continue
            try:
                watchdog.cfg_watchdog_ao_expir_states([nidaqmx.system.watchdog.AOExpirationState(
                    physical_channel=channel, expiration_state=0.0,
                    output_type=nidaqmx.constants.WatchdogAOExpirState.VOLTAGE) for channel in channels])
                watchdog.start()
            except nidaqmx.errors.Error as exc:
                _close_quietly(watchdog)
                missing.append((device, channels, exc))
                continue
            self._watchdogs.append((device, watchdog))
        covered = ", ".join(device for device, _ in self._watchdogs)
        if not missing:
            self.watchdog_status = f"armed: 0 V after {self.watchdog_timeout_s:g} s without a write ({covered})"
            self.host_loss_timeout_s = self.watchdog_timeout_s
            return
        problems = "; ".join(f"{self._describe_device(device)} ({channels[0]}..{channels[-1]}): {_one_line(exc)}"
                             for device, channels, exc in missing)
        message = f"no NI-DAQmx analog-output watchdog on {problems}. {WATCHDOG_HINT}"
        if self.require_watchdog:
            self._close_watchdogs()
            raise HardwareError(f"daq backend (require_watchdog: true): {message}")
        self.watchdog_status = "MISSING on " + ", ".join(device for device, _, _ in missing)
        self.host_loss_timeout_s = None
        self.partial_host_loss_timeout_s = self.watchdog_timeout_s if self._watchdogs else None
        _LOG.warning("daq backend: %s", message)

    def _watchdog_device(self, device: str) -> str:
        """The device whose watchdog timer drives ``device``'s outputs: a C Series module's chassis, else itself."""
        nidaqmx = self._nidaqmx
        try:
            found = nidaqmx.system.Device(device)
            if found.product_category == nidaqmx.constants.ProductCategory.C_SERIES_MODULE:
                return found.compact_daq_chassis_device.name
        except nidaqmx.errors.Error:
            pass  # an unknown device fails below with NI's own message
        return device

    def _describe_device(self, device: str) -> str:
        try:
            return f"{device} ({self._nidaqmx.system.Device(device).product_type})"
        except self._nidaqmx.errors.Error:
            return device

    def _close_watchdogs(self) -> None:
        """Stop and release the watchdog tasks (clearing an expiration first, so the device accepts writes again)."""
        watchdogs, self._watchdogs = self._watchdogs, []
        for device, watchdog in watchdogs:
            if self._expired:
                try:
                    watchdog.clear_expiration()
                except Exception as exc:  # noqa: BLE001 - the outputs stay at 0 V; say how to unlock them
                    _LOG.warning("daq backend: could not clear the expired watchdog of %s (%s); reset the device "
                                 "(NI MAX: Reset Device) before the next open.", device, _one_line(exc))
            try:
                watchdog.stop()
            except Exception:  # noqa: BLE001 - releasing must go on
                pass
            _close_quietly(watchdog)
        self._expired = ""
        self.watchdog_status, self.host_loss_timeout_s, self.partial_host_loss_timeout_s = "not open", None, None

    def _expiry(self, exc: BaseException) -> str:
        """Why the write failed if a watchdog has expired (its error code, or its ``expired`` flag), else ''."""
        if not self._watchdogs:
            return ""
        codes = self._nidaqmx.error_codes.DAQmxErrors
        expired = getattr(exc, "error_code", None) in {codes[name].value for name in _EXPIRED_ERRORS if name in
                                                       codes.__members__}
        devices = []
        for device, watchdog in self._watchdogs:
            try:
                if watchdog.expired:
                    devices.append(device)
            except Exception:  # noqa: BLE001 - the error code alone decides then
                pass
        if not (expired or devices):
            return ""
        where = ", ".join(devices) or ", ".join(device for device, _ in self._watchdogs)
        return (f"the NI-DAQmx watchdog of {where} EXPIRED: no write reached the device for longer than "
                f"watchdog_timeout_s = {self.watchdog_timeout_s:g} s (the process stalled), so the device set every "
                f"output to 0 V by itself and locks them ({_one_line(exc)}). The regulators are vented; close and "
                "re-open the backend (configure and activate the hardware node) to clear it (still locked after that: "
                "reset the device in NI MAX). If it recurs, find what stalls the command loop or raise "
                "watchdog_timeout_s.")

    # -- output ---------------------------------------------------------------------------------
    def _output(self, volts: list[float]) -> None:
        """One sample per channel, then reset the watchdogs; on a failure try zero volts, then raise HardwareError.

        After a watchdog expired the outputs are locked at 0 V: a vent (all zeros) is then already done, any
        other command raises HardwareError until the backend is re-opened.
        """
        if self._task is None:
            raise HardwareError("daq backend: no NI-DAQmx task is open; configure the hardware node again.")
        if self._expired:
            if any(volts):
                raise HardwareError(f"daq backend: {self._expired}")
            return
        try:
            self._task.write(volts, auto_start=True)
            for _, watchdog in self._watchdogs:
                watchdog.reset_timer()
        except BaseException as exc:
            expiry = self._expiry(exc) if isinstance(exc, Exception) else ""
            if expiry:
                self._expired, self.watchdog_status = expiry, "EXPIRED"
                if any(volts):
                    raise HardwareError(f"daq backend: {expiry}") from exc
                _LOG.warning("daq backend: %s", expiry)
                return  # a vent: the device already holds 0 V
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
