"""The gait driver's calls after a stop at a gait phase, against stand-in services answered by hand (no DDS).

Found by a helper's review (stop 59): after a stop at a phase (the navigator's stop a cycle ahead), driving on sent
gait_player's ``~/start`` before the new cycle and its parameters (the idle player ramped the old gait in: the
creep from rest began with a kick of the cruise gait), and with no dead man's handle it sent no ``~/start`` at all
(the robot lay still while the navigator said "driving", until the stall timeout). And at 0.5 Hz or slower the
dead man's cycles ran out before the phase asked for.
"""

from __future__ import annotations

import pytest
from rcl_interfaces.msg import SetParametersResult
from rcl_interfaces.srv import SetParameters, SetParametersAtomically
from rclpy.task import Future
from srs_testing import rolling_cycle
from std_srvs.srv import Trigger

from srs_ros.core.gait.playback import GaitPlayback
from srs_ros.core.navigation import GaitCommand
from srs_ros.ros.gait_driver import GaitDriver


class StandInClient:
    """A service client whose calls wait in ``node.calls`` until the test answers them."""

    def __init__(self, node, srv_type, name: str):
        self.node, self.srv_type, self.srv_name = node, srv_type, name

    def service_is_ready(self) -> bool:
        return True

    def call_async(self, request) -> Future:
        future = Future()
        self.node.calls.append((self.srv_name.rsplit("/", 1)[-1], request, future, self.srv_type))
        return future

    def remove_pending_request(self, future) -> None:
        pass


class StandInNode:
    def __init__(self):
        self.calls: list = []
        self.log: list[str] = []

    def create_client(self, srv_type, name: str) -> StandInClient:
        return StandInClient(self, srv_type, name)

    def answer_all(self) -> None:
        """Answer every call in order, as the nodes would (success), recording what was called."""
        while self.calls:
            what, request, future, srv_type = self.calls.pop(0)
            self.log.append(what if what != "set_parameters" else
                            "set_player " + ",".join(p.name for p in request.parameters))
            if srv_type is SetParametersAtomically:
                future.set_result(SetParametersAtomically.Response(result=SetParametersResult(successful=True)))
            elif srv_type is SetParameters:
                future.set_result(SetParameters.Response(results=[SetParametersResult(successful=True)]
                                                         * len(request.parameters)))
            else:
                future.set_result(Trigger.Response(success=True, message="ok"))


CRUISE = GaitCommand("inward_rolling", 0.0, 4.0, 1.0)
CREEP = GaitCommand("outward_rolling", 0.0, 1.5, 0.25, creep=True)


def driven(keepalive_s: float):
    node, now = StandInNode(), [0.0]
    driver = GaitDriver(node, "trajectory_server", "gait_player", keepalive_s=keepalive_s, clock=lambda: now[0])
    driver.drive(CRUISE)
    node.answer_all()
    assert driver.playing and node.log[-1] == "start", node.log
    now[0] += 0.3
    driver.drive(GaitCommand(None, 0.0, 4.0, 1.0, stop_phase=0.25))  # the stop a cycle ahead
    node.answer_all()
    assert node.log[-1] == "set_player stop_at_phase", node.log
    return driver, node, now


@pytest.mark.parametrize("keepalive_s", [0.0, 2.0])
def test_driving_on_after_a_stop_at_a_phase_sets_the_new_cycle_first_then_starts(keepalive_s):
    driver, node, now = driven(keepalive_s)
    before = len(node.log)
    now[0] += 3.0  # the player has ramped out at the phase and is idle; the fine approach creeps from rest
    for _ in range(5):
        driver.drive(CREEP)
        node.answer_all()
        now[0] += 0.1
    after = node.log[before:]
    assert "start" in after, after  # with no dead man's handle nothing started the player again
    first_start = after.index("start")
    assert after[:first_start] == ["set_parameters_atomically", "regenerate",
                                   "set_player frequency_hz,reverse,cycles,stop_at_phase"], after
    assert driver.playing and not driver.error


@pytest.mark.parametrize("frequency_hz", [0.1, 0.25, 0.4, 0.5, 1.0, 2.0])
def test_the_dead_mans_cycles_outlast_a_stop_at_a_phase_set_a_quarter_keepalive_after_the_start(frequency_hz):
    """The player (core playback) started with the driver's cycles; a stop at a phase is set a quarter of
    keepalive_s later (the latest before the next keepalive start): it must ramp out at that phase, not earlier."""
    node = StandInNode()
    driver = GaitDriver(node, "trajectory_server", "gait_player", keepalive_s=2.0)
    cycles = driver._player_values(GaitCommand("inward_rolling", 0.0, 4.0, frequency_hz))[2]
    playback, dt_s = GaitPlayback(ramp_time_s=0.5), 0.005
    playback.load(rolling_cycle(), frequency_hz)
    playback.start(cycles=cycles)
    for _ in range(round(0.5 / dt_s)):  # keepalive_s / 4
        playback.step(dt_s)
    stop_phase = (playback.phase + 0.999) % 1.0  # just under a whole cycle ahead: the worst case
    playback.stop_at_phase(stop_phase)
    while playback.state.value in ("starting", "running"):
        playback.step(dt_s)
    behind = (playback.phase - stop_phase) % 1.0  # the ramp-out begins on the step that passes the phase
    assert behind <= frequency_hz * dt_s + 1e-9, (cycles, stop_phase, playback.phase)


class FlakyStartNode(StandInNode):
    """Its gait_player's ``~/start`` service can be missing from the graph for a moment (a DDS hiccup)."""

    def __init__(self):
        super().__init__()
        self.start_ready, self.errors = True, []

    def create_client(self, srv_type, name: str) -> StandInClient:
        client = StandInClient(self, srv_type, name)
        if name.endswith("/start"):
            client.service_is_ready = lambda: self.start_ready
        return client

    def get_logger(self):
        return self

    def error(self, text: str, **_kwargs) -> None:
        self.errors.append(text)


@pytest.mark.parametrize("failure", ["not sent", "refused"])
def test_a_stop_after_a_keepalive_start_that_failed_still_stops_the_player_after_driving_on(failure):
    """The failed keepalive marked the player not playing though it still played the last start, so the stop for a
    lost pose sent no ~/stop: the gait played on until its dead man's cycles ran out (a helper's review). The owed
    stop must also outlast the navigator's next drives (it drives at every pose): the first fix cleared it there."""
    node, now = FlakyStartNode(), [0.0]
    driver = GaitDriver(node, "trajectory_server", "gait_player", keepalive_s=2.0, clock=lambda: now[0])
    driver.drive(CRUISE)
    node.answer_all()
    assert driver.playing and node.log[-1] == "start", node.log
    now[0] = 0.6
    if failure == "not sent":
        node.start_ready = False  # the keepalive's ~/start cannot go out
        driver.drive(CRUISE)
        assert "not available" in driver.error
        node.start_ready = True
    else:
        driver.drive(CRUISE)
        what, _request, future, _srv = node.calls.pop(0)
        assert what == "start"
        future.set_result(Trigger.Response(success=False, message="busy"))
        assert "did not start" in driver.error
    node.log[:] = []
    now[0] += 0.05
    driver.drive(CRUISE)  # driving on, as at the next pose: the keepalive is tried again only later
    assert node.calls == [], node.calls
    for _ in range(5):
        now[0] += 0.1
        driver.drive(GaitCommand(None, 0.0, 4.0, 1.0))  # the pose lost: stop
        node.answer_all()
    assert node.log == ["stop"] and not driver.playing
