"""Fake ``nidaqmx`` for tests: same call shapes as NI's package, simulated devices, records what is written.

The simulated hardware lives in :data:`BEHAVIOUR` (devices, their output terminals, watchdog state and a
clock the tests advance); :data:`RECORD` holds every task and watchdog task created. Never install this.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from nidaqmx import errors
from nidaqmx.constants import ProductCategory
from nidaqmx.error_codes import DAQmxErrors

#: Everything the fake saw; tests reset it with :func:`reset`.
RECORD: dict = {}


class Clock:
    """The fake hardware's time (s): manual by default (tests call :meth:`advance`), or monotonic + offset."""

    def __init__(self, real_time: bool = False):
        self.real_time, self.offset_s = real_time, 1000.0

    def __call__(self) -> float:
        return (time.monotonic() if self.real_time else 0.0) + self.offset_s

    def advance(self, seconds: float) -> None:
        self.offset_s += seconds


@dataclass
class FakeDevice:
    """One device in NI MAX: its AO lines, what its watchdog timer can do, its terminals."""

    ao_count: int
    product_type: str
    category: ProductCategory
    watchdog: str = "ao"    # "ao": a watchdog task with AO expiration states; "digital": DIO/PFI only; "": none
    chassis: str = ""       # a C Series module: the CompactDAQ chassis that holds it (and its watchdog)
    outputs_v: dict = field(default_factory=dict)  # physical channel -> volts on the terminal now
    expired: bool = False   # the watchdog expired: outputs at their expiration states, writes refused


def default_devices() -> dict[str, FakeDevice]:
    modules = {f"cDAQ1Mod{slot}": FakeDevice(4, "NI 9263", ProductCategory.C_SERIES_MODULE, "", chassis="cDAQ1")
               for slot in (1, 2, 3)}
    return {
        "Dev1": FakeDevice(16, "AO device with an AO watchdog (fake)", ProductCategory.AO_SERIES),
        "Dev2": FakeDevice(4, "AO device with an AO watchdog (fake)", ProductCategory.AO_SERIES),
        "Dev3": FakeDevice(4, "USB-6343", ProductCategory.X_SERIES_DAQ, "digital"),
        "Dev4": FakeDevice(16, "AO device without a watchdog (fake)", ProductCategory.AO_SERIES, ""),
        "cDAQ1": FakeDevice(0, "cDAQ-9189", ProductCategory.COMPACT_DAQ_CHASSIS),
        **modules,
    }


@dataclass
class Behaviour:
    """What the fake hardware does: which devices exist, which writes fail, how time passes."""

    driver_installed: bool = True
    devices: dict = field(default_factory=default_devices)
    fail_writes: int = 0          # the next n writes raise DaqWriteError
    fail_all_writes: bool = False
    raise_on_write: BaseException | None = None  # raised (once) instead of writing, e.g. KeyboardInterrupt
    clock: Callable[[], float] = field(default_factory=Clock)
    stall_after_writes: int = 0   # before non-zero AO write n + 1 the clock jumps by stall_s (a frozen process)
    stall_s: float = 0.0
    nonzero_writes: int = 0


BEHAVIOUR = Behaviour()


def reset() -> None:
    """Fresh record and default behaviour; in a node process, FAKE_NIDAQMX_REAL_TIME=1 and
    FAKE_NIDAQMX_STALL=<writes>:<seconds> configure the clock and one stall."""
    global BEHAVIOUR
    BEHAVIOUR = Behaviour(clock=Clock(real_time=os.environ.get("FAKE_NIDAQMX_REAL_TIME") == "1"))
    stall = os.environ.get("FAKE_NIDAQMX_STALL")
    if stall:
        writes, seconds = stall.split(":")
        BEHAVIOUR.stall_after_writes, BEHAVIOUR.stall_s = int(writes), float(seconds)
    RECORD.clear()
    RECORD.update(tasks=[], watchdogs=[])


def require_driver() -> None:
    if not BEHAVIOUR.driver_installed:
        raise errors.DaqNotFoundError(
            "Could not find an installation of NI-DAQmx. Please ensure that NI-DAQmx is installed on this "
            "machine or contact National Instruments for support.")


def device(name: str) -> FakeDevice:
    found = BEHAVIOUR.devices.get(name)
    if found is None:
        raise errors.DaqError(f"Device identifier is invalid.\nDevice Specified: {name}", DAQmxErrors.INVALID_DEVICE_ID)
    return found


def watchdog_home(device_name: str) -> str:
    """The device whose watchdog timer covers ``device_name`` (a module's chassis, else itself)."""
    return device(device_name).chassis or device_name


def update_watchdogs() -> None:
    """Let every running watchdog notice the time that passed (expiring where it was not reset in time)."""
    for watchdog in RECORD["watchdogs"]:
        watchdog._update()


