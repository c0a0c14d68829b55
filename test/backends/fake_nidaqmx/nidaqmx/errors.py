"""Fake ``nidaqmx.errors``: the same class tree as NI's package (DaqNotFoundError is not a DaqError)."""


class Error(Exception):
    """Base of every nidaqmx error."""


class DaqError(Error):
    def __init__(self, message: str, error_code: int, task_name: str = ""):
        super().__init__(f"{message}\n\nStatus Code: {error_code}")
        self.error_code = error_code


class DaqWriteError(DaqError):
    pass


class DaqNotFoundError(Error):
    pass
