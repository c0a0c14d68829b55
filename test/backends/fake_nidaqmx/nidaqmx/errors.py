"""Fake ``nidaqmx.errors``: the same class tree as NI's package (DaqNotFoundError is not a DaqError)."""

import warnings

from nidaqmx.error_codes import DAQmxErrors


class Error(Exception):
    """Base of every nidaqmx error."""


class DaqNotFoundError(Error):
    pass


class DaqError(Error):
    def __init__(self, message: str, error_code: int, task_name: str = ""):
        self._error_code = int(error_code)
        try:
            self._error_type = DAQmxErrors(self._error_code)
        except ValueError:
            self._error_type = DAQmxErrors.UNKNOWN
        if task_name:
            message = f"{message}\n\nTask Name: {task_name}"
        super().__init__(f"{message}\n\nStatus Code: {error_code}")

    @property
    def error_code(self) -> int:
        return self._error_code

    @property
    def error_type(self) -> DAQmxErrors:
        return self._error_type


class DaqWriteError(DaqError):
    def __init__(self, message: str, error_code: int, samps_per_chan_written: int, task_name: str = ""):
        super().__init__(message, error_code, task_name)
        self.samps_per_chan_written = samps_per_chan_written


class DaqResourceWarning(ResourceWarning):
    pass


def warn_double_close(name: str) -> None:
    warnings.warn(f'Attempted to close NI-DAQmx task of name "{name}" but task was already closed.',
                  DaqResourceWarning, stacklevel=3)
