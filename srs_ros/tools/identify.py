"""``srs_identify``: measure each muscle of a rig and write its calibration file (docs/identification.md).

It steps the regulators from vented to a series of levels (or plays a chirp), venting after every
step, through the rig's backend and the one clamp, and records the regulators' pressure read-back
and the muscles' lengths where the rig measures them (the simulated rigs do; a real rig's lengths
come from a ruler-and-pressure table, ``--length-table``). Per muscle it fits the static
characteristic (deadzone, extension per bar, saturation) and the supply line's dynamics (transport
delay, first-order time constant) and writes them to a calibration file that the hardware node
reads (``calibration_file``, ``pressure_map: calibrated``, ``lag_compensation``).

A rig with real regulators needs the operator's go (``--yes`` or a typed yes). Ctrl-C or SIGTERM
vents every regulator at once. A rig that cannot measure what is asked is refused before any air.

Exit codes: 0 done, 1 hardware failure or a fit that failed, 2 bad arguments, configuration or
refusal, 130 interrupted.
"""

from __future__ import annotations

import argparse
import datetime
import math
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from srs_ros.backends import BACKENDS, ActuatorBackend
from srs_ros.core.actuation.identification import (
    DEFAULT_MAX_DELAY_S,
    SETTLED_SHARE,
    CommandPlan,
    Identification,
    Measurement,
    Recording,
    Step,
    chirp_plan,
    identify,
    read_length_table,
    step_plan,
)
from srs_ros.core.actuation.muscle_calibration import (
    DYNAMIC_KEYS,
    STATIC_KEYS,
    MuscleCalibration,
    calibration_from_values,
    load_calibration,
    save_calibration,
)
from srs_ros.core.actuation.muscle_model import MUSCLE_OPTIONS
from srs_ros.core.actuation.paused_runs import run_plan_through_pauses
from srs_ros.core.errors import ConfigurationError, FitError, HardwareError
from srs_ros.core.rig import RigConfig, default_rig_path, load_rig
from srs_ros.core.robot import RobotDescription, load_robot
from srs_ros.tools.output import prepare_output_file
from srs_ros.tools.rig_session import (
    EXIT_HARDWARE,
    EXIT_OK,
    EXIT_USAGE,
    backend_for,
    interrupts_on_sigterm,
    operator_go,
    ros_context,
    run_vented,
    write_whole,
)
from srs_ros.tools.wiring_check import select_joints

PROGRAM = "srs_identify"
DEFAULT_LEVELS_BAR = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0)
DEFAULT_HOLD_S = 1.0
DEFAULT_VENT_S = 0.5
MAX_HOLD_S = 60.0
#: Share of the hardware's own vent-on-silence timeout a command may be late before its step is run again.
HARDWARE_TIMEOUT_SHARE = 0.8


class BackendIO:
    """A backend as identification's :class:`~srs_ros.core.actuation.identification.RigIO`, on ``clock`` (s).

    A measurement is dated by the backend's read-back age where it reports one (the sim backend's
    ``monitor_age_s``, the CAN board's ``readback_age_s``), so the delay fitted is the line's.
    ``clock`` and ``sleep`` may be replaced to run a simulated backend faster than real time.
    """

    def __init__(self, backend: ActuatorBackend, clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep):
        """Drive ``backend`` (open) on ``clock``, waiting with ``sleep``."""
        self.backend, self.clock, self.sleep = backend, clock, sleep

    def now_s(self) -> float:
        """The clock (s)."""
        return self.clock()

    def wait_until(self, time_s: float) -> None:
        """Sleep until ``time_s``."""
        remaining_s = time_s - self.clock()
        if remaining_s > 0.0:
            self.sleep(remaining_s)

    def write_pressures(self, pressure_bar: np.ndarray) -> np.ndarray:
        """One command through the backend's final ``write_pressures`` (the one clamp)."""
        return write_whole(self.backend, pressure_bar)

    def measure(self) -> Measurement:
        """The backend's newest read-back, dated by its age."""
        now_s = self.clock()
        state = self.backend.read_state()
        ages = [v for v in np.ravel(state.details.get("monitor_age_s", state.details.get("readback_age_s", 0.0)))
                if math.isfinite(v)]
        return Measurement(now_s - (float(np.mean(ages)) if ages else 0.0), state.measured_pressure_bar,
                           state.measured_length_m)


