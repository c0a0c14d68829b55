"""CAN backend: the nine regulator voltages as DBC-encoded frames on any python-can bus.

The bus is opened with ``can.Bus`` from the rig's options (``interface``, ``channel``, ``bitrate``,
or python-can's own config file), so socketcan, PCAN, Kvaser, slcan, virtual ... work unchanged.
The frame layout lives in a DBC file (default ``config/srs_dac.dbc``) and is encoded and decoded
with cantools: a board with another layout needs another DBC, not other code.

Conventions (``docs/can.md``): joint ``i`` drives DAC channel ``channels[i]``; its command is the
DBC signal ``command_signal.format(channel=...)`` (default ``CMD_CH1..9``) in volts; every message
holding a command signal is sent on every write, in DBC order. So that a board can vent by itself
when the host dies (SIGKILL, segfault, cable), each command message may carry an alive counter
(signal ``alive_signal``, default ``ALIVE``: 0 at open, +1 per write modulo its range, the same in
every message of one write) and a CRC-8/SAE-J1850 of its other bytes (``checksum_signal``, default
``CRC8``); a DBC without them sends none. The board must vent when no valid command arrives within
``board_timeout_s`` (the rig states it; the host only counts its own longer gaps). Other signals of
a command message are sent at their DBC initial value (or 0). Optional read-back of the regulators'
monitor outputs: signals ``monitor_signal`` (default ``MON_CH1..9``) in ``V`` (mapped through
``monitor_range_v`` to 0..full scale) or in ``bar``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from srs_ros.backends.base import ActuatorBackend
from srs_ros.core.errors import BackendUnavailableError, HardwareError
from srs_ros.core.robot import RobotDescription, config_file
from srs_ros.core.schema import Field, Table, refusal

DEFAULT_DBC_FILE = "srs_dac.dbc"
DEFAULT_COMMAND_SIGNAL = "CMD_CH{channel}"
DEFAULT_MONITOR_SIGNAL = "MON_CH{channel}"
#: SMC ITV3000 analog monitor output (voltage type): 1-5 V spans 0..full-scale pressure.
DEFAULT_MONITOR_RANGE_V = (1.0, 5.0)
DEFAULT_SEND_TIMEOUT_S = 0.02
DEFAULT_ALIVE_SIGNAL = "ALIVE"
DEFAULT_CHECKSUM_SIGNAL = "CRC8"
#: How long the DAC board may go without a valid command frame before it vents (docs/can.md).
DEFAULT_BOARD_TIMEOUT_S = 0.1
BOARD_TIMEOUT_RANGE_S = (0.005, 5.0)
#: Most read-back frames handled per call, so a flooded bus cannot stall the command loop.
MAX_FRAMES_PER_DRAIN = 256

#: Where an option error says it is.
WHERE = "can backend_options"
#: The options of the can backend (``backend_options`` of a rig file; see :class:`CanBackend`).
CAN_OPTIONS = Table("", (
    Field("interface", str, None, nonempty=True, example="'socketcan' or 'pcan'",
          description="python-can interface name; leave out for python-can's own configuration"),
    Field("channel", object, None, expected_text="a channel name or number, e.g. 'can0' or 0",
          description="the bus channel, passed to can.Bus"),
    Field("bitrate", int, None, 10_000, 1_000_000, "bit/s", "bit rate, passed to can.Bus", example="500000"),
    Field("can_config_file", object, None, expected_text="an existing python-can INI config file",
          description="python-can config file (instead of interface, channel, bitrate)"),
    Field("can_config_context", object, None, expected_text="a section name of the config file",
          description="the section of can_config_file (default 'default')"),
    Field("bus_options", dict, None, description="further keyword arguments of can.Bus"),
    Field("dbc_file", str, DEFAULT_DBC_FILE, nonempty=True, description="the frame layout"),
    Field("channels", list, None, minimum=0, item=int, description="DAC channel of each joint in joint order",
          expected_text="distinct DAC channel numbers (integers >= 0), one per joint in joint order"),
    Field("command_signal", str, DEFAULT_COMMAND_SIGNAL, description="command signal-name pattern with {channel}"),
    Field("monitor_signal", str, DEFAULT_MONITOR_SIGNAL, description="read-back signal-name pattern with {channel}"),
    Field("readback", bool, True, description="decode monitor frames into measured pressures"),
    Field("monitor_range_v", list, DEFAULT_MONITOR_RANGE_V, item=float, length=2, unit="V",
          description="[V at 0 bar, V at full scale] of a monitor signal"),
    Field("send_timeout_s", float, DEFAULT_SEND_TIMEOUT_S, minimum=0.0, above_minimum=True, unit="s",
          description="how long one frame may wait for the bus"),
    Field("alive_signal", str, DEFAULT_ALIVE_SIGNAL, nonempty=True, description="alive-counter signal name"),
    Field("checksum_signal", str, DEFAULT_CHECKSUM_SIGNAL, nonempty=True, description="CRC-8 signal name"),
    Field("board_timeout_s", float, DEFAULT_BOARD_TIMEOUT_S, *BOARD_TIMEOUT_RANGE_S, unit="s",
          description="the board vents by itself without a valid command this long"),
), description="a mapping of option: value")
#: Raise what it returns: the one error format with this backend's place.
_refuse = partial(refusal, WHERE)


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


class CanBackend(ActuatorBackend):
    """Nine regulator commands as DBC-encoded CAN frames; optional monitor read-back.

    Options (``backend_options`` of the rig), all optional:

    - ``interface`` (python-can interface name, e.g. ``socketcan``, ``pcan``, ``virtual``),
      ``channel``, ``bitrate`` (bit/s): passed to ``can.Bus``. Without ``interface`` python-can's own
      configuration is used: ``can_config_file`` (an INI file) with section ``can_config_context``,
      or its default files and ``CAN_*`` environment variables.
    - ``bus_options``: further keyword arguments of ``can.Bus`` (e.g. ``{fd: true}``).
    - ``dbc_file``: the frame layout (default ``srs_dac.dbc`` of the package's config folder).
    - ``channels``: DAC channel of each joint in joint order (default ``[1, ..., 9]``).
    - ``command_signal`` / ``monitor_signal``: signal-name patterns with ``{channel}``.
    - ``readback``: decode monitor frames into measured pressures (default true).
    - ``monitor_range_v``: ``[V at 0 bar, V at full scale]`` of a monitor signal in volts (default [1, 5]).
    - ``send_timeout_s``: how long one frame may wait for the bus (default 0.02 s).
    - ``alive_signal``: name of the alive-counter signal in the command messages (default ``ALIVE``);
      an unsigned integer signal (factor 1, offset 0) counting 0 .. its DBC maximum (or 2^bits - 1).
    - ``checksum_signal``: name of the CRC-8/SAE-J1850 signal (default ``CRC8``): 8 bits, byte-aligned,
      over the message's other bytes in order. Messages without these signals are sent without them;
      a name set explicitly must exist in at least one command message.
    - ``board_timeout_s``: how long the board may go without a valid command frame before it vents by
      itself (default 0.1 s; the board's firmware implements it, see docs/can.md). The host counts its
      own gaps longer than this (``read_state().details['board_timeout_gaps']``).
    """

    name = "can"

    def __init__(self, robot: RobotDescription | None = None, options: Mapping[str, Any] | None = None):
        """Validate the options and load the DBC (ConfigurationError naming the key on any problem)."""
        super().__init__(robot, options)
        self._opts = CAN_OPTIONS.read(self.options, WHERE)
        self._bus_kwargs = self._bus_config()
        self.send_timeout_s: float = self._opts["send_timeout_s"]
        self.board_timeout_s: float = self._opts["board_timeout_s"]
        #: How long the hardware keeps the last command after the host stops writing (s).
        self.host_loss_timeout_s = self.board_timeout_s
        self.channels = self._channel_list()
        self.dbc_path = config_file(self._opts["dbc_file"])
        self.database = self._load_dbc(self.dbc_path)
        self._command_layout = self._command_signals()
        names = {message.name for message, _ in self._command_layout}
        self._command_messages = [message for message in self.database.messages if message.name in names]
        self._alive_layout = self._sequence_signals("alive_signal", DEFAULT_ALIVE_SIGNAL, self._check_alive)
        self._checksum_layout = self._sequence_signals("checksum_signal", DEFAULT_CHECKSUM_SIGNAL,
                                                       self._check_checksum)
        self.monitor_range_v = self._monitor_range()
        self._monitor_layout = self._monitor_signals() if self._opts["readback"] else {}
        self.measures_pressure = bool(self._monitor_layout)
        self._bus = None
        self._measured_bar = np.full(self.robot.joint_count, np.nan)
        self._measured_stamp_s = np.full(self.robot.joint_count, np.nan)
        self._decode_errors = 0
        self._alive = 0
        self._last_send_s = math.nan
        self._board_timeout_gaps = 0

    # -- option validation ----------------------------------------------------------------
    def _bus_config(self) -> dict[str, Any]:
        opts = self._opts
        kwargs: dict[str, Any] = {}
        extra = opts["bus_options"] or {}
        if not all(isinstance(k, str) for k in extra):
            raise _refuse("bus_options", extra, "a mapping of can.Bus keyword arguments")
        if opts["can_config_file"] is not None:
            import can

            path = Path(str(opts["can_config_file"])).expanduser()
            if not path.is_file():
                raise _refuse("can_config_file", opts["can_config_file"], CAN_OPTIONS["can_config_file"].expected)
            section = opts["can_config_context"] if opts["can_config_context"] is not None else "default"
            kwargs.update(can.util.load_file_config(path, section=str(section)))
            if not kwargs:
                raise _refuse("can_config_context", section, f"a section of {path} with interface and channel")
        elif opts["can_config_context"] is not None:
            kwargs["config_context"] = str(opts["can_config_context"])
        kwargs.update(extra)
        for key in ("interface", "bitrate"):
            if opts[key] is not None:
                kwargs[key] = opts[key]
        if opts["channel"] is not None:
            if not isinstance(opts["channel"], (str, int)) or isinstance(opts["channel"], bool):
                raise _refuse("channel", opts["channel"], CAN_OPTIONS["channel"].expected)
            kwargs["channel"] = opts["channel"]
        if opts["can_config_file"] is not None:
            kwargs["ignore_config"] = True
        return kwargs

    def _channel_list(self) -> tuple[int, ...]:
        count = self.robot.joint_count
        channels = self._opts["channels"]
        channels = tuple(range(1, count + 1)) if channels is None else channels
        if len(channels) != count or len(set(channels)) != count:
            raise _refuse("channels", list(channels), f"{count} distinct DAC channel numbers in joint order "
                        f"{list(self.robot.joint_names)}")
        return tuple(channels)

    def _monitor_range(self) -> tuple[float, float]:
        low_v, high_v = self._opts["monitor_range_v"]
        if high_v <= low_v:
            raise _refuse("monitor_range_v", [low_v, high_v], "[volts at 0 bar, volts at full scale], e.g. [1.0, 5.0]")
        return low_v, high_v

    @staticmethod
    def _load_dbc(path: Path):
        import cantools

        if not path.is_file():
            raise _refuse("dbc_file", str(path), "an existing DBC file (default: srs_dac.dbc in the package config/)")
        try:
            return cantools.database.load_file(str(path), database_format="dbc")
        except Exception as exc:  # cantools raises parser-specific errors
            raise _refuse("dbc_file", str(path), f"a valid DBC file (cantools: {exc})") from exc

    def _signal_names(self, key: str, default: str) -> list[str]:
        pattern = self._opts[key]
        if "{channel}" not in pattern:
            raise _refuse(key, pattern, "a signal-name pattern containing '{channel}', e.g. " + repr(default))
        return [pattern.format(channel=channel) for channel in self.channels]

    def _find_signals(self, names: list[str], key: str) -> dict[str, Any]:
        """Signal name -> (message, signal) from the DBC; ConfigurationError for a missing one."""
        found = {}
        for message in self.database.messages:
            for signal in message.signals:
                if signal.name in names:
                    found[signal.name] = (message, signal)
        missing = [n for n in names if n not in found]
        if missing:
            raise _refuse(key, self.options.get(key), f"signals present in {self.dbc_path}; missing {missing}")
        return found

    def _command_signals(self) -> list[tuple[Any, Any]]:
        """Per joint: (message, signal) of its command; checks units and ranges."""
        names = self._signal_names("command_signal", DEFAULT_COMMAND_SIGNAL)
        found = self._find_signals(names, "command_signal")
        full_v = self.robot.regulator.command_full_scale_v
        for name in names:
            _, signal = found[name]
            if (signal.unit or "").strip() != "V":
                raise _refuse("dbc_file", str(self.dbc_path), f"command signal {name} in unit \"V\" (found "
                            f"{signal.unit!r}); scale counts or millivolts with the signal's factor")
            low = 0.0 if signal.minimum is None else signal.minimum
            high = math.inf if signal.maximum is None else signal.maximum
            if low > 0.0 or high < full_v * self.robot.max_pressure_bar / self.robot.command_full_scale_pressure_bar:
                raise _refuse("dbc_file", str(self.dbc_path), f"command signal {name} with a range covering 0 V "
                            f"up to the command at the pressure limit (found [{low}, {high}] V)")
        return [found[name] for name in names]

    def _sequence_signals(self, key: str, default: str, check) -> dict[str, tuple[Any, int]]:
        """Command message name -> (signal, detail from ``check``) for the alive or checksum signal."""
        name = self._opts[key]
        layout = {}
        for message in self._command_messages:
            signal = next((s for s in message.signals if s.name == name), None)
            if signal is not None:
                layout[message.name] = (signal, check(message, signal))
        if not layout and key in self.options:
            raise _refuse(key, name, f"a signal of the command messages in {self.dbc_path} (none has it)")
        return layout

    def _check_alive(self, message, signal) -> int:
        """The counter's modulus: its DBC maximum + 1, else 2^bits."""
        full = 1 << signal.length
        top = full - 1 if signal.maximum is None else signal.maximum
        ok = (not signal.is_signed and not signal.is_float and signal.scale == 1 and signal.offset == 0
              and signal.length >= 2 and (signal.minimum or 0) == 0 and float(top).is_integer() and 2 <= top < full)
        if not ok:
            raise _refuse("alive_signal", signal.name, f"an unsigned integer counter of at least 2 bits with factor 1, "
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
            raise _refuse("checksum_signal", signal.name, f"an unsigned 8-bit byte-aligned signal (factor 1, offset 0) "
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
                raise _refuse("dbc_file", str(self.dbc_path), f"monitor signal {name} in \"V\" or \"bar\" "
                            f"(found {signal.unit!r}); or set readback: false")
            key = (message.frame_id, message.is_extended_frame)
            layout.setdefault(key, (message, []))[1].append((joint, name, unit))
        return layout

    # -- the contract -----------------------------------------------------------------------
    def channel_labels(self) -> list[str]:
        """Per joint: the signal and frame that drive it, e.g. ``CMD_CH1 in SRS_CMD_A (0x100)``."""
        return [f"{s.name} in {m.name} (0x{m.frame_id:03X})" for m, s in self._command_layout]

    def _open(self) -> None:
        import can

        description = self._bus_description()
        try:
            bus = can.Bus(**self._bus_kwargs)
        except can.CanInterfaceNotImplementedError as exc:
            interface = self._bus_kwargs.get("interface")
            from can.interfaces import BACKENDS

            if interface is None or interface not in BACKENDS:
                raise _refuse("interface", interface, f"one of {sorted(BACKENDS)}, here or in python-can's config "
                            f"(can_config_file / CAN_INTERFACE); python-can: {exc}") from exc
            raise BackendUnavailableError(
                f"CAN interface {description} is not available on this machine ({exc}); install its driver "
                "(see python-can's interface docs) or choose another 'interface'.") from exc
        except TypeError as exc:  # a keyword the interface does not take
            raise _refuse("bus_options", self.options.get("bus_options", {}),
                        f"keyword arguments that the {description} interface accepts ({exc})") from exc
        except (can.CanError, OSError, ValueError) as exc:
            raise HardwareError(f"cannot open CAN bus {description}: {exc}. Check the adapter is connected, "
                                "the channel name and bitrate, and that the interface is up.") from exc
        self._bus = bus
        self._alive, self._last_send_s, self._board_timeout_gaps = 0, math.nan, 0
        self._measured_bar[:] = np.nan
        self._measured_stamp_s[:] = np.nan
        try:
            if self._monitor_layout:
                bus.set_filters([{"can_id": frame_id, "can_mask": 0x1FFFFFFF, "extended": extended}
                                 for frame_id, extended in self._monitor_layout])
            self._send_frames(np.zeros(self.robot.joint_count))
        except BaseException:
            self._close()
            raise

    def _write(self, pressure_bar: np.ndarray, command_v: np.ndarray) -> None:
        self._send_frames(command_v)
        self._drain()

    def _close(self) -> None:
        bus, self._bus = self._bus, None
        if bus is not None:
            try:
                bus.shutdown()
            except Exception:  # noqa: BLE001 - releasing a broken adapter must not mask the first error
                pass

    def _measure(self) -> dict[str, Any]:
        details: dict[str, Any] = {"board_timeout_gaps": self._board_timeout_gaps}
        if self._alive_layout and self._alive:
            _, modulus = next(iter(self._alive_layout.values()))
            details["alive_counter"] = (self._alive - 1) % modulus  # carried by the last write
        if not self._monitor_layout:
            return {"details": details}
        self._drain()
        details["readback_decode_errors"] = self._decode_errors
        if np.all(np.isnan(self._measured_stamp_s)):
            return {"details": details}
        details["readback_age_s"] = (time.monotonic() - self._measured_stamp_s).tolist()
        return {"measured_pressure_bar": self._measured_bar.copy(), "details": details}

    # -- frames -------------------------------------------------------------------------------
    def encode_frames(self, command_v: np.ndarray, alive: int = 0) -> list[tuple[int, bool, bytes]]:
        """(arbitration id, extended, data) of every command message for the voltages (V) of one write.

        ``alive`` is the write's counter (wrapped to each alive signal's range); the CRC is filled in last.
        """
        values: dict[str, dict[str, float]] = {}
        for (message, signal), volts in zip(self._command_layout, command_v):
            values.setdefault(message.name, {})[signal.name] = float(volts)
        frames = []
        for message in self._command_messages:  # in the DBC's order, whatever the channel mapping
            data = values[message.name]
            if message.name in self._alive_layout:
                signal, modulus = self._alive_layout[message.name]
                data[signal.name] = alive % modulus
            for signal in message.signals:
                if signal.name not in data:
                    data[signal.name] = signal.initial if signal.initial is not None else 0.0
            payload = message.encode(data)
            if message.name in self._checksum_layout:
                _, index = self._checksum_layout[message.name]
                payload = bytearray(payload)
                payload[index] = crc8_sae_j1850(payload[:index] + payload[index + 1:])
                payload = bytes(payload)
            frames.append((message.frame_id, message.is_extended_frame, payload))
        return frames

    def _send_frames(self, command_v: np.ndarray) -> None:
        import can

        if self._bus is None:
            raise HardwareError("can backend: the bus is not open; configure the hardware node again.")
        now_s = time.monotonic()
        if now_s - self._last_send_s > self.board_timeout_s:
            self._board_timeout_gaps += 1  # by its contract the board has vented by itself meanwhile
        self._last_send_s = now_s
        frames = self.encode_frames(command_v, self._alive)
        self._alive += 1  # the write count since open; each message carries it modulo its counter's range
        for frame_id, extended, data in frames:
            message = can.Message(arbitration_id=frame_id, is_extended_id=extended, data=data)
            try:
                self._bus.send(message, timeout=self.send_timeout_s)
            except (can.CanError, OSError) as exc:
                raise HardwareError(
                    f"CAN send of frame 0x{frame_id:03X} on {self._bus_description()} failed: {exc}. "
                    "Regulator commands are no longer reaching the board (cable, termination, bitrate, "
                    "bus-off?); vent and re-open the backend (configure/activate the hardware node).") from exc

    def _drain(self) -> None:
        """Decode the monitor frames received since the last call (non-blocking)."""
        import can

        if not self._monitor_layout or self._bus is None:
            return
        for _ in range(MAX_FRAMES_PER_DRAIN):
            try:
                message = self._bus.recv(timeout=0.0)
            except (can.CanError, OSError):
                return  # a broken bus shows up on the next send, which raises HardwareError
            if message is None:
                return
            self._decode_monitor(message)

    def _decode_monitor(self, message) -> None:
        entry = self._monitor_layout.get((message.arbitration_id, bool(message.is_extended_id)))
        if entry is None:
            return
        dbc_message, layout = entry
        try:
            decoded = dbc_message.decode(bytes(message.data))
        except Exception:  # noqa: BLE001 - a malformed frame is counted, never fatal
            self._decode_errors += 1
            return
        low_v, high_v = self.monitor_range_v
        full_bar = self.robot.command_full_scale_pressure_bar
        now = time.monotonic()
        for joint, name, unit in layout:
            value = float(decoded[name])
            if unit == "V":
                value = (value - low_v) / (high_v - low_v) * full_bar
            self._measured_bar[joint] = value
            self._measured_stamp_s[joint] = now

    def _bus_description(self) -> str:
        kwargs = self._bus_kwargs
        return f"{kwargs.get('interface', '<python-can config>')}:{kwargs.get('channel', '<default>')}"
