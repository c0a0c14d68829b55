"""The hardware node's clocks, checked at configure without ROS: command rate, setpoint timeout and stall gap.

Three rules keep the watchdog honest (docs/safety.md):

- staleness is acted on at command ticks, so there are at least two commands per ``setpoint_timeout_s``
  (:func:`~srs_ros.core.actuation.safety.min_setpoint_rate_hz`): a slow tick would hold a stale pressure;
- hardware that vents by itself when the host falls silent (a CAN board, an NI watchdog) must outlast
  :data:`HOST_LOSS_COMMAND_PERIODS` command periods, or it would vent between commands;
- a gap between two command ticks longer than the setpoint timeout or that hardware timeout (the node itself
  stalled) restarts the output with a ramp (:attr:`~srs_ros.core.actuation.safety.CommandGate.max_gap_s`).

Example::

    timing = command_timing(rig, state_publish_rate_hz=50.0)  # 0 = the rig's rate and timeout
    warning = timing.check_hardware("can", host_loss_timeout_s=0.1, drives_real_hardware=True)
    gate.max_gap_s = timing.stall_gap_s(0.1)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from srs_ros.core.actuation.safety import min_setpoint_rate_hz
from srs_ros.core.errors import ConfigurationError
from srs_ros.core.rig import RigConfig

#: The hardware's own vent-on-silence must outlast this many command periods.
HOST_LOSS_COMMAND_PERIODS = 3.0


@dataclass(frozen=True)
class CommandTiming:
    """The command rate (Hz), setpoint timeout (s) and actuator-state rate (Hz) of one configuration.

    Raises :class:`ConfigurationError` when the rate is too slow for the timeout (fewer than two
    commands per timeout).
    """

    command_rate_hz: float
    setpoint_timeout_s: float
    state_publish_rate_hz: float = math.inf

    def __post_init__(self) -> None:
        """Refuse a command rate that would hold a stale pressure for more than half a timeout."""
        slowest_hz = min_setpoint_rate_hz(self.setpoint_timeout_s)
        if self.command_rate_hz < slowest_hz:
            raise ConfigurationError(f"command_rate_hz is {self.command_rate_hz:g} Hz with setpoint_timeout_s "
                                     f"{self.setpoint_timeout_s:g} s; expected at least {slowest_hz:g} Hz (two "
                                     "commands per timeout).")

    @property
    def period_s(self) -> float:
        """Seconds between two commands."""
        return 1.0 / self.command_rate_hz

    @property
    def state_every_ticks(self) -> int:
        """Read and publish the actuator state every this many commands (at most the command rate)."""
        return max(1, round(self.command_rate_hz / min(self.state_publish_rate_hz, self.command_rate_hz)))

    def stall_gap_s(self, host_loss_timeout_s: float | None) -> float:
        """A gap between two commands (s) after which the hardware may have vented: output restarts with a ramp."""
        return min(self.setpoint_timeout_s, host_loss_timeout_s or math.inf)

    def check_hardware(self, hardware: str, host_loss_timeout_s: float | None, drives_real_hardware: bool,
                       silence_vent_s: float | None = None) -> str:
        """Check the hardware's own vent-on-silence (s, None = it has none) against the command period.

        ``silence_vent_s``: the shortest vent-on-silence of any output where only some have one (default
        ``host_loss_timeout_s``). Raises :class:`ConfigurationError` if an output would vent between commands;
        returns a warning for real hardware whose outputs do not all vent (they keep the last command if the host
        dies), else ''.
        """
        vents_s = host_loss_timeout_s if silence_vent_s is None else silence_vent_s
        if vents_s is not None and vents_s < HOST_LOSS_COMMAND_PERIODS * self.period_s:
            raise ConfigurationError(
                f"the {hardware} hardware vents after {vents_s:g} s without a command, less than three "
                f"command periods at command_rate_hz {self.command_rate_hz:g} Hz: it would vent between commands; "
                f"raise command_rate_hz to at least {HOST_LOSS_COMMAND_PERIODS / vents_s:g} Hz.")
        if host_loss_timeout_s is None and drives_real_hardware:
            return (f"the {hardware} hardware keeps its last command if this host dies (no watchdog): fit a dump "
                    "valve or relay on the supply (docs/safety.md)")
        return ""


def command_timing(rig: RigConfig, command_rate_hz: float = 0.0, setpoint_timeout_s: float = 0.0,
                   state_publish_rate_hz: float = math.inf) -> CommandTiming:
    """The node's timing from its parameters, where 0 means the rig's value (see :class:`CommandTiming`)."""
    return CommandTiming(command_rate_hz or rig.command_rate_hz, setpoint_timeout_s or rig.setpoint_timeout_s,
                         state_publish_rate_hz)