def build_parser() -> argparse.ArgumentParser:
    """The command line of ``srs_identify``."""
    parser = argparse.ArgumentParser(
        prog=PROGRAM,
        description="Measure each muscle of a rig (deadzone, extension per bar, saturation, supply-line delay and "
                    "lag) and write the rig's calibration file. Vents between steps; Ctrl-C vents at once.")
    parser.add_argument("--rig", default=str(default_rig_path()), help="rig file (config/rigs/*.yaml)")
    parser.add_argument("--backend", choices=sorted(BACKENDS), help="override the rig's backend")
    parser.add_argument("--robot", help="robot description file (default: the package's config/robot.yaml)")
    parser.add_argument("--out", help="calibration file to write (default: <rig name>_calibration.yaml here); an "
                                      "existing one keeps the values of what this run does not identify")
    parser.add_argument("--channels", nargs="+", metavar="JOINT",
                        help="muscles to identify, by joint name or number 1..9 (default: all)")
    parser.add_argument("--together", action="store_true",
                        help="step the selected muscles at once (faster) instead of one after the other")
    parser.add_argument("--levels", nargs="+", type=float, default=list(DEFAULT_LEVELS_BAR), metavar="BAR",
                        help="step levels in bar, within (0, max_pressure_bar] (default: 0.5 to 4 by 0.5)")
    parser.add_argument("--hold-s", type=float, default=DEFAULT_HOLD_S,
                        help=f"seconds each step is held; at least delay + 5 time constants (default {DEFAULT_HOLD_S})")
    parser.add_argument("--vent-s", type=float, default=DEFAULT_VENT_S,
                        help=f"seconds vented after each step (default {DEFAULT_VENT_S})")
    parser.add_argument("--signal", choices=("steps", "chirp"), default="steps",
                        help="what the dynamics are fitted on: the steps, or a chirp played after them")
    parser.add_argument("--chirp-bar", nargs=2, type=float, default=(1.0, 3.0), metavar=("LOW", "HIGH"),
                        help="chirp pressure range in bar (default 1 3)")
    parser.add_argument("--chirp-hz", nargs=2, type=float, default=(0.2, 4.0), metavar=("START", "END"),
                        help="chirp frequencies in Hz (default 0.2 4)")
    parser.add_argument("--chirp-s", type=float, default=10.0, help="chirp duration per group in s (default 10)")
    what = parser.add_mutually_exclusive_group()
    what.add_argument("--static-only", action="store_true", help="only the static characteristic")
    what.add_argument("--dynamics-only", action="store_true", help="only the delay and the time constant")
    parser.add_argument("--length-table", metavar="CSV",
                        help="measured lengths for a rig that cannot measure them: CSV joint,pressure_bar,length_m "
                             "(a ruler at held pressures); the static characteristic is fitted from it")
    parser.add_argument("--max-delay-s", type=float, default=DEFAULT_MAX_DELAY_S,
                        help=f"largest transport delay searched, s (default {DEFAULT_MAX_DELAY_S:g})")
    parser.add_argument("--startup-timeout-s", type=float, default=20.0,
                        help="how long to wait for the rig's first read-back, s (default 20; sim_world builds first)")
    parser.add_argument("--yes", action="store_true", help="the operator's go for a rig with real regulators")
    return parser


#: Commands the settled end of a step (its last SETTLED_SHARE) must span at least, for a read-back to average.
SETTLED_COMMANDS = 2


