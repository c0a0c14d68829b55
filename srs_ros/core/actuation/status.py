"""What the hardware node reports, without ROS: its counters and faults, /diagnostics, latency figures, its log lines.

:class:`HardwareStatus` counts what the node does (setpoints taken, output changes, backend writes), keeps
its backend fault and whether the rig recovers by itself, and turns the counters into a
:class:`DiagnosticReport` (level, message, key/values) once a period; the node only wraps the report in a
``diagnostic_msgs/DiagnosticStatus`` (:func:`srs_ros.ros.interfaces.diagnostic_status`). The functions at the
end word what the node says at configure, on an output change, a stall and at exit.

Example::

    status = HardwareStatus()
    status.count_setpoint(take_setpoint(setpoint, shaper, gate, now_ns, now_s))
    report = status.report(now_s, NodeSetup(rig="mock", backend="mock", backend_open=True,
                                            lifecycle_state="active", configured=True), gate, shaper)
    report.level, report.message  # "OK", "commanding"
"""

from __future__ import annotations

import collections
import dataclasses
import math
from collections.abc import Iterable

import numpy as np

from srs_ros.core.actuation.compensation import SetpointShaper
from srs_ros.core.actuation.intake import IntakeDecision, Verdict
from srs_ros.core.actuation.safety import VENT_FAILED, CommandGate, OutputReason, StampCheck, min_setpoint_rate_hz
from srs_ros.core.actuation.timing import CommandTiming
from srs_ros.core.rig import RigConfig

#: Setpoint -> backend write latencies kept for the figures (the last this many written setpoints).
LATENCY_WINDOW = 2000
#: Output reasons under which the backend is sent the setpoint's command (not 0 bar).
SENDING = (OutputReason.COMMANDING, OutputReason.RAMPING)


@dataclasses.dataclass(frozen=True)
class NodeSetup:
    """What the node has open at a report: rig and backend names, the lifecycle state, its runtime interfaces."""

    rig: str = "none"
    backend: str = "none"
    backend_open: bool = False
    lifecycle_state: str = "unconfigured"
    configured: bool = False  # the command timer, the publishers and the setpoint subscription exist


@dataclasses.dataclass(frozen=True)
class DiagnosticReport:
    """One /diagnostics report: level (``"OK"``, ``"WARN"``, ``"ERROR"``), a message for people, key/values."""

    level: str
    message: str
    values: dict[str, str]


