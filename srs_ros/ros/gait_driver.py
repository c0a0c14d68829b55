"""Plays the navigator's gait commands through the existing gait interfaces, never around them.

A :class:`GaitDriver` turns each new :class:`~srs_ros.core.navigation.GaitCommand` into the calls an operator
would make (relative names, resolved in the navigator's namespace)::

    trajectory_server/set_parameters_atomically   gait, amplitude_bar, <gait>.turn_phase_rad or .c_rad_per_unit
    trajectory_server/regenerate                  the new cycle is fitted and latched; gait_player cross-fades
    gait_player/set_parameters                    frequency_hz and reverse (live; the signed frequency ramps,
                                                  through 0 for a reversal: outward rolling = inward backward)
    gait_player/start                             ramp in when the robot was stopped; then again every quarter
                                                  of ``keepalive_s`` (a dead man's handle, below)
    gait_player/stop                              ramp out to 0 (all lengths 0 = every muscle vented)
    gait_player/set_parameters  stop_at_phase     a stop near the goal: ramp out as the phase passes it (the
                                                  navigator decides a cycle ahead; a late call stops as exactly)

A dead man's handle made of the player's own interface: the driver sets gait_player's ``cycles`` so that a
``~/start`` lets it play ``keepalive_s`` (2 s by default) more, and calls ``~/start`` again every quarter of
that while the robot is to move ("already running" only pushes the end on). A navigator that dies or hangs
stops calling: the player ramps out by itself after at most ``keepalive_s`` plus two cycles
(:meth:`GaitDriver._player_values`).

So every pressure still goes through gait_player's ramps and the hardware node's one clamp; the driver never
arms, never touches the e-stop and never publishes a setpoint. Calls are asynchronous (a callback never
blocks the node), one at a time in that order, the newest command wins; a stop goes out at once, even while
another call is pending. A refused or unanswered call is retried after :data:`RETRY_S` and said in
:attr:`GaitDriver.error` (the navigator publishes it). A ``~/regenerate`` answered "busy" (trajectory_server is
still fitting, e.g. its start-up fit when the navigator starts with it) is no failure: the gait's parameters and
``~/regenerate`` are sent again every :data:`~srs_ros.ros.interfaces.BUSY_RETRY_S`, and it is said as an error (and
retried after :data:`RETRY_S`) only once the server has answered "busy" for :data:`CALL_TIMEOUT_S`. Busy answers
more than :data:`BUSY_GAP_S` apart belong to separate periods (the driver stopped asking meanwhile).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

from rcl_interfaces.srv import SetParameters, SetParametersAtomically
from rclpy.exceptions import NameValidationException
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_srvs.srv import Trigger

from srs_ros.core.errors import ConfigurationError
from srs_ros.ros.interfaces import BUSY_RETRY_S, fit_busy

#: Wait before a failed call is made again (s).
RETRY_S = 1.0
#: A call without an answer for this long is given up (and retried), s.
CALL_TIMEOUT_S = 5.0
#: "Busy" answers of ``~/regenerate`` further apart than this start a new busy period (s): while the driver still
#: wants a new cycle it asks again within RETRY_S (plus the calls' round trip), so two of those.
BUSY_GAP_S = 2.0 * RETRY_S + BUSY_RETRY_S
#: gait_player's parameters the driver sets, in the order of its player key.
PLAYER_VALUES = ("frequency_hz", "reverse", "cycles", "stop_at_phase")
#: gait_player's ``stop_at_phase`` for none pending.
NO_STOP_PHASE = -1.0


class GaitDriver:
    """Drives ``trajectory_server`` and ``gait_player`` (node names, relative) from gait commands.

    :meth:`drive` takes a new command; :meth:`pump` (from the navigator's timer and after every answer) makes
    the next call. ``_playing`` is True from a ``~/start`` sent until a ``~/stop`` answered: a start and a stop
    in flight together (two services, no order between them) end with another stop.
    """

    def __init__(self, node: Node, trajectory_server: str, gait_player: str, keepalive_s: float = 2.0,
                 clock: Callable[[], float] = time.monotonic):
        self._node = node
        self._clock = clock
        self.keepalive_s = float(keepalive_s)  # 0: no dead man's handle (the gait plays until stopped)
        self._started_s = -math.inf  # when the last ~/start was sent
        try:
            self._clients = {
                "set_gait": node.create_client(SetParametersAtomically,
                                               f"{trajectory_server}/set_parameters_atomically"),
                "regenerate": node.create_client(Trigger, f"{trajectory_server}/regenerate"),
                "set_player": node.create_client(SetParameters, f"{gait_player}/set_parameters"),
                "start": node.create_client(Trigger, f"{gait_player}/start"),
                "stop": node.create_client(Trigger, f"{gait_player}/stop"),
            }
        except NameValidationException as exc:  # a traceback before (a helper's review)
            raise ConfigurationError(
                f"trajectory_server {trajectory_server!r} or gait_player {gait_player!r} is not a node name: "
                f"{str(exc).splitlines()[0].rstrip(':')}; expected letters, digits and '_' (e.g. gait_player, or "
                "/snake1/gait_player in another namespace)") from None
        self.wanted = None  # the newest GaitCommand
        self._cycle_key: tuple | None = None  # latched by trajectory_server (its regenerate answered success)
        self._sent_key: tuple | None = None  # parameters set, regenerate not yet answered
        self._player_key: tuple | None = None  # gait_player's (frequency_hz, reverse, cycles, stop_at_phase) as set
        self._playing = False
        self._phase_stopped = False  # stop_at_phase sent: the player ramps out by itself at the phase
        self._stop_owed = False  # stop() called: a ~/stop is sent once no ~/start is in flight
        self._pending: dict[str, tuple[Any, float]] = {}  # what -> (future, sent at)
        self._retry_at = 0.0
        self._busy = (math.nan, math.nan)  # regenerate's busy period: its first and its last "busy" answer (s)
        self.error = ""  # the last failure ('' once a call succeeds again)
        self.calls: dict[str, int] = {name: 0 for name in self._clients}  # calls made, by kind

    # ------------------------------------------------------------- the interface
    def drive(self, command) -> None:
        """Take ``command`` (a GaitCommand); a stop is sent at once, anything else by :meth:`pump`."""
        if command != self.wanted:
            self._retry_at = 0.0  # a new command is tried at once; the same one after RETRY_S
        self.wanted = command
        self.pump()

    def stop(self, command) -> None:
        """Take the stop ``command`` and call ``gait_player/stop`` whether or not this driver started it.

        A ``~/start`` still unanswered (the dead man's handle sends one every quarter of ``keepalive_s``) is let
        answer first: the two services have no order between them, and a start the player took after the stop
        would ramp the gait in again (found while tracing a cancel test; not seen to happen). The stop goes out
        with the start's answer, or once the start is given up (:data:`CALL_TIMEOUT_S`). :attr:`busy` is False
        once it is answered.
        """
        self.wanted = command
        self._playing = self._phase_stopped = False
        self._stop_owed = True
        self.pump()

    @property
    def playing(self) -> bool:
        """True while the player was started by this driver and no stop has been answered since."""
        return self._playing

    @property
    def busy(self) -> bool:
        """True while a call is waiting for its answer."""
        return bool(self._pending)

    def services(self) -> list[str]:
        """The full names of the services the driver calls."""
        return [self._node.resolve_service_name(client.srv_name) for client in self._clients.values()]

    def missing_services(self) -> list[str]:
        """The services not (yet) available."""
        return [client.srv_name for client in self._clients.values() if not client.service_is_ready()]

    def pump(self) -> None:
        """Give up unanswered calls, then make the next call the newest command needs (if none is pending)."""
        now = self._clock()
        for what, (future, sent_s) in list(self._pending.items()):
            if now - sent_s > CALL_TIMEOUT_S:
                self._clients[what].remove_pending_request(future)
                del self._pending[what]
                self._failed(what, f"no answer for {CALL_TIMEOUT_S:g} s (is the node running?)")
        command = self.wanted
        if command is None:
            return
        if not command.moving:
            if command.stop_phase is not None and self._playing:
                self._stop_at_phase(float(command.stop_phase), now)
            elif (self._playing or self._stop_owed) and not {"stop", "start"} & self._pending.keys():
                self._call("stop", Trigger.Request(), self._on_stop)  # owed until answered: a failed one again
            return
        keepalive = self.keepalive_s > 0 and now - self._started_s >= self.keepalive_s / 4
        if self._playing and not self._phase_stopped and keepalive and "start" not in self._pending:
            self._start(now)  # the dead man's handle, whatever else is pending
        if self._pending or now < self._retry_at:
            return
        if command.cycle_key != self._cycle_key:
            self._set_gait(command)
        elif self._player_key != self._player_values(command):
            self._set_player(self._player_values(command))
        elif not self._playing or self._phase_stopped:
            # After a stop at a phase the player ramps out by itself: driving on starts it again once the new cycle
            # and its parameters are set (before, the keepalive's start ramped the old gait in first, and with no
            # keepalive nothing started it at all: the robot lay still while the navigator said "driving").
            self._playing, self._phase_stopped = True, False
            self._start(now)

    def _player_values(self, command) -> tuple[float, bool, int, float]:
        """gait_player's (frequency_hz, reverse, cycles, stop_at_phase) for a moving ``command``.

        cycles: keepalive_s of them (0 = none), and at least enough that a stop at a phase set up to a quarter of
        keepalive_s after the last start still comes first, a cycle later (1 cycle at 0.5 Hz ramped out at phase 0
        before the phase asked for); no stop at a phase pending.
        """
        wanted = self.keepalive_s * command.frequency_hz
        cycles = max(math.ceil(wanted), math.floor(wanted / 4) + 2) if self.keepalive_s > 0 else 0
        return (float(command.frequency_hz), bool(command.reverse), cycles, NO_STOP_PHASE)

    def _stop_at_phase(self, phase: float, now: float) -> None:
        """A stop at a gait phase: gait_player's ``stop_at_phase`` set (it ramps out as the phase passes it).

        No ``~/start`` meanwhile (a start after the ramp-out began would ramp in again): the ``cycles`` of the
        last start outlast the one cycle to the phase (:meth:`_player_values`), and a navigator that dies now leaves a
        gait that ramps out by itself at the phase.
        """
        key = (*(self._player_key or (math.nan, False, 0, NO_STOP_PHASE))[:3], phase)
        if self._player_key == key or "set_player" in self._pending or now < self._retry_at:
            return
        self._phase_stopped = True
        self._set_player(key, names=("stop_at_phase",))

    # ------------------------------------------------------------- the calls
    def _set_gait(self, command) -> None:
        values = {"gait": command.gait, "amplitude_bar": float(command.amplitude_bar),
                  **{f"{command.gait}.{name}": value for name, value in command.gait_parameters.items()}}
        request = SetParametersAtomically.Request(
            parameters=[Parameter(name, value=value).to_parameter_msg() for name, value in values.items()])
        self._sent_key = command.cycle_key
        self._call("set_gait", request, self._on_set_gait)

    def _start(self, now: float) -> None:
        self._started_s = now
        self._call("start", Trigger.Request(), self._on_start)

    def _set_player(self, key: tuple[float, bool, int, float], names: tuple[str, ...] = PLAYER_VALUES) -> None:
        """Set gait_player's ``names`` (of :data:`PLAYER_VALUES`) to their values in ``key``; ``key`` once done."""
        values = {name: value for name, value in zip(PLAYER_VALUES, key) if name in names}
        request = SetParameters.Request(
            parameters=[Parameter(name, value=value).to_parameter_msg() for name, value in values.items()])
        self._call("set_player", request, lambda response: self._on_set_player(response, values, key))

    def _call(self, what: str, request, on_answer: Callable[[Any], None]) -> None:
        client = self._clients[what]
        if not client.service_is_ready():
            self._failed(what, f"service {client.srv_name} is not available (is the node running?)")
            if what == "start":  # a keepalive's: the player may still play the last start, so a stop is owed
                self._playing, self._stop_owed = False, True
            return
        future = client.call_async(request)
        self._pending[what] = (future, self._clock())
        self.calls[what] += 1

        def answered(done) -> None:
            if self._pending.get(what, (None,))[0] is not done:
                return  # given up meanwhile
            del self._pending[what]
            try:
                response = done.result()
            except Exception as exc:  # the client was destroyed at shutdown, or rclpy raised
                self._failed(what, f"{type(exc).__name__}: {exc}")
                return
            on_answer(response)
            self.pump()

        future.add_done_callback(answered)

    # ------------------------------------------------------------- the answers
    def _on_set_gait(self, response) -> None:
        if not response.result.successful:
            self._failed("set_gait", f"trajectory_server refused the parameters: {response.result.reason}")
            return
        self._call("regenerate", Trigger.Request(), self._on_regenerate)

    def _on_regenerate(self, response) -> None:
        if not response.success:
            now = self._clock()
            if fit_busy(response.message):
                since, last = self._busy
                since = since if now - last <= BUSY_GAP_S else now  # NaN (no period yet) compares False
                self._busy = (since, now)
                if now - since < CALL_TIMEOUT_S:
                    self._retry_at = now + BUSY_RETRY_S  # another fit is running: asked again soon, not a failure
                    return
            self._failed("regenerate", f"trajectory_server could not regenerate: {response.message}")
            return
        self._cycle_key, self.error, self._busy = self._sent_key, "", (math.nan, math.nan)

    def _on_set_player(self, response, values: dict[str, Any], key: tuple) -> None:
        refused = [f"{name} {value}: {result.reason}" for (name, value), result in zip(values.items(), response.results)
                   if not result.successful]
        if refused or len(response.results) != len(values):
            self._failed("set_player", "gait_player refused " + ("; ".join(refused) or "the parameters (no result)"))
            return
        self._player_key, self.error = key, ""

    def _on_start(self, response) -> None:
        if not response.success:
            self._playing, self._stop_owed = False, True  # it may still play an earlier start: stop it when asked
            self._failed("start", f"gait_player did not start: {response.message}")
            return
        # Playing as asked: a stop owed (a failed or refused start before, a cancel) is covered by playing now. It is
        # not cleared by driving on: the navigator drives at every pose, and a stop owed was lost before the lost pose.
        self._playing, self._stop_owed, self.error = True, False, ""

    def _on_stop(self, response) -> None:
        if not response.success:
            self._failed("stop", f"gait_player did not stop: {response.message}")
            return
        self._stop_owed = False
        self._playing = "start" in self._pending  # a start sent after this stop (a new goal) is in flight
        if not self._playing:  # stopped as wanted: an earlier failure (a start never answered) is over
            self.error = ""

    def _failed(self, what: str, reason: str) -> None:
        self.error = f"{what}: {reason}"
        self._retry_at = self._clock() + RETRY_S
        self._node.get_logger().error(f"gait command not applied, retrying in {RETRY_S:g} s: {self.error}",
                                      throttle_duration_sec=2.0)