def _check_arguments(parser: argparse.ArgumentParser, args: argparse.Namespace, rig: RigConfig) -> None:
    limit = rig.robot.max_pressure_bar
    for level in [*args.levels, *args.chirp_bar]:
        if not (math.isfinite(level) and 0.0 < level <= limit):
            parser.error(f"pressure {level:g} bar: expected levels within (0, {limit:g}] bar (max_pressure_bar)")
    if len(set(args.levels)) < 3:
        parser.error(f"--levels {args.levels}: expected at least three distinct levels (below and above the deadzone)")
    for flag, value, high in (("--hold-s", args.hold_s, MAX_HOLD_S), ("--vent-s", args.vent_s, MAX_HOLD_S),
                              ("--chirp-s", args.chirp_s, 600.0),
                              ("--max-delay-s", args.max_delay_s, MUSCLE_OPTIONS["transport_delay_s"].maximum),
                              ("--startup-timeout-s", args.startup_timeout_s, 600.0)):
        if not (math.isfinite(value) and 0.0 < value <= high):
            parser.error(f"{flag} {value:g}: expected seconds in (0, {high:g}]")
    settled_s, commands_s = SETTLED_SHARE * args.hold_s, SETTLED_COMMANDS / rig.command_rate_hz
    if settled_s < commands_s:  # no settled read-back to fit: it failed later as "the machine is too busy"
        parser.error(f"--hold-s {args.hold_s:g}: its settled last {SETTLED_SHARE:.0%} ({settled_s:g} s) is shorter "
                     f"than {SETTLED_COMMANDS} commands at the rig's {rig.command_rate_hz:g} Hz; expected at least "
                     f"{commands_s / SETTLED_SHARE:g} s")
    if args.chirp_bar[0] >= args.chirp_bar[1] or not (0.0 < args.chirp_hz[0] < args.chirp_hz[1] <= 50.0):
        parser.error("--chirp-bar LOW HIGH and --chirp-hz START END: expected LOW < HIGH and 0 < START < END <= 50")


def _plan(args: argparse.Namespace, rig: RigConfig, joints: list[int], steps: bool, chirp: bool) -> CommandPlan:
    groups = [joints] if args.together else [[j] for j in joints]
    count, rate = rig.robot.joint_count, rig.command_rate_hz
    plan = step_plan(count, rate, sorted(set(args.levels)), args.hold_s, args.vent_s, groups) if steps else None
    if chirp:
        played = chirp_plan(count, rate, groups, *args.chirp_bar, *args.chirp_hz, args.chirp_s, args.vent_s)
        plan = played if plan is None else plan.then(played)
    return plan


def _refusal(backend: ActuatorBackend, static: bool, dynamics: bool, table: bool) -> str:
    """Why this rig cannot measure what is asked ('' when it can)."""
    if static and not table and not backend.measures_length:
        return (f"the {backend.name} rig measures no muscle lengths, so the static characteristic cannot be measured "
                "here: hold each muscle at a few pressures, measure its extension (ruler or camera) and pass the table "
                "with --length-table FILE (CSV joint,pressure_bar,length_m), or run --dynamics-only.")
    if dynamics and not backend.measures_pressure:
        return (f"the {backend.name} rig reports no pressure read-back, so the delay and the time constant cannot be "
                "measured: enable the regulators' monitor read-back (CAN: readback: true with MON_CH signals), or run "
                "--static-only with --length-table.")
    return ""


def _base_values(out: Path, robot: RobotDescription) -> dict[str, dict[str, float]]:
    """The values of an existing calibration file (the part this run keeps), else nothing."""
    if not out.exists():
        return {}
    calibration = load_calibration(out, robot)
    return {name: calibration.muscle_values(i) for i, name in enumerate(calibration.joint_names)}


def _merged(base: dict[str, dict[str, float]], found: Identification) -> dict[str, dict[str, float]]:
    values = {name: dict(entry) for name, entry in base.items()}
    for name, entry in found.values.items():
        values.setdefault(name, {}).update(entry)
    return values


def _check_complete(base, robot: RobotDescription, joints: list[int], static: bool, dynamics: bool,
                    out: Path) -> None:
    """Refuse before any air when the result could not make a whole calibration file."""
    planned = Identification()
    for joint in joints:
        entry = planned.values.setdefault(robot.joint_names[joint], {})
        if static:
            entry.update(deadzone_bar=0.0, extension_per_bar_m=0.01, saturation_bar=robot.max_pressure_bar)
        if dynamics:
            entry.update(transport_delay_s=0.0, pressure_time_constant_s=0.0)
    try:
        calibration_from_values(_merged(base, planned), robot, source=str(out))
    except ConfigurationError as exc:
        raise ConfigurationError(f"this run alone cannot complete the calibration file: {exc}") from None


