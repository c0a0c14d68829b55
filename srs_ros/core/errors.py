"""The srs_ros error tree: callers catch the branch they can handle (python-can style)."""


class SrsError(Exception):
    """Base of every error srs_ros raises on purpose."""


class ConfigurationError(SrsError, ValueError):
    """A configuration file, parameter or option is missing, mistyped or out of range."""


class InvalidInputError(SrsError, ValueError):
    """An argument (array shape, NaN, unknown name, out-of-range value) cannot be used."""


class FitError(SrsError, RuntimeError):
    """A fit did not reach an acceptable solution (a gait shape, a muscle's characteristic or dynamics)."""


class HardwareError(SrsError, RuntimeError):
    """The actuator hardware (bus, DAQ card, regulator) failed or cannot be reached."""


class BackendUnavailableError(HardwareError):
    """A backend's driver or library is not installed on this machine."""


class SimulationError(SrsError, RuntimeError):
    """The simulated world diverged (non-finite or exploding state) and cannot give a pose."""


class ClusterError(SrsError, RuntimeError):
    """The workers of the offline runs (a Dask cluster) cannot be reached, cannot be used or run other code."""