@dataclasses.dataclass
class HardwareStatus:
    """The hardware node's counters and messages, and what they say on /diagnostics."""

    ticks: int = 0
    setpoints_received: int = 0
    setpoints_accepted: int = 0
    rejected_setpoints: int = 0
    ignored_velocities: int = 0  # setpoints whose velocities were unusable (NaN, wrong size): lengths used alone
    setpoints_while_unconfigured: int = 0  # queued before a release (fault, cleanup), dropped after it
    stale_on_arrival: int = 0
    future_stamped: int = 0
    limited_setpoints: int = 0  # accepted, but some length needed more than the pressure limit
    stale_vents: int = 0  # times the output went from commanding to 0 bar because setpoints went stale
    arrival_age_max_s: float = 0.0  # oldest stamp age at arrival since the last diagnostics message
    clock_offset_s: float = 0.0  # the latest stamp-vs-clock difference that was out of bounds
    last_error: str = ""
    fault: str = ""  # set by a backend failure, cleared by the next successful configure
    recovers_by_itself: bool = False  # the faulted rig (sim) is configured again by the node, at the last fault
    reactivate: bool = False  # ... and activated again: it was active at the last fault
    holding: str = ""  # why the backend holds output at 0 bar right now (a paused simulator), '' if it does not
    holds: int = 0  # times output went to 0 bar because the backend held (a paused simulator)
    recoveries: int = 0  # times a rig that recovers by itself (sim) was configured and activated again after a fault
    reason: OutputReason = OutputReason.INACTIVE
    # (time s, ticks, setpoints received, stamp problems) at the previous diagnostics
    rate_window: tuple[float, int, int, int] = (math.nan, 0, 0, 0)
    pending_stamp_ns: int = 0  # stamp of an accepted setpoint not yet written (for the latency figure)
    latency_ms: collections.deque = dataclasses.field(
        default_factory=lambda: collections.deque(maxlen=LATENCY_WINDOW))

    # -- counting -----------------------------------------------------------------------------
    def count_setpoint(self, decision: IntakeDecision) -> None:
        """Count what the intake did with one setpoint (:func:`~srs_ros.core.actuation.intake.take_setpoint`)."""
        if decision.verdict is not Verdict.ACCEPTED:
            self.rejected_setpoints += 1
        if decision.stamp is None:  # invalid lengths: nothing else was looked at
            return
        self.ignored_velocities += bool(decision.velocity_note)
        self.arrival_age_max_s = max(self.arrival_age_max_s, decision.age_s)
        self.stale_on_arrival += decision.stamp is StampCheck.STALE
        self.future_stamped += decision.stamp is StampCheck.FUTURE
        if decision.clock_offset_s is not None:
            self.clock_offset_s = decision.clock_offset_s
        if decision.accepted:
            self.limited_setpoints += bool(decision.limit_note)
            self.setpoints_accepted += 1
            self.pending_stamp_ns = decision.stamp_ns

    def note_reason(self, reason: OutputReason) -> bool:
        """Note why the output is what it is now; True if that changed (stale vents and holds are counted)."""
        if reason is self.reason:
            return False
        self.stale_vents += reason is OutputReason.STALE and self.reason in SENDING
        self.holds += reason is OutputReason.HOLDING
        self.reason = reason
        return True

    def note_write(self, reason: OutputReason, holding: str, now_ns: int) -> None:
        """Count one backend write under ``reason`` at ``now_ns`` (ns, the stamps' clock), the backend ``holding``.

        The first write that sends a stamped setpoint's command gives a stamp -> write latency figure.
        """
        if self.pending_stamp_ns and reason in SENDING:
            self.latency_ms.append((now_ns - self.pending_stamp_ns) * 1e-6)
        self.pending_stamp_ns = 0
        self.ticks += 1
        self.holding = holding

    def start_rate_window(self, now_s: float) -> None:
        """Measure the rates of the next report from ``now_s`` (s, steady clock; at configure)."""
        self.rate_window = (now_s, self.ticks, self.setpoints_received, self.stale_on_arrival + self.future_stamped)

    def released(self) -> None:
        """The backend was closed: output inactive, nothing held."""
        self.reason = OutputReason.INACTIVE
        self.holding = ""

    # -- faults -------------------------------------------------------------------------------
    def note_fault(self, fault: str, recovers_by_itself: bool, was_active: bool) -> None:
        """A backend failed while commanding (``fault`` says how); its node vents and goes through error processing.

        A rig that ``recovers_by_itself`` (the simulated robot) is configured again by the node, and activated
        again if it ``was_active``; a real rig waits for the operator.
        """
        self.fault, self.recovers_by_itself, self.reactivate = fault, recovers_by_itself, was_active

    def error_processed(self, retry_period_s: float) -> str:
        """What the node says once error processing closed the backend; the retry every ``retry_period_s`` (s)."""
        fault = self.fault or self.last_error
        if not self.recovers_by_itself:
            return ("error processing done: backend closed, node unconfigured; configure and activate to recover "
                    f"(fault: {fault})")
        return (f"error processing done: backend closed, node unconfigured (fault: {fault}); the simulated rig "
                f"recovers by itself: configure{' + activate' if self.reactivate else ''} in {retry_period_s:g} s")

    def recovered(self, lifecycle_state: str) -> str:
        """Count a recovery by the node itself (now ``lifecycle_state``) and say it."""
        self.recovers_by_itself = self.reactivate = False
        self.recoveries += 1
        return (f"recovered by itself after a fault: {lifecycle_state}, holding 0 bar until the simulated robot "
                "answers, then ramping up")

    # -- reporting ----------------------------------------------------------------------------
    def report(self, now_s: float, setup: NodeSetup, gate: CommandGate,
               shaper: SetpointShaper | None) -> DiagnosticReport:
        """The report at ``now_s`` (s, steady clock): rates since the previous report, which starts the next window."""
        then_s, then_ticks, then_received, then_problems = self.rate_window
        span_s = now_s - then_s if now_s > then_s and setup.configured else math.inf
        setpoint_rate_hz = (self.setpoints_received - then_received) / span_s
        problems = self.stale_on_arrival + self.future_stamped
        self.rate_window = (now_s, self.ticks, self.setpoints_received, problems)
        arrival_age_max_s, self.arrival_age_max_s = self.arrival_age_max_s, 0.0
        level, message = self.summary(setup, gate, setpoint_rate_hz, problems - then_problems)
        values = {
            "backend": setup.backend,
            "backend_open": str(setup.backend_open),
            "rig": setup.rig,
            "lifecycle_state": setup.lifecycle_state,
            "output": self.reason.value if setup.configured else "not configured",
            "requires_arm": str(gate.requires_arm),
            "armed": str(gate.armed),
            "command_rate_hz": f"{(self.ticks - then_ticks) / span_s:.1f}",
            "setpoint_rate_hz": f"{setpoint_rate_hz:.1f}",
            "setpoint_age_s": f"{gate.setpoint_age_s(now_s):.3f}",
            "setpoint_timeout_s": f"{gate.setpoint_timeout_s:g}",
            "estop_latched": str(gate.estop_latched),
            **self._counter_values(gate, shaper),
            "setpoint_arrival_age_max_ms": f"{arrival_age_max_s * 1e3:.3f}",
            "backend_writes": str(self.ticks),
            **latency_figures(self.latency_ms),
            "last_error": self.last_error or "none",
        }
        return DiagnosticReport(level, message, values)

    def _counter_values(self, gate: CommandGate, shaper: SetpointShaper | None) -> dict[str, str]:
        return {
            "setpoints_received": str(self.setpoints_received),
            "setpoints_accepted": str(self.setpoints_accepted),
            "rejected_setpoints": str(self.rejected_setpoints),
            "ignored_velocities": str(self.ignored_velocities),
            "setpoints_while_unconfigured": str(self.setpoints_while_unconfigured),
            "stale_on_arrival": str(self.stale_on_arrival),
            "future_stamped": str(self.future_stamped),
            "clock_offset_s": f"{self.clock_offset_s:.3f}",
            "limited_setpoints": str(self.limited_setpoints),
            "pressure_map": shaper.map.name if shaper else "none",
            "lag_compensation": str(bool(shaper and shaper.compensation)),
            "compensation_clamped": str(shaper.compensation_clamped if shaper else 0),
            "stale_vents": str(self.stale_vents),
            "command_stalls": str(gate.stalls),
            "holding": self.holding or "none",
            "holds": str(self.holds),
            "recoveries": str(self.recoveries),
        }

    def summary(self, setup: NodeSetup, gate: CommandGate, setpoint_rate_hz: float,
                stamp_problems: int) -> tuple[str, str]:
        """The level and message: a fault first, then the e-stop, a slow stream, clock trouble, a vent or a hold.

        ``setpoint_rate_hz`` (Hz) and ``stamp_problems`` (stale or future stamps) are those of the last period.
        """
        if self.fault:
            then = ("the simulated rig recovers by itself" if self.recovers_by_itself
                    else "configure and activate to recover")
            return "ERROR", f"backend fault: {self.fault}; {then}"
        if gate.estop_latched:
            return "WARN", "e-stop latched: venting until ~/reset"
        if not setup.configured:
            return "OK", "unconfigured: backend closed, nothing sent"
        slowest_hz = min_setpoint_rate_hz(gate.setpoint_timeout_s)
        if 0.0 < setpoint_rate_hz < slowest_hz:
            return "WARN", (f"setpoints arrive at {setpoint_rate_hz:.1f} Hz, fewer than two per setpoint_timeout_s "
                            f"({gate.setpoint_timeout_s:g} s): the valves pulse; raise the player's rate_hz to at "
                            f"least {slowest_hz:g} Hz")
        if stamp_problems:
            return "WARN", (f"{self.reason.value}; {stamp_problems} setpoint stamps in the last period were stale "
                            f"on arrival or from the future (latest offset {self.clock_offset_s:+.3f} s): a stall or "
                            "a clock offset between hosts (sync the clocks)")
        if self.reason is OutputReason.STALE:
            return "WARN", "setpoints stale: venting to 0 bar"
        if self.reason is OutputReason.HOLDING:
            return "WARN", f"holding at 0 bar: {self.holding}; output ramps back in when it answers"
        return "OK", self.reason.value


