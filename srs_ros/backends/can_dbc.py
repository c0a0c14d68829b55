"""The CAN backend's frame layout: which DBC signals carry what, checked when the backend is built.

:class:`FrameLayout` finds the command, alive-counter, CRC and monitor signals of a rig's DAC channels in the
DBC, refuses what cannot carry the rig's commands (a wrong unit, a range or a bit width short of the pressure
limit's voltage, a malformed counter or CRC) naming ``backend_options`` and the signal, and encodes the frames
of one write. Conventions: ``docs/can.md``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from srs_ros.core.actuation.pressure import pressure_limit_bar, pressures_to_command_v
from srs_ros.core.robot import RobotDescription
from srs_ros.core.schema import refusal

DEFAULT_DBC_FILE = "srs_dac.dbc"
DEFAULT_COMMAND_SIGNAL = "CMD_CH{channel}"
DEFAULT_MONITOR_SIGNAL = "MON_CH{channel}"
DEFAULT_ALIVE_SIGNAL = "ALIVE"
DEFAULT_CHECKSUM_SIGNAL = "CRC8"

#: Where an option error says it is.
WHERE = "can backend_options"
#: Raise what it returns: the one error format with this backend's place.
refuse = partial(refusal, WHERE)
#: What ``str.format`` raises for a pattern with other fields than ``{channel}`` or an unpaired brace.
_FORMAT_ERRORS = (KeyError, IndexError, ValueError, AttributeError, TypeError)


def _crc8_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1D) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
        table.append(crc)
    return tuple(table)


_CRC8_TABLE = _crc8_table()


def crc8_sae_j1850(data: bytes) -> int:
    """CRC-8/SAE-J1850 (poly 0x1D, init 0xFF, no reflection, xorout 0xFF; check value 0x4B for b"123456789")."""
    crc = 0xFF
    for byte in data:
        crc = _CRC8_TABLE[crc ^ byte]
    return crc ^ 0xFF


class FrameLayout:
    """The DBC signals of a rig's channels, checked against the robot's pressure limit; encodes one write.

    ``opts``: the backend options as read (defaults filled in); ``given``: as the rig wrote them (a refusal
    shows the rig's value; an alive or checksum name set there must exist). Raises ConfigurationError.
    """

    def __init__(self, database, dbc_path: Path, opts: Mapping[str, Any], given: Mapping[str, Any],
                 channels: tuple[int, ...], robot: RobotDescription):
        self.database, self.dbc_path, self.channels, self.robot = database, dbc_path, channels, robot
        self._opts, self._given = opts, given
        #: The highest command voltage the backend ever sends: the one at the pressure limit (V).
        self.limit_v = float(pressures_to_command_v(np.full(robot.joint_count, pressure_limit_bar(robot)), robot)[0])
        #: Per joint: (message, signal) of its command.
        self.command = self._command_signals()
        #: Per joint: the highest voltage its signal carries at or below the limit (V). cantools rounds to the
        #: nearest raw step, so a coarse factor sent 4.5 V, 4.05 bar, for the limit's 4.44 V (a helper's review).
        self.cap_v = np.array([self._highest_step_v(signal) for _, signal in self.command])
        names = {message.name for message, _ in self.command}
        #: The messages sent on every write, in DBC order.
        self.command_messages = [message for message in database.messages if message.name in names]
        #: Command message name -> (alive signal, modulus) and -> (CRC signal, byte index).
        self.alive = self._sequence_signals("alive_signal", self._check_alive)
        self.checksum = self._sequence_signals("checksum_signal", self._check_checksum)
        self._check_encodable()
        #: (frame id, extended) -> (message, [(joint index, signal name, unit)]) of the read-back signals.
        self.monitor = self._monitor_signals() if opts["readback"] else {}

    # -- frames ---------------------------------------------------------------------------------
    def encode_frames(self, command_v: np.ndarray, alive: int = 0) -> list[tuple[int, bool, bytes]]:
        """(arbitration id, extended, data) of every command message for the voltages (V) of one write."""
        values: dict[str, dict[str, float]] = {}
        for (message, signal), volts in zip(self.command, np.minimum(command_v, self.cap_v)):
            values.setdefault(message.name, {})[signal.name] = float(volts)
        return [self._encode(message, values[message.name], alive) for message in self.command_messages]

    def _encode(self, message, commands: dict[str, float], alive: int) -> tuple[int, bool, bytes]:
        """One command message: its commands, the counter, other signals at their start value (or 0), the CRC."""
        data: dict[str, Any] = dict(commands)
        if message.name in self.alive:
            signal, modulus = self.alive[message.name]
            data[signal.name] = alive % modulus
        for signal in message.signals:
            if signal.name not in data:
                data[signal.name] = signal.initial if signal.initial is not None else 0.0
        payload = message.encode(data)
        if message.name in self.checksum:
            _, index = self.checksum[message.name]
            payload = bytearray(payload)
            payload[index] = crc8_sae_j1850(payload[:index] + payload[index + 1:])
            payload = bytes(payload)
        return message.frame_id, message.is_extended_frame, payload

    # -- checks ---------------------------------------------------------------------------------
    def _signal_names(self, key: str, default: str) -> list[str]:
        pattern = self._opts[key]
        expected = ("a signal-name pattern whose only field is {channel} (a literal brace written {{ or }}), "
                    "e.g. " + repr(default))
        if "{channel}" not in pattern:
            raise refuse(key, pattern, expected)
        try:
            return [pattern.format(channel=channel) for channel in self.channels]
        except _FORMAT_ERRORS as exc:
            raise refuse(key, pattern, f"{expected} (str.format: {type(exc).__name__} {exc})") from exc

    def _find_signals(self, names: list[str], key: str) -> dict[str, Any]:
        """Signal name -> (message, signal) from the DBC; ConfigurationError for a missing one."""
        found = {}
        for message in self.database.messages:
            for signal in message.signals:
                if signal.name in names:
                    found[signal.name] = (message, signal)
        missing = [n for n in names if n not in found]
        if missing:
            raise refuse(key, self._given.get(key), f"signals present in {self.dbc_path}; missing {missing}")
        return found

    def _command_signals(self) -> list[tuple[Any, Any]]:
        """Per joint: (message, signal) of its command; checks units and ranges."""
        names = self._signal_names("command_signal", DEFAULT_COMMAND_SIGNAL)
        found = self._find_signals(names, "command_signal")
        for name in names:
            _, signal = found[name]
            if (signal.unit or "").strip() != "V":
                raise refuse("dbc_file", str(self.dbc_path), f"command signal {name} in unit \"V\" (found "
                             f"{signal.unit!r}); scale counts or millivolts with the signal's factor")
            low = 0.0 if signal.minimum is None else signal.minimum
            high = math.inf if signal.maximum is None else signal.maximum
            if low > 0.0 or high < self.limit_v:
                raise refuse("dbc_file", str(self.dbc_path), f"command signal {name} with a range covering 0 V "
                             f"up to the command at the pressure limit (found [{low}, {high}] V)")
        return [found[name] for name in names]

    def _highest_step_v(self, signal) -> float:
        """The largest value ``signal`` encodes exactly at or below :attr:`limit_v` (V)."""
        steps = math.floor((self.limit_v - signal.offset) / signal.scale + 1e-9)
        return min(self.limit_v, steps * signal.scale + signal.offset)

    def _check_encodable(self) -> None:
        """Encode 0 V and the pressure limit's voltage on every command signal, refusing one that cannot carry them.

        A signal with too few bits for its factor is refused here, not with an OverflowError in the middle of a run.
        """
        for (message, signal), cap_v in zip(self.command, self.cap_v):
            siblings = {s.name: 0.0 for m, s in self.command if m.name == message.name}
            for volts in (0.0, cap_v):
                try:
                    sent = message.decode(self._encode(message, {**siblings, signal.name: volts}, 0)[2])[signal.name]
                    if sent > self.limit_v + 1e-9:  # never more on the wire than the limit's voltage
                        raise ValueError(f"{volts:.4g} V is sent as {sent:.4g} V, over the limit")
                except Exception as exc:  # noqa: BLE001 - cantools raises EncodeError, OverflowError, ...
                    raise refuse("dbc_file", str(self.dbc_path), f"command signal {signal.name} in {message.name} "
                                 f"able to carry 0 V up to {self.limit_v:.4g} V, the command at the pressure limit "
                                 f"(encoding {volts:.4g} V failed: {exc}); give it more bits or a coarser factor"
                                 ) from exc

    def _sequence_signals(self, key: str, check) -> dict[str, tuple[Any, int]]:
        """Command message name -> (signal, detail from ``check``) for the alive or checksum signal."""
        name = self._opts[key]
        layout = {}
        for message in self.command_messages:
            signal = next((s for s in message.signals if s.name == name), None)
            if signal is not None:
                layout[message.name] = (signal, check(message, signal))
        if not layout and key in self._given:
            raise refuse(key, name, f"a signal of the command messages in {self.dbc_path} (none has it)")
        return layout

    def _check_alive(self, message, signal) -> int:
        """The counter's modulus: its DBC maximum + 1, else 2^bits."""
        full = 1 << signal.length
        top = full - 1 if signal.maximum is None else signal.maximum
        ok = (not signal.is_signed and not signal.is_float and signal.scale == 1 and signal.offset == 0
              and signal.length >= 2 and (signal.minimum or 0) == 0 and float(top).is_integer() and 2 <= top < full)
        if not ok:
            raise refuse("alive_signal", signal.name, f"an unsigned integer counter of at least 2 bits with factor 1, "
                         f"offset 0, range [0, max] in {message.name} of {self.dbc_path}")
        return int(top) + 1

    def _check_checksum(self, message, signal) -> int:
        """The byte index of the CRC in the frame (it must fill exactly one byte)."""
        raw = {s.name: 0 for s in message.signals}
        raw[signal.name] = 0xFF
        data = message.encode(raw, scaling=False, strict=False)
        filled = [i for i, byte in enumerate(data) if byte]
        ok = (not signal.is_signed and not signal.is_float and signal.scale == 1 and signal.offset == 0
              and signal.length == 8 and len(filled) == 1 and data[filled[0]] == 0xFF)
        if not ok:
            raise refuse("checksum_signal", signal.name, f"an unsigned 8-bit byte-aligned signal (factor 1, offset 0) "
                         f"in {message.name} of {self.dbc_path}")
        return filled[0]

    def _monitor_signals(self) -> dict[tuple[int, bool], tuple[Any, list[tuple[int, str, str]]]]:
        """(frame id, extended) -> (message, [(joint index, signal name, unit)]) of the read-back signals."""
        names = self._signal_names("monitor_signal", DEFAULT_MONITOR_SIGNAL)
        found = self._find_signals(names, "monitor_signal")
        layout: dict[tuple[int, bool], tuple[Any, list[tuple[int, str, str]]]] = {}
        for joint, name in enumerate(names):
            message, signal = found[name]
            unit = (signal.unit or "").strip()
            if unit not in ("V", "bar"):
                raise refuse("dbc_file", str(self.dbc_path), f"monitor signal {name} in \"V\" or \"bar\" "
                             f"(found {signal.unit!r}); or set readback: false")
            key = (message.frame_id, message.is_extended_frame)
            layout.setdefault(key, (message, []))[1].append((joint, name, unit))
        return layout
