"""``srs_wiring_check``: pulse the nine regulators one at a time to check which muscle each channel drives.

Each pulse commands one regulator (through the one clamp, never above the pressure limit) for
``--hold-s`` seconds, resending at the rig's command rate, then vents for ``--vent-s`` seconds. It prints
the joint, the channel (CAN signal and frame, or NI physical channel) and the volts. Ctrl-C (or SIGTERM)
vents every regulator at once and exits with 130. A rig with real regulators (CAN, DAQ) needs the operator's go
first, as ``srs_identify``: ``--yes``, or a typed yes at a terminal; without it nothing is sent (exit 2).

Exit codes: 0 done, 1 hardware failure (or driver missing), 2 bad arguments, configuration or no go, 130 interrupted.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Sequence

import numpy as np

from srs_ros.backends import BACKENDS, ActuatorBackend
from srs_ros.core.errors import ConfigurationError
from srs_ros.core.rig import RigConfig, default_rig_path, load_rig
from srs_ros.core.robot import load_robot
from srs_ros.tools.rig_session import (
    EXIT_USAGE,
    backend_for,
    interrupts_on_sigterm,
    operator_go,
    ros_context,
    run_vented,
    wait_until_ready,
    write_whole,
)

DEFAULT_PRESSURE_BAR = 1.5
DEFAULT_HOLD_S = 1.0
DEFAULT_VENT_S = 0.5
MAX_HOLD_S = 60.0


def build_parser() -> argparse.ArgumentParser:
    """The command line of ``srs_wiring_check``."""
    parser = argparse.ArgumentParser(
        prog="srs_wiring_check",
        description="Pulse each pressure regulator in turn and print which joint and channel it drives. "
                    "Ctrl-C vents every regulator at once.")
    parser.add_argument("--rig", default=str(default_rig_path()),
                        help="rig file (config/rigs/*.yaml): backend, its options, regulator model, command rate")
    parser.add_argument("--backend", choices=sorted(BACKENDS),
                        help="override the rig's backend (its backend_options are used only for the rig's own backend)")
    parser.add_argument("--robot", help="robot description file (default: the package's config/robot.yaml)")
    parser.add_argument("--pressure-bar", type=float, default=DEFAULT_PRESSURE_BAR,
                        help="pulse pressure in bar, above 0 and at most the robot's max_pressure_bar "
                             f"(default {DEFAULT_PRESSURE_BAR})")
    parser.add_argument("--hold-s", type=float, default=DEFAULT_HOLD_S,
                        help=f"seconds each pulse is held (default {DEFAULT_HOLD_S})")
    parser.add_argument("--vent-s", type=float, default=DEFAULT_VENT_S,
                        help=f"seconds vented between pulses (default {DEFAULT_VENT_S})")
    parser.add_argument("--channels", nargs="+", metavar="JOINT",
                        help="regulators to pulse, by joint name (m1_pma1) or number 1..9 (default: all, in order)")
    parser.add_argument("--yes", action="store_true", help="the operator's go for a rig with real regulators "
                                                            "(robot clear, someone at the supply valve)")
    return parser


def select_joints(tokens: Sequence[str] | None, joint_names: Sequence[str]) -> list[int]:
    """Joint indices for ``--channels`` tokens (names or 1-based numbers, also comma-separated)."""
    if not tokens:
        return list(range(len(joint_names)))
    indices = []
    for token in (t for item in tokens for t in item.split(",") if t):
        if token in joint_names:
            indices.append(joint_names.index(token))
        elif token.isascii() and token.isdigit() and 1 <= int(token) <= len(joint_names):
            indices.append(int(token) - 1)
        else:
            raise ValueError(f"--channels: {token!r} is neither a joint name {list(joint_names)} "
                             f"nor a number 1..{len(joint_names)}")
    if not indices:  # "," or "": nothing pulsed, and "done" said
        raise ValueError(f"--channels {' '.join(tokens)!r}: no joint given; expected joint names or numbers "
                         f"1..{len(joint_names)}, or leave it out for all")
    return indices


def _hold(backend: ActuatorBackend, pressure_bar: np.ndarray, seconds: float, rate_hz: float) -> None:
    """Resend the command at ``rate_hz`` for ``seconds`` (a CAN board or the node's watchdog expects a stream)."""
    period_s = 1.0 / rate_hz
    start = time.monotonic()
    tick = 0
    while True:
        write_whole(backend, pressure_bar)
        tick += 1
        next_s = start + tick * period_s
        if next_s - start >= seconds:
            break
        time.sleep(max(next_s - time.monotonic(), 0.0))


def _labels(backend: ActuatorBackend) -> list[str]:
    labels = getattr(backend, "channel_labels", None)
    if callable(labels):
        return list(labels())
    return [f"{backend.name} output {i + 1}" for i in range(backend.robot.joint_count)]


def run(backend: ActuatorBackend, rig: RigConfig, joints: list[int], pressure_bar: float, hold_s: float,
        vent_s: float) -> None:
    """Pulse ``joints`` one after another on an open backend; vents after each pulse."""
    names = backend.robot.joint_names
    labels = _labels(backend)
    count = backend.robot.joint_count
    for number, joint in enumerate(joints, start=1):
        command = np.zeros(count)
        command[joint] = pressure_bar
        sent = write_whole(backend, command)
        volts = backend.read_state().command_v[joint]
        print(f"pulse {number}/{len(joints)}: {names[joint]} (joint {joint + 1}) -> {labels[joint]}: "
              f"{sent[joint]:.2f} bar = {volts:.3f} V for {hold_s:g} s", flush=True)
        _hold(backend, command, hold_s, rig.command_rate_hz)
        _hold(backend, np.zeros(count), vent_s, rig.command_rate_hz)
        print(f"  vented {names[joint]} (0 V)", flush=True)


def main(argv: Sequence[str] | None = None) -> int:
    """Console entry point; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        robot = load_robot(args.robot) if args.robot else None
        rig = load_rig(args.rig, robot)
        pressure_limit_bar = rig.robot.max_pressure_bar
        if not (math.isfinite(args.pressure_bar) and 0.0 < args.pressure_bar <= pressure_limit_bar):
            parser.error(f"--pressure-bar {args.pressure_bar:g}: expected a pressure in (0, {pressure_limit_bar:g}] "
                         "bar (the robot's max_pressure_bar)")
        for flag, value in (("--hold-s", args.hold_s), ("--vent-s", args.vent_s)):
            if not (math.isfinite(value) and 0.0 < value <= MAX_HOLD_S):
                parser.error(f"{flag} {value:g}: expected seconds in (0, {MAX_HOLD_S:g}]")
        joints = select_joints(args.channels, rig.robot.joint_names)
        backend = backend_for(rig, args.backend)
    except (ConfigurationError, ValueError) as exc:
        print(f"srs_wiring_check: error: {exc}", file=sys.stderr, flush=True)
        return EXIT_USAGE
    refusal = operator_go(backend, f"{len(joints)} pulse(s) of {args.pressure_bar:g} bar, one regulator at a time",
                          args.yes, "srs_wiring_check")
    if refusal:
        print(f"srs_wiring_check: refused: {refusal}", file=sys.stderr, flush=True)
        return EXIT_USAGE

    with interrupts_on_sigterm(), ros_context(backend):
        return _open_and_run(backend, rig, joints, args)


def _open_and_run(backend: ActuatorBackend, rig: RigConfig, joints: list[int], args: argparse.Namespace) -> int:
    def pulses() -> None:
        print(f"wiring check on rig {rig.name!r} ({backend.name} backend, {rig.robot.regulator.name}): "
              f"{len(joints)} pulse(s) of {args.pressure_bar:g} bar", flush=True)
        # The sim rig pulsed into nothing and said "done" with no sim_world running (its startup timeout is longer
        # than the default run): wait for the rig to answer first (a helper's review).
        wait_until_ready(backend, rig.command_rate_hz, "srs_wiring_check")
        run(backend, rig, joints, args.pressure_bar, args.hold_s, args.vent_s)

    return run_vented(backend, "srs_wiring_check", pulses, f"done: {len(joints)} regulator(s) pulsed")


if __name__ == "__main__":
    sys.exit(main())
