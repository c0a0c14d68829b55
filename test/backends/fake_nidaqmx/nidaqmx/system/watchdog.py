"""Fake ``nidaqmx.system.watchdog``: ``WatchdogTask`` with NI's constructor, methods and errors.

A started watchdog expires when ``reset_timer`` was not called for ``timeout`` seconds of the fake
clock: the device then sets each configured AO channel to its expiration state and refuses writes
(``WRITE_FAILED_BECAUSE_WATCHDOG_EXPIRED``) and resets (``CANT_RESET_EXPIRED_WATCHDOG``) until
``clear_expiration`` or ``Device.reset_device``. On a CompactDAQ chassis the watchdog task must start
before other tasks reserve the chassis (``CANT_RESERVE_WATCHDOG_TASK_WHILE_OTHER_TASKS_RESERVED``).
"""

from __future__ import annotations

import nidaqmx
from nidaqmx import errors
from nidaqmx.constants import ProductCategory, WatchdogAOExpirState
from nidaqmx.error_codes import DAQmxErrors
from nidaqmx.types import AOExpirationState

__all__ = ["AOExpirationState", "WatchdogTask"]

MAX_TIMEOUT_S = 107.0  # (2^32 - 1) x 25 ns on a cDAQ chassis


class ExpirationState:
    def __init__(self, physical_channel: str, ao_state: float, ao_output_type: WatchdogAOExpirState):
        self.physical_channel, self.ao_state, self.ao_output_type = physical_channel, ao_state, ao_output_type


class WatchdogTask:
    def __init__(self, device_name, task_name="", timeout=10, grpc_options=None):
        nidaqmx.require_driver()
        found = nidaqmx.device(device_name)
        if not found.watchdog:
            raise errors.DaqError(f"The watchdog timer is not supported by this device.\nDevice: {device_name}",
                                  DAQmxErrors.WATCHDOG_TIMER_NOT_SUPPORTED, task_name)
        self._device_name, self._name = device_name, task_name or f"_watchdog_{len(nidaqmx.RECORD['watchdogs'])}"
        self.timeout = timeout
        self._states: dict[str, ExpirationState] = {}
        self.running = self.closed = False
        self._last_reset_s = 0.0
        self.resets = 0
        nidaqmx.RECORD["watchdogs"].append(self)

    # -- properties ---------------------------------------------------------------------------
    @property
    def name(self) -> str:
        return self._name

    @property
    def timeout(self) -> float:
        return self._timeout

    @timeout.setter
    def timeout(self, value: float) -> None:
        if not (value == -1 or 0 < value <= MAX_TIMEOUT_S):
            raise errors.DaqError(f"Watchdog timeout is out of range and is not a special value.\n"
                                  f"Requested Value: {value}",
                                  DAQmxErrors.WATCHDOG_TIMEOUT_OUT_OF_RANGE_AND_NOT_SPECIAL_VAL)
        self._timeout = float(value)

    @property
    def expiration_states(self) -> dict[str, ExpirationState]:
        return dict(self._states)

    @property
    def expired(self) -> bool:
        self._check_open()
        if not self.running:
            raise errors.DaqError("Cannot get property when task is not reserved, committed or running.",
                                  DAQmxErrors.CANNOT_GET_PROPERTY_WHEN_TASK_NOT_RESERVED_COMMITTED_OR_RUNNING,
                                  self._name)
        self._update()
        return nidaqmx.device(self._device_name).expired

    # -- methods ------------------------------------------------------------------------------
    def cfg_watchdog_ao_expir_states(self, expiration_states):
        self._check_open()
        home = nidaqmx.device(self._device_name)
        if home.watchdog != "ao":
            # Assumed error: NI documents X Series watchdogs for DIO/PFI lines only; the exact code is not verified.
            raise errors.DaqError("Specified property is not supported by the device or is not applicable to the "
                                  "task.\nProperty: DAQmx_Watchdog_AO_ExpirState", DAQmxErrors.ATTR_NOT_SUPPORTED,
                                  self._name)
        states = []
        for state in expiration_states:
            device_name, _, line = state.physical_channel.partition("/")
            ok = (device_name in nidaqmx.BEHAVIOUR.devices and nidaqmx.watchdog_home(device_name) == self._device_name
                  and line.startswith("ao") and line[2:].isdigit()
                  and int(line[2:]) < nidaqmx.device(device_name).ao_count)
            if not ok:
                raise errors.DaqError(f"Physical channel specified does not exist on this device.\n"
                                      f"Physical Channel Name: {state.physical_channel}",
                                      DAQmxErrors.PHYSICAL_CHAN_DOES_NOT_EXIST, self._name)
            if not isinstance(state.output_type, WatchdogAOExpirState) or not -10.0 <= state.expiration_state <= 10.0:
                raise errors.DaqError("Requested value is not a supported value for this property.",
                                      DAQmxErrors.INVALID_ATTRIBUTE_VALUE, self._name)
            states.append(ExpirationState(state.physical_channel, float(state.expiration_state), state.output_type))
        self._states.update((s.physical_channel, s) for s in states)
        return states

    def start(self) -> None:
        self._check_open()
        if nidaqmx.device(self._device_name).category == ProductCategory.COMPACT_DAQ_CHASSIS:
            busy = [t for t in nidaqmx.RECORD["tasks"] if not t.closed and t.started and any(
                nidaqmx.watchdog_home(c.device_name) == self._device_name for c in t.ao_channels.channels)]
            if busy:
                raise errors.DaqError("The watchdog timer task cannot be reserved while other tasks are reserved "
                                      "on the chassis.",
                                      DAQmxErrors.CANT_RESERVE_WATCHDOG_TASK_WHILE_OTHER_TASKS_RESERVED, self._name)
        self.running = True
        self._last_reset_s = nidaqmx.BEHAVIOUR.clock()

    def reset_timer(self) -> None:
        self._check_open()
        self._update()
        if nidaqmx.device(self._device_name).expired:
            raise errors.DaqError("The watchdog timer expired and cannot be reset. Clear the expiration first.",
                                  DAQmxErrors.CANT_RESET_EXPIRED_WATCHDOG, self._name)
        self._last_reset_s = nidaqmx.BEHAVIOUR.clock()
        self.resets += 1

    def clear_expiration(self) -> None:
        self._check_open()
        nidaqmx.device(self._device_name).expired = False
        self._last_reset_s = nidaqmx.BEHAVIOUR.clock()

    def stop(self) -> None:
        self._check_open()
        self.running = False

    def close(self) -> None:
        if self.closed:
            errors.warn_double_close(self._name)
            return
        self.running, self.closed = False, True

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # -- the simulated timer --------------------------------------------------------------------
    def _check_open(self) -> None:
        if self.closed:
            raise errors.DaqError("Task specified is invalid or does not exist.", DAQmxErrors.INVALID_TASK, self._name)

    def _update(self) -> None:
        home = nidaqmx.device(self._device_name)
        if (not self.running or self.closed or home.expired or self._timeout == -1
                or nidaqmx.BEHAVIOUR.clock() - self._last_reset_s <= self._timeout):
            return
        home.expired = True
        for channel, state in self._states.items():
            nidaqmx.device(channel.partition("/")[0]).outputs_v[channel] = state.ao_state
