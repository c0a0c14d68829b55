"""A reference DAC board: what docs/can.md asks of the board's firmware, in Python, for the tests.

It decodes the host's command frames with the DBC and keeps nine output voltages. A command frame is
*valid* when it has 8 data bytes, its CRC-8 matches and its alive counter moved on by +1 .. +MAX_STEP
from the previous frame of the same ID. The board vents (0 V on all nine outputs) when

- any command frame ID has had no valid frame for ``timeout_s`` (silence, or a counter that stopped:
  repeated frames are not valid, so they do not keep it alive),
- a counter jumps (any other step), or
- its controller goes bus-off,

and applies commands again only after every command ID has sent RESYNC_FRAMES valid frames in a row.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field

import cantools

from srs_ros.backends.can_backend import crc8_sae_j1850
from srs_ros.core.robot import config_dir

MAX_STEP = 3        # accept up to two lost ticks
RESYNC_FRAMES = 2   # valid frames in a row, per ID, before commands apply again
CHANNELS = 9


@dataclass
class _Stream:
    last_alive: int | None = None
    last_valid_s: float = float("-inf")
    run: int = 0  # valid frames in a row


@dataclass
class ReferenceDacBoard:
    """Board logic; call :meth:`receive` per frame and :meth:`check` periodically (both thread-safe)."""

    timeout_s: float
    dbc_path: str = str(config_dir() / "srs_dac.dbc")
    outputs_v: list[float] = field(default_factory=lambda: [0.0] * CHANNELS)
    vented: bool = True
    vents: list[tuple[float, str]] = field(default_factory=list)  # (time s, reason)
    invalid: dict[str, int] = field(default_factory=dict)

    def __post_init__(self):
        self.db = cantools.database.load_file(self.dbc_path)
        self.command_ids = [m.frame_id for m in self.db.messages if m.name.startswith("SRS_CMD")]
        self.streams = {frame_id: _Stream() for frame_id in self.command_ids}
        self.lock = threading.Lock()

    def _vent(self, now_s: float, reason: str) -> None:
        if not self.vented:
            self.vents.append((now_s, reason))
        self.vented = True
        self.outputs_v = [0.0] * CHANNELS
        for stream in self.streams.values():
            stream.run = 0

    def _reject(self, reason: str) -> None:
        self.invalid[reason] = self.invalid.get(reason, 0) + 1

    def receive(self, frame_id: int, data: bytes, now_s: float) -> None:
        with self.lock:
            stream = self.streams.get(frame_id)
            if stream is None:
                return
            if len(data) != 8:
                return self._reject("length")
            if crc8_sae_j1850(data[:7]) != data[7]:
                return self._reject("crc")
            signals = self.db.decode_message(frame_id, data)
            alive = int(signals["ALIVE"])
            previous, stream.last_alive = stream.last_alive, alive
            if previous is not None:
                step = (alive - previous) % 256
                if step == 0:
                    return self._reject("repeated")  # stale: does not keep the board alive
                if step > MAX_STEP:
                    self._reject("jump")
                    return self._vent(now_s, f"alive counter jumped {previous} -> {alive}")
            stream.last_valid_s = now_s
            stream.run += 1
            if self.vented and all(s.run >= RESYNC_FRAMES for s in self.streams.values()):
                self.vented = False
            if not self.vented:
                for name, value in signals.items():
                    if name.startswith("CMD_CH"):
                        self.outputs_v[int(name[6:]) - 1] = float(value)

    def check(self, now_s: float) -> None:
        with self.lock:
            stale = [f"0x{i:03X}" for i, s in self.streams.items() if now_s - s.last_valid_s > self.timeout_s]
            if stale and not self.vented:
                self._vent(now_s, f"no valid command frame {'/'.join(stale)} for {self.timeout_s:g} s")

    def bus_off(self, now_s: float) -> None:
        with self.lock:
            self._vent(now_s, "bus-off")

    def oldest_valid_s(self) -> float:
        """When the command ID heard from longest ago last sent a valid frame (its timeout runs first)."""
        with self.lock:
            return min(s.last_valid_s for s in self.streams.values())

    def snapshot(self) -> tuple[bool, list[float], list[tuple[float, str]]]:
        with self.lock:
            return self.vented, list(self.outputs_v), list(self.vents)


class BoardTicker:
    """Runs :meth:`ReferenceDacBoard.check` every ``period_s`` in a thread, as the board's timer interrupt."""

    def __init__(self, board: ReferenceDacBoard, period_s: float = 0.002, bus=None):
        self.board, self.period_s, self.bus = board, period_s, bus
        self.stop_event = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while not self.stop_event.is_set():
            if self.bus is not None:  # also the board's CAN receive path
                message = self.bus.recv(timeout=self.period_s)
                while message is not None:
                    self.board.receive(message.arbitration_id, bytes(message.data), time.monotonic())
                    message = self.bus.recv(timeout=0.0)
            else:
                time.sleep(self.period_s)
            self.board.check(time.monotonic())

    def close(self) -> None:
        self.stop_event.set()
        self.thread.join(5.0)