def _report(calibration: MuscleCalibration, found: Identification, robot: RobotDescription) -> str:
    limit = robot.max_pressure_bar
    paper_m = limit / robot.pressure_per_length_bar_per_m
    lines = [f"{'muscle':9} {'deadzone':>9} {'gain':>12} {'saturation':>16} {'at ' + format(limit, 'g') + ' bar':>10} "
             f"{'vs P=100 l':>10} {'delay':>8} {'tau':>8}"]
    at_limit_m = calibration.extension_m(np.full(len(calibration.joint_names), limit))
    for i, name in enumerate(calibration.joint_names):
        mark = "" if name in found.values else "  (kept from the file)"
        seen = found.fit.get(name, {}).get("saturation_seen", True)
        dyn = (f"{calibration.transport_delay_s[i] * 1e3:6.1f}ms {calibration.pressure_time_constant_s[i] * 1e3:6.1f}ms"
               if calibration.has_dynamics else f"{'-':>8} {'-':>8}")
        lines.append(f"{name:9} {calibration.deadzone_bar[i]:7.2f}bar {calibration.extension_per_bar_m[i] * 1e3:7.2f}"
                     f"mm/bar {calibration.saturation_bar[i]:7.2f}bar{'' if seen else ' (n/r)':6} "
                     f"{at_limit_m[i] * 1e3:8.1f}mm {100 * (at_limit_m[i] / paper_m - 1):+9.0f}% {dyn}{mark}")
    lines.append(f"(n/r: no knee up to the highest pressure tested; 'vs P=100 l': extension at {limit:g} bar against "
                 f"the {paper_m * 1e3:.0f} mm the paper's map plans)")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    """Console entry point; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    static, dynamics = not args.dynamics_only, not args.static_only
    try:
        robot = load_robot(args.robot) if args.robot else None
        rig = load_rig(args.rig, robot)
        _check_arguments(parser, args, rig)
        joints = select_joints(args.channels, rig.robot.joint_names)
        out = prepare_output_file(args.out or f"{rig.name}_calibration.yaml", "--out")  # before any air
        table = read_length_table(args.length_table, rig.robot) if args.length_table else None
        backend = backend_for(rig, args.backend)
        refusal = _refusal(backend, static, dynamics, table is not None)
        if not refusal:
            base = _base_values(out, rig.robot)
            _check_complete(base, rig.robot, joints, static, dynamics, out)
    except (ConfigurationError, ValueError) as exc:
        print(f"{PROGRAM}: error: {exc}", file=sys.stderr, flush=True)
        return EXIT_USAGE
    if refusal:
        print(f"{PROGRAM}: refused: {refusal}", file=sys.stderr, flush=True)
        return EXIT_USAGE

    recording = plan = None
    if dynamics or (static and table is None):
        plan = _plan(args, rig, joints, steps=(static and table is None) or args.signal == "steps",
                     chirp=dynamics and args.signal == "chirp")
        what = (f"{len(joints)} muscle(s) up to {plan.pressure_bar.max():g} bar for {plan.duration_s:.0f} s"
                + (", together" if args.together else ", one at a time"))
        refusal = operator_go(backend, what, args.yes, PROGRAM)
        if refusal:
            print(f"{PROGRAM}: refused: {refusal}", file=sys.stderr, flush=True)
            return EXIT_USAGE
        with interrupts_on_sigterm(), ros_context(backend):
            code, recording, plan = _open_and_run(backend, rig, plan, args)
        if code != EXIT_OK:
            return code
    try:
        found = identify(rig.robot, joints, recording, plan, static=static, dynamics=dynamics, length_table=table,
                         max_delay_s=args.max_delay_s)
        info = {"rig": rig.name, "created": datetime.datetime.now().isoformat(timespec="seconds"),
                "method": (plan.description if plan else "") + (f"; lengths from {args.length_table}" if table else ""),
                "fit": {name: {k: (float(f"{v:.4g}") if isinstance(v, float) else v) for k, v in fit.items()}
                        for name, fit in found.fit.items()}}
        calibration = calibration_from_values(_merged(base, found), rig.robot, info, str(out))
    except (FitError, ConfigurationError) as exc:
        print(f"{PROGRAM}: identification failed: {exc}", file=sys.stderr, flush=True)
        return EXIT_HARDWARE
    print(_report(calibration, found, rig.robot), flush=True)
    for warning in found.warnings:
        print(f"warning: {warning}", flush=True)
    save_calibration(calibration, out, header=(
        f"Muscle calibration of rig '{rig.name}' ({rig.source}), written by {PROGRAM}; docs/identification.md.\n"
        f"Use: hardware_node -p calibration_file:={out} -p pressure_map:=calibrated -p lag_compensation:=true"))
    keys = [*(STATIC_KEYS if static else ()), *(DYNAMIC_KEYS if dynamics else ())]
    print(f"wrote {out}: {', '.join(keys)} of {len(joints)} muscle(s)", flush=True)
    return EXIT_OK


def _wait_for_readback(backend: ActuatorBackend, rig: RigConfig, io: BackendIO, timeout_s: float) -> None:
    """Vent at the command rate until the rig's first measurement arrives (sim_world may still be building)."""
    end_s = io.now_s() + timeout_s
    while True:
        backend.vent()
        state = backend.read_state()
        if state.measured_pressure_bar is not None or state.measured_length_m is not None:
            return
        if io.now_s() >= end_s:
            raise HardwareError(f"no read-back from the {backend.name} rig within {timeout_s:g} s (is sim_world "
                                "running on this ROS_DOMAIN_ID? is the regulators' monitor wired?)")
        io.wait_until(io.now_s() + 1.0 / rig.command_rate_hz)


