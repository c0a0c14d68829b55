"""Fake ``nidaqmx.system.device.Device``: the properties the backend reads, from the simulated devices."""

from __future__ import annotations

import nidaqmx
from nidaqmx import errors
from nidaqmx.constants import ProductCategory
from nidaqmx.error_codes import DAQmxErrors


class Device:
    def __init__(self, name, *, grpc_options=None):
        self._name = name

    def __repr__(self):
        return f"Device(name={self._name})"

    def _device(self):
        nidaqmx.require_driver()
        return nidaqmx.device(self._name)

    @property
    def name(self) -> str:
        return self._name

    @property
    def product_type(self) -> str:
        return self._device().product_type

    @property
    def product_category(self) -> ProductCategory:
        return self._device().category

    @property
    def compact_daq_chassis_device(self) -> Device:
        found = self._device()
        if found.category != ProductCategory.C_SERIES_MODULE:
            raise errors.DaqError(f"Specified property is not supported by the device or is not applicable to the "
                                  f"task.\nProperty: DAQmx_Dev_CompactDAQ_ChassisDevName\nDevice: {self._name}",
                                  DAQmxErrors.ATTR_NOT_SUPPORTED)
        return Device(found.chassis)

    def reset_device(self) -> None:
        found = self._device()
        found.expired = False
        for name, simulated in nidaqmx.BEHAVIOUR.devices.items():
            if name == self._name or simulated.chassis == self._name:
                simulated.outputs_v = dict.fromkeys(simulated.outputs_v, 0.0)
