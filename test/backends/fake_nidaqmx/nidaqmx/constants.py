"""Fake ``nidaqmx.constants``: the enums the backend uses, with NI's values."""

from enum import Enum


class WatchdogAOExpirState(Enum):
    VOLTAGE = 10322
    CURRENT = 10134
    NO_CHANGE = 10160


class WDTTaskAction(Enum):
    RESET_TIMER = 0
    CLEAR_EXPIRATION = 1


class ProductCategory(Enum):
    M_SERIES_DAQ = 14643
    X_SERIES_DAQ = 15858
    AO_SERIES = 14647
    COMPACT_DAQ_CHASSIS = 14658
    C_SERIES_MODULE = 14659
    UNKNOWN = 12588