def terminals(device_name: str) -> dict[str, float]:
    """The voltages on a device's AO terminals now (what a voltmeter would show), after the watchdogs ran."""
    update_watchdogs()
    return dict(device(device_name).outputs_v)


reset()


class AOChannel:
    def __init__(self, physical_channel: str, min_val: float, max_val: float):
        self.physical_channel, self.ao_min, self.ao_max = physical_channel, min_val, max_val
        self.device_name = physical_channel.partition("/")[0]


class AOChannelCollection:
    def __init__(self, task: Task):
        self._task = task
        self.channels: list[AOChannel] = []

    def add_ao_voltage_chan(self, physical_channel, name_to_assign_to_channel="", min_val=-10.0, max_val=10.0,
                            units=None, custom_scale_name=""):
        self._task._check_open()
        device_name, _, line = physical_channel.partition("/")
        count = device(device_name).ao_count
        if not (line.startswith("ao") and line[2:].isdigit() and int(line[2:]) < count):
            raise errors.DaqError(f"Physical channel specified does not exist on this device.\n"
                                  f"Physical Channel Name: {physical_channel}",
                                  DAQmxErrors.PHYSICAL_CHAN_DOES_NOT_EXIST)
        if min_val < -10.0 or max_val > 10.0:
            raise errors.DaqError("Requested value is not a supported value for this property.",
                                  DAQmxErrors.INVALID_ATTRIBUTE_VALUE)
        channel = AOChannel(physical_channel, min_val, max_val)
        self.channels.append(channel)
        return channel

    @property
    def channel_names(self) -> list[str]:
        return [c.physical_channel for c in self.channels]


class Task:
    """``nidaqmx.Task``: creating one needs the driver."""

    def __init__(self, new_task_name: str = ""):
        require_driver()
        self.name = new_task_name
        self.ao_channels = AOChannelCollection(self)
        self.writes: list[list[float]] = []
        self.closed = False
        self.started = False
        RECORD["tasks"].append(self)

    def _check_open(self) -> None:
        if self.closed:
            raise errors.DaqError("Task specified is invalid or does not exist.", DAQmxErrors.INVALID_TASK)

    def write(self, data, auto_start=True, timeout=10.0):
        self._check_open()
        if BEHAVIOUR.raise_on_write is not None:
            exc, BEHAVIOUR.raise_on_write = BEHAVIOUR.raise_on_write, None
            raise exc
        if BEHAVIOUR.fail_all_writes or BEHAVIOUR.fail_writes > 0:
            BEHAVIOUR.fail_writes = max(BEHAVIOUR.fail_writes - 1, 0)
            raise errors.DaqWriteError("Onboard device memory underflow.", DAQmxErrors.DAC_UNDERFLOW, 0)
        values = [float(data)] if not isinstance(data, (list, tuple)) else [float(v) for v in data]
        if any(values):
            if BEHAVIOUR.stall_after_writes and BEHAVIOUR.nonzero_writes == BEHAVIOUR.stall_after_writes:
                BEHAVIOUR.clock.advance(BEHAVIOUR.stall_s)  # the process froze before this write
            BEHAVIOUR.nonzero_writes += 1
        update_watchdogs()
        channels = self.ao_channels.channels
        for channel in channels:
            if device(watchdog_home(channel.device_name)).expired:
                raise errors.DaqError("Write cannot be performed, because the watchdog timer expired. Clear the "
                                      "expiration of the watchdog task or reset the device.",
                                      DAQmxErrors.WRITE_FAILED_BECAUSE_WATCHDOG_EXPIRED, self.name)
        if len(values) != len(channels):
            raise errors.DaqError(f"Write cannot be performed: {len(values)} values for {len(channels)} channels.",
                                  DAQmxErrors.WRITE_NUM_CHANS_MISMATCH)
        for channel, value in zip(channels, values):
            if not channel.ao_min <= value <= channel.ao_max:
                raise errors.DaqError(f"Requested value {value} is outside [{channel.ao_min}, {channel.ao_max}] on "
                                      f"{channel.physical_channel}.", DAQmxErrors.INVALID_ATTRIBUTE_VALUE)
        if not auto_start and not self.started:
            raise errors.DaqError("Task not started.", DAQmxErrors.CAN_NOT_PERFORM_OP_WHILE_TASK_RUNNING)
        self.started = True
        for channel, value in zip(channels, values):
            device(channel.device_name).outputs_v[channel.physical_channel] = value
        self.writes.append(values)
        return 1

    def close(self) -> None:
        self.closed = True

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


from nidaqmx import constants, error_codes, system, types  # noqa: E402, F401 - loaded by `import nidaqmx`, as in NI's
