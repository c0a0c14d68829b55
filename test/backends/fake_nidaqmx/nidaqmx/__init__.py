"""Fake ``nidaqmx`` for tests: same call shapes as NI's package, records what is written (never install)."""

from __future__ import annotations

from dataclasses import dataclass, field

from nidaqmx import errors

#: Everything the fake saw; tests reset it with :func:`reset`.
RECORD: dict = {}


@dataclass
class Behaviour:
    """What the fake hardware does: which devices exist, which writes fail."""

    driver_installed: bool = True
    devices: dict = field(default_factory=lambda: {"Dev1": 16, "Dev2": 4})  # device -> AO channel count
    fail_writes: int = 0          # the next n writes raise DaqError
    fail_all_writes: bool = False
    raise_on_write: BaseException | None = None  # raised (once) instead of writing, e.g. KeyboardInterrupt


BEHAVIOUR = Behaviour()


def reset() -> None:
    """Fresh record and default behaviour."""
    global BEHAVIOUR
    BEHAVIOUR = Behaviour()
    RECORD.clear()
    RECORD.update(tasks=[])


reset()


class AOChannel:
    def __init__(self, physical_channel: str, min_val: float, max_val: float):
        self.physical_channel, self.ao_min, self.ao_max = physical_channel, min_val, max_val


class AOChannelCollection:
    def __init__(self, task: Task):
        self._task = task
        self.channels: list[AOChannel] = []

    def add_ao_voltage_chan(self, physical_channel, name_to_assign_to_channel="", min_val=-10.0, max_val=10.0,
                            units=None, custom_scale_name=""):
        self._task._check_open()
        device, _, line = physical_channel.partition("/")
        count = BEHAVIOUR.devices.get(device)
        if count is None:
            raise errors.DaqError(f"Device identifier is invalid.\nDevice Specified: {device}", -200220)
        if not (line.startswith("ao") and line[2:].isdigit() and int(line[2:]) < count):
            raise errors.DaqError(f"Physical channel specified does not exist on this device.\n"
                                  f"Physical Channel Name: {physical_channel}", -200170)
        if min_val < -10.0 or max_val > 10.0:
            raise errors.DaqError("Requested value is not a supported value for this property.", -200077)
        channel = AOChannel(physical_channel, min_val, max_val)
        self.channels.append(channel)
        return channel

    @property
    def channel_names(self) -> list[str]:
        return [c.physical_channel for c in self.channels]


class Task:
    """``nidaqmx.Task``: creating one needs the driver."""

    def __init__(self, new_task_name: str = ""):
        if not BEHAVIOUR.driver_installed:
            raise errors.DaqNotFoundError(
                "Could not find an installation of NI-DAQmx. Please ensure that NI-DAQmx is installed on this "
                "machine or contact National Instruments for support.")
        self.name = new_task_name
        self.ao_channels = AOChannelCollection(self)
        self.writes: list[list[float]] = []
        self.closed = False
        self.started = False
        RECORD["tasks"].append(self)

    def _check_open(self) -> None:
        if self.closed:
            raise errors.DaqError("Task specified is invalid or does not exist.", -200088)

    def write(self, data, auto_start=True, timeout=10.0):
        self._check_open()
        if BEHAVIOUR.raise_on_write is not None:
            exc, BEHAVIOUR.raise_on_write = BEHAVIOUR.raise_on_write, None
            raise exc
        if BEHAVIOUR.fail_all_writes or BEHAVIOUR.fail_writes > 0:
            BEHAVIOUR.fail_writes = max(BEHAVIOUR.fail_writes - 1, 0)
            raise errors.DaqWriteError("Onboard device memory underflow.", -200018)
        channels = self.ao_channels.channels
        values = [float(data)] if not isinstance(data, (list, tuple)) else [float(v) for v in data]
        if len(values) != len(channels):
            raise errors.DaqError(f"Write cannot be performed: {len(values)} values for {len(channels)} channels.",
                                  -200524)
        for channel, value in zip(channels, values):
            if not channel.ao_min <= value <= channel.ao_max:
                raise errors.DaqError(f"Requested value {value} is outside [{channel.ao_min}, {channel.ao_max}] on "
                                      f"{channel.physical_channel}.", -200077)
        if not auto_start and not self.started:
            raise errors.DaqError("Task not started.", -200479)
        self.started = True
        self.writes.append(values)
        return 1

    def close(self) -> None:
        self.closed = True

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
