"""CAN backend: the nine regulator voltages as DBC-encoded frames on any python-can bus.

The bus is opened with ``can.Bus`` from the rig's options (``interface``, ``channel``, ``bitrate``,
or python-can's own config file), so socketcan, PCAN, Kvaser, slcan, virtual ... work unchanged.
The frame layout lives in a DBC file (default ``config/srs_dac.dbc``) and is encoded and decoded
with cantools (:mod:`srs_ros.backends.can_dbc` checks it): a board with another layout needs another DBC,
not other code.

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

import importlib
import math
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from srs_ros.backends.base import ActuatorBackend
from srs_ros.backends.can_dbc import (
    DEFAULT_ALIVE_SIGNAL,
    DEFAULT_CHECKSUM_SIGNAL,
    DEFAULT_COMMAND_SIGNAL,
    DEFAULT_DBC_FILE,
    DEFAULT_MONITOR_SIGNAL,
    WHERE,
    FrameLayout,
    crc8_sae_j1850,
)
from srs_ros.backends.can_dbc import refuse as _refuse
from srs_ros.core.errors import BackendUnavailableError, HardwareError
from srs_ros.core.robot import RobotDescription, config_file
from srs_ros.core.schema import Field, Table

#: SMC ITV3000 analog monitor output (voltage type): 1-5 V spans 0..full-scale pressure.
DEFAULT_MONITOR_RANGE_V = (1.0, 5.0)
DEFAULT_SEND_TIMEOUT_S = 0.02
#: How long the DAC board may go without a valid command frame before it vents (docs/can.md).
DEFAULT_BOARD_TIMEOUT_S = 0.1
BOARD_TIMEOUT_RANGE_S = (0.005, 5.0)
#: Most read-back frames handled per call, so a flooded bus cannot stall the command loop.
MAX_FRAMES_PER_DRAIN = 256
#: The pip name of each Python package the backend needs (module name -> distribution).
DRIVER_PACKAGES = {"can": "python-can", "cantools": "cantools"}
INSTALL_HINT = ("`pip install python-can cantools` (the package's `hardware` extra; rosdep: python3-can, "
                "python3-cantools-pip), or choose another backend (mock, sim).")

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
          description="how long one frame may wait for the bus (at most board_timeout_s / command frames)"),
    Field("alive_signal", str, DEFAULT_ALIVE_SIGNAL, nonempty=True, description="alive-counter signal name"),
    Field("checksum_signal", str, DEFAULT_CHECKSUM_SIGNAL, nonempty=True, description="CRC-8 signal name"),
    Field("board_timeout_s", float, DEFAULT_BOARD_TIMEOUT_S, *BOARD_TIMEOUT_RANGE_S, unit="s",
          description="the board vents by itself without a valid command this long"),
), description="a mapping of option: value")
__all__ = ["CAN_OPTIONS", "CanBackend", "crc8_sae_j1850"]


def _import_driver(module: str):
    """The python-can or cantools module; BackendUnavailableError with the install hint where it is missing."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise BackendUnavailableError(f"can backend: the Python package {DRIVER_PACKAGES[module]} is not installed "
                                      f"({exc}); {INSTALL_HINT}") from exc


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
    - ``send_timeout_s``: how long one frame may wait for the bus (default 0.02 s): at most ``board_timeout_s``
      divided by the command frames of one write, so a write on a stuck bus ends before the board vents
      (unset, it is lowered to that share).
    - ``alive_signal``: name of the alive-counter signal in the command messages (default ``ALIVE``);
      an unsigned integer signal (factor 1, offset 0) counting 0 .. its DBC maximum (or 2^bits - 1).
    - ``checksum_signal``: name of the CRC-8/SAE-J1850 signal (default ``CRC8``): 8 bits, byte-aligned,
      over the message's other bytes in order. Messages without these signals are sent without them;
      a name set explicitly must exist in at least one command message.
    - ``board_timeout_s``: how long the board may go without a valid command frame before it vents by
      itself (default 0.1 s; the board's firmware implements it, see docs/can.md). The host counts its
      own gaps longer than this (``read_state().details['board_timeout_gaps']``).

    Raises BackendUnavailableError where python-can or cantools is not installed.
    """

    name = "can"

    def __init__(self, robot: RobotDescription | None = None, options: Mapping[str, Any] | None = None):
        """Validate the options and load the DBC (ConfigurationError naming the key on any problem)."""
        super().__init__(robot, options)
        self._can = _import_driver("can")
        cantools = _import_driver("cantools")
        self._opts = CAN_OPTIONS.read(self.options, WHERE)
        self._bus_kwargs = self._bus_config()
        self.board_timeout_s: float = self._opts["board_timeout_s"]
        #: How long the hardware keeps the last command after the host stops writing (s).
        self.host_loss_timeout_s = self.board_timeout_s
        self.channels = self._channel_list()
        self.dbc_path = config_file(self._opts["dbc_file"])
        self.database = self._load_dbc(cantools, self.dbc_path)
        self.monitor_range_v = self._monitor_range()
        self.layout = FrameLayout(self.database, self.dbc_path, self._opts, self.options, self.channels, self.robot)
        self.send_timeout_s = self._send_timeout()
        self.measures_pressure = bool(self.layout.monitor)
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
            kwargs.update(self._file_bus_config())
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

    def _file_bus_config(self) -> dict[str, Any]:
        """The section of ``can_config_file``, its values typed as python-can types its own config file's."""
        opts = self._opts
        path = Path(str(opts["can_config_file"])).expanduser()
        if not path.is_file():
            raise _refuse("can_config_file", opts["can_config_file"], CAN_OPTIONS["can_config_file"].expected)
        section = opts["can_config_context"] if opts["can_config_context"] is not None else "default"
        values = self._can.util.load_file_config(path, section=str(section))
        if not values:
            raise _refuse("can_config_context", section, f"a section of {path} with interface and channel")
        # can.util.load_config does the same ('500000' -> 500000, 'False' -> False); ignore_config skips it in can.Bus
        return {key: self._can.util.cast_from_string(value) for key, value in values.items()}

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

    def _send_timeout(self) -> float:
        """``send_timeout_s``, so that the frames of one write, each waiting that long, fit in ``board_timeout_s``."""
        frames = len(self.layout.command_messages)
        most_s = self.board_timeout_s / frames
        if self.options.get("send_timeout_s") is None:
            return min(DEFAULT_SEND_TIMEOUT_S, most_s)
        timeout_s = self._opts["send_timeout_s"]
        if timeout_s > most_s:
            raise _refuse("send_timeout_s", timeout_s, f"at most {most_s:.4g} s: board_timeout_s "
                        f"{self.board_timeout_s:g} s shared by the {frames} command frames of one write; a write that "
                        "waits longer for a stuck bus outlasts the board's timeout and stalls the command loop (lower "
                        "it, or raise board_timeout_s)")
        return timeout_s

    @staticmethod
    def _load_dbc(cantools, path: Path):
        if not path.is_file():
            raise _refuse("dbc_file", str(path), f"an existing DBC file (default: {DEFAULT_DBC_FILE} in the package "
                        "config/)")
        try:
            return cantools.database.load_file(str(path), database_format="dbc")
        except Exception as exc:  # cantools raises parser-specific errors
            raise _refuse("dbc_file", str(path), f"a valid DBC file (cantools: {exc})") from exc

    # -- the contract -----------------------------------------------------------------------
    def channel_labels(self) -> list[str]:
        """Per joint: the signal and frame that drive it, e.g. ``CMD_CH1 in SRS_CMD_A (0x100)``."""
        return [f"{s.name} in {m.name} (0x{m.frame_id:03X})" for m, s in self.layout.command]

    def _open(self) -> None:
        can = self._can
        description = self._bus_description()
        try:
            bus = can.Bus(**self._bus_kwargs)
        except can.CanInterfaceNotImplementedError as exc:
            interface = self._bus_kwargs.get("interface")
            backends = can.interfaces.BACKENDS
            if interface is None or interface not in backends:
                raise _refuse("interface", interface, f"one of {sorted(backends)}, here or in python-can's config "
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
            if self.layout.monitor:
                bus.set_filters([{"can_id": frame_id, "can_mask": 0x1FFFFFFF, "extended": extended}
                                 for frame_id, extended in self.layout.monitor])
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
        if self.layout.alive and self._alive:
            _, modulus = next(iter(self.layout.alive.values()))
            details["alive_counter"] = (self._alive - 1) % modulus  # carried by the last write
        if not self.layout.monitor:
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
        return self.layout.encode_frames(command_v, alive)

    def _send_frames(self, command_v: np.ndarray) -> None:
        can = self._can
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
        """Decode the monitor frames received since the last call (non-blocking); never raises."""
        if not self.layout.monitor or self._bus is None:
            return
        for _ in range(MAX_FRAMES_PER_DRAIN):
            try:
                message = self._bus.recv(timeout=0.0)
            except (self._can.CanError, OSError):
                return  # a broken bus shows up on the next send, which raises HardwareError
            if message is None:
                return
            self._decode_monitor(message)

    def _decode_monitor(self, message) -> None:
        entry = self.layout.monitor.get((message.arbitration_id, bool(message.is_extended_id)))
        if entry is None:
            return
        dbc_message, layout = entry
        try:  # numbers, not a VAL_ table's names: a named value is still a voltage or a pressure
            decoded = dbc_message.decode(bytes(message.data), decode_choices=False)
            values = [(joint, float(decoded[name]), unit) for joint, name, unit in layout]
        except Exception:  # noqa: BLE001 - a malformed frame is counted, never fatal
            self._decode_errors += 1
            return
        low_v, high_v = self.monitor_range_v
        full_bar = self.robot.command_full_scale_pressure_bar
        now = time.monotonic()
        for joint, value, unit in values:
            if unit == "V":
                value = (value - low_v) / (high_v - low_v) * full_bar
            self._measured_bar[joint] = value
            self._measured_stamp_s[joint] = now

    def _bus_description(self) -> str:
        kwargs = self._bus_kwargs
        return f"{kwargs.get('interface', '<python-can config>')}:{kwargs.get('channel', '<default>')}"