def _max_late_s(backend: ActuatorBackend, rig: RigConfig) -> float:
    """How late a command may go out before its part of the plan is run again (s).

    No hardware node stands between this tool and the rig, so what vents is the hardware's own timeout
    (a CAN board's, an NI watchdog's, sim_world's board): 80 % of it. Hardware that holds its last command
    for ever has none, and the rig's setpoint timeout stands in (a step started that late is short).
    """
    timeout_s = backend.silence_vent_s  # where only some outputs have a watchdog, theirs
    return HARDWARE_TIMEOUT_SHARE * timeout_s if timeout_s is not None else rig.setpoint_timeout_s


def _open_and_run(backend: ActuatorBackend, rig: RigConfig, plan: CommandPlan,
                  args: argparse.Namespace) -> tuple[int, Recording | None, CommandPlan]:
    """Run ``plan`` on the open rig; the exit code, the recording and the plan it belongs to (parts run again)."""
    names = rig.robot.joint_names
    io = BackendIO(backend)
    runs = []
    numbers = {(s.joints, s.level_bar): i + 1 for i, s in enumerate(plan.steps)}  # a step run again keeps its number

    def announce(index: int, step: Step) -> None:
        number = numbers.get((step.joints, step.level_bar), index + 1)
        print(f"step {number}/{len(plan.steps)}: {', '.join(names[j] for j in step.joints)} at "
              f"{step.level_bar:g} bar", flush=True)

    def measure() -> None:
        print(f"{PROGRAM}: rig {rig.name!r} ({backend.name} backend): {plan.description}; "
              f"{plan.duration_s:.1f} s", flush=True)
        _wait_for_readback(backend, rig, io, args.startup_timeout_s)
        max_late_s = _max_late_s(backend, rig)
        runs.append(run_plan_through_pauses(
            io, plan, max_late_s, on_step=announce, on_retry=lambda why: print(f"{PROGRAM}: {why}", flush=True),
            on_progress=lambda at_s: print(f"{PROGRAM}: {at_s:.0f} of {plan.duration_s:.0f} s sent", flush=True)))

    code = run_vented(backend, PROGRAM, measure, "measured")
    recording, ran = runs[0] if runs and code == EXIT_OK else (None, plan)
    return code, recording, ran


if __name__ == "__main__":
    sys.exit(main())
