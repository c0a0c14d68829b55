"""Fake ``nidaqmx.system``: ``Device`` and ``WatchdogTask`` as NI's package exports them."""

from nidaqmx.system.device import Device
from nidaqmx.system.watchdog import AOExpirationState, WatchdogTask

__all__ = ["AOExpirationState", "Device", "WatchdogTask"]
