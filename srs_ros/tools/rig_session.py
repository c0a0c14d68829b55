"""What every tool that drives a rig directly shares: the backend from a rig file, ROS for the sim, Ctrl-C, the vent.

``srs_wiring_check`` and ``srs_identify`` open a backend through the one contract (as the hardware node
does) and must leave every regulator at 0 bar however they end: :func:`interrupts_on_sigterm` turns
SIGTERM into the same ``KeyboardInterrupt`` as Ctrl-C, :func:`vent_and_close` vents with both ignored.
A real rig (``drives_real_hardware``) needs the operator's go (:func:`operator_go`).
"""

from __future__ import annotations

import contextlib
import signal
import sys
import time
from collections.abc import Callable, Iterator

import numpy as np

from srs_ros.backends import ActuatorBackend, create_backend
from srs_ros.core.actuation.safety import VENT_FAILED
from srs_ros.core.errors import ConfigurationError, HardwareError
from srs_ros.core.rig import RigConfig

EXIT_OK, EXIT_HARDWARE, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130


def backend_for(rig: RigConfig, name: str | None = None) -> ActuatorBackend:
    """The rig's backend (not opened), or the backend ``name`` (its rig options apply only to the rig's own)."""
    name = name or rig.backend
    own = name == rig.backend
    return create_backend(name, rig.robot, rig.backend_options if own else {}, rig.source if own else "")


@contextlib.contextmanager
def ros_context(backend: ActuatorBackend) -> Iterator[None]:
    """Initialise rclpy while a backend that talks over DDS (``sim``) is in use; nothing for the others.

    The domain is ``ROS_DOMAIN_ID``'s; the topics are the backend's options. rclpy installs no signal
    handler: Ctrl-C stays a ``KeyboardInterrupt`` that the tool turns into a vent.
    """
    if not backend.needs_rclpy:
        yield
        return
    import rclpy
    from rclpy.signals import SignalHandlerOptions

    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    try:
        yield
    finally:
        rclpy.try_shutdown()


def _raise_keyboard_interrupt(signum, frame) -> None:
    """The first Ctrl-C or SIGTERM: every later one is ignored from here, then ``KeyboardInterrupt`` (vent, exit).

    A SIGTERM right after a Ctrl-C (a terminal's and a supervisor's stop together) ran its handler at the first
    line of the vent, before that ignored them: a second ``KeyboardInterrupt`` left 1.5 bar held (a review).
    :func:`interrupts_on_sigterm` restores the handlers as it leaves.
    """
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, signal.SIG_IGN)
    raise KeyboardInterrupt


@contextlib.contextmanager
def interrupts_on_sigterm() -> Iterator[None]:
    """SIGTERM raises ``KeyboardInterrupt`` like Ctrl-C while inside (a supervisor's stop vents too).

    Ctrl-C (SIGINT) raises it too even if the process started with SIGINT ignored, as a command started with
    ``&`` from a script is: Python then installs no handler, and the tool would not vent on SIGINT.
    """
    previous = signal.signal(signal.SIGTERM, _raise_keyboard_interrupt)
    previous_int = signal.signal(signal.SIGINT, _raise_keyboard_interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
        signal.signal(signal.SIGINT, previous_int)


def write_whole(backend: ActuatorBackend, pressure_bar) -> np.ndarray:
    """One command as one write: a Ctrl-C or SIGTERM during it takes effect right after it (main thread).

    A CAN command is three frames: an interrupt between them would leave the board with the first
    frame of a new command and the rest of the old one before the vent.
    """
    held: list[int] = []
    previous = {sig: signal.signal(sig, lambda signum, _frame: held.append(signum))
                for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        return backend.write_pressures(pressure_bar)
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        if held and callable(previous[held[0]]):
            previous[held[0]](held[0], None)  # e.g. KeyboardInterrupt, now that the command is whole


def wait_until_ready(backend: ActuatorBackend, rate_hz: float, program: str) -> None:
    """Vent at ``rate_hz`` until the open backend can follow commands (``holding_reason`` is '').

    A simulated world answers first. The backend raises HardwareError once it gives up (the sim backend after
    its ``startup_timeout_s``). Real boards are ready at once.
    """
    said = False
    while reason := backend.holding_reason():
        if not said:
            print(f"{program}: waiting: {reason}", flush=True)
            said = True
        backend.vent()
        time.sleep(1.0 / rate_hz)


def vent_and_close(backend: ActuatorBackend) -> bool:
    """Vent and close with Ctrl-C and SIGTERM ignored; True if vented.

    Neither a second Ctrl-C nor a supervisor's stop can cut the vent short (a CAN vent is three frames).
    """
    if not backend.is_open:
        return True  # never opened (or open failed): nothing of ours is pressurised
    previous = {sig: signal.signal(sig, signal.SIG_IGN) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        try:
            backend.vent()
            vented = True
        except HardwareError as exc:
            print(f"error: {VENT_FAILED} ({exc})", file=sys.stderr, flush=True)
            vented = False
        try:
            backend.close()
        except HardwareError as exc:
            print(f"error: {VENT_FAILED} (while closing: {exc})", file=sys.stderr, flush=True)
            vented = False
        return vented
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def operator_go(backend: ActuatorBackend, what: str, confirmed: bool, program: str) -> str:
    """'' when the run may start; else why not. A real rig needs ``--yes`` or a typed 'yes' at a terminal."""
    if not backend.drives_real_hardware or confirmed:
        return ""
    if not sys.stdin.isatty():
        return (f"the {backend.name} rig drives real regulators with real air: {what}. Pass --yes once the robot is "
                "clear and someone stands at the supply valve.")
    print(f"{program}: the {backend.name} rig drives real regulators with real air: {what}.\n"
          "Robot clear, someone at the supply valve? Type yes to start (Ctrl-C vents at any time): ",
          end="", flush=True)
    try:
        answer = sys.stdin.readline().strip().lower()
    except KeyboardInterrupt:
        answer = ""
    return "" if answer == "yes" else "the operator did not say yes; nothing was sent."


def run_vented(backend: ActuatorBackend, program: str, body: Callable[[], None], done: str) -> int:
    """Open ``backend``, run ``body``, then vent and close however it ends; return the exit code.

    Ctrl-C (and SIGTERM, see :func:`interrupts_on_sigterm`) vents at once (130); a configuration error
    exits 2, a hardware error 1, both vented; any other exception is raised after the vent. ``done`` is
    printed after a vented end ("<done>, all vented").
    """
    try:
        backend.open()
        body()
    except KeyboardInterrupt:
        vented = vent_and_close(backend)
        print("interrupted: all regulators vented (0 bar)" if vented else f"interrupted: {VENT_FAILED}", flush=True)
        return EXIT_INTERRUPTED
    except ConfigurationError as exc:
        print(f"{program}: error: {exc}", file=sys.stderr, flush=True)
        vent_and_close(backend)
        return EXIT_USAGE
    except HardwareError as exc:
        print(f"{program}: hardware error on the {backend.name} backend: {exc}", file=sys.stderr, flush=True)
        vent_and_close(backend)
        return EXIT_HARDWARE
    except BaseException:
        vent_and_close(backend)  # any other way out (a broken pipe, a bug) still leaves every valve at 0 bar
        raise
    vented = vent_and_close(backend)
    print(f"{done}, all vented" if vented else f"{done}, but {VENT_FAILED}", flush=True)
    return EXIT_OK if vented else EXIT_HARDWARE