def latency_figures(latency_ms: Iterable[float]) -> dict[str, str]:
    """Setpoint stamp -> backend write latency (ms): median, 99th percentile, largest and count, as text."""
    samples = np.fromiter(latency_ms, float)
    if samples.size == 0:
        return {"command_latency_p50_ms": "n/a", "command_latency_p99_ms": "n/a", "command_latency_max_ms": "n/a",
                "command_latency_count": "0"}
    p50, p99, worst = np.percentile(samples, [50, 99, 100])
    return {"command_latency_p50_ms": f"{p50:.3f}", "command_latency_p99_ms": f"{p99:.3f}",
            "command_latency_max_ms": f"{worst:.3f}", "command_latency_count": str(samples.size)}


def configured_message(rig: RigConfig, backend: str, gate: CommandGate, timing: CommandTiming,
                       shaper: SetpointShaper) -> str:
    """What the node says once configured: rig, ``backend``, what it takes to command, rates, limit, the map."""
    arm = ("real regulators: nothing above 0 bar until an operator calls ~/arm" if gate.requires_arm
           else "simulated: no arm needed" if gate.has_go else "simulated, disarmed: 0 bar until ~/arm")
    return (f"configured: rig {rig.name!r}, backend {backend!r} ({arm}), {timing.command_rate_hz:g} Hz, "
            f"setpoint timeout {timing.setpoint_timeout_s:g} s, limit {rig.robot.max_pressure_bar:g} bar, "
            f"{shaper.map.describe()}, lag compensation {'on' if shaper.compensation else 'off'}")


def stall_message(max_gap_s: float) -> str:
    """What the node says when its command ticks stalled longer than ``max_gap_s`` (s) and output restarts."""
    return (f"command ticks stalled longer than {max_gap_s:g} s (this process was frozen or starved of CPU; see "
            "realtime_priority): output restarts with a ramp from 0 bar")


def exit_message(program: str, vented: bool, was_open: bool) -> str:
    """The last line of a node process: the vent (``vented``), nothing to vent (not ``was_open``) or VENT FAILED."""
    outcome = VENT_FAILED if not vented else ("every valve vented to 0 bar" if was_open
                                              else "no backend was open, nothing to vent")
    return f"{program}: stopped; {outcome}"


def output_message(reason: OutputReason, setpoint_timeout_s: float, holding: str = "") -> str:
    """What the node says when the output changes to ``reason`` (the backend ``holding`` for HOLDING)."""
    if reason is OutputReason.STALE:
        return f"output: {reason.value} (older than {setpoint_timeout_s:g} s) -> 0 bar"
    if reason is OutputReason.HOLDING:
        return f"output: {reason.value}: {holding}; ramps back in when it answers"
    return f"output: {reason.value}" + ("" if reason in SENDING else " -> 0 bar")
