"""Pacing the simulated world to a clock (bounded catch-up) and the simulated board's vent on silence."""

import numpy as np
import pytest

from srs_ros.sim.realtime import (
    MAX_CATCH_UP_S,
    RECEIVER_BEHIND_S,
    RealTimePacer,
    ReceiverWatch,
    SimulatedBoard,
)


def test_the_pacer_follows_the_wall_clock_and_slips_after_a_stall_instead_of_racing():
    pacer = RealTimePacer()
    assert pacer.step_s(100.0) == 0.0  # the first wake-up only starts the clock
    assert pacer.step_s(100.01) == pytest.approx(0.01)
    assert pacer.step_s(100.02) == pytest.approx(0.01)
    # A stall of 0.3 s: the world advances by the bound only; the rest is slipped and counted.
    assert pacer.step_s(100.32) == pytest.approx(MAX_CATCH_UP_S)
    assert pacer.slipped_s == pytest.approx(0.3 - MAX_CATCH_UP_S) and pacer.slips == 1
    assert pacer.step_s(100.33) == pytest.approx(0.01)  # and then follows the wall clock again
    assert pacer.step_s(100.32) == 0.0  # a clock that goes back never steps backwards
    pacer.restart()
    assert pacer.step_s(200.0) == 0.0


def test_the_board_applies_every_command_once_at_the_world_time_it_arrived():
    board = SimulatedBoard(joint_count=9, command_timeout_s=0.5)
    assert board.take(0.0) == []  # vented from the start: nothing to time out
    board.receive(np.full(9, 2.0), 0.003)
    board.receive(np.full(9, 3.0), 0.008)
    taken = board.take(0.01)
    assert [t for t, _ in taken] == pytest.approx([0.003, 0.008])  # each at its own time, in order
    assert [p[0] for _, p in taken] == [2.0, 3.0]
    assert board.take(0.02) == []
    board.receive(np.full(9, 1.0), 0.05)  # dated after the wake-up (the loop ran late): at the wake-up
    board.receive(np.full(9, 1.5), 0.001)  # dated before the previous one: not before it
    board.receive(np.full(9, 0.5))  # undated: at the wake-up
    assert [t for t, _ in board.take(0.03)] == pytest.approx([0.03, 0.03, 0.03])


def test_the_board_vents_once_when_commands_stop_for_its_timeout_of_world_time():
    board = SimulatedBoard(joint_count=9, command_timeout_s=0.5)
    board.receive(np.full(9, 4.0), 0.99)
    board.take(1.0)
    assert board.take(1.49) == []  # exactly the timeout after the command's own time: still holding
    [(when_s, vent)] = board.take(1.5)
    assert when_s == 1.5 and not vent.any() and board.vented_by_silence and board.silence_vents == 1
    assert board.take(3.0) == []  # vented once, not at every wake-up
    board.receive(np.full(9, 1.0), 3.005)  # commands come back: the board follows them again
    [(when_s, command)] = board.take(3.01)
    assert when_s == pytest.approx(3.005) and command == pytest.approx(np.full(9, 1.0))
    assert not board.vented_by_silence
    board.reset()
    assert board.take(10.0) == [] and not board.vented_by_silence and board.silence_vents == 1


def test_silence_counts_only_from_the_last_moment_the_receiver_was_behind():
    """A stall of the simulator's own receiving thread is not the sender's silence: the sender gets a whole
    timeout once the receiver runs again, and a sender that then stays silent is vented as always."""
    board = SimulatedBoard(joint_count=9, command_timeout_s=0.5)
    board.receive(np.full(9, 4.0), 0.99)
    board.take(1.0)
    for world_s in np.arange(1.1, 2.0, 0.1):  # the receiver is behind from 1.1 s to 1.9 s: nothing comes in
        board.receiver_behind(world_s)
        assert board.take(world_s) == []
    assert board.take(2.3) == [] and board.silence_vents == 0  # 1.3 s after the command, 0.4 s after the stall
    board.receive(np.full(9, 3.0), 2.35)  # the commands the stall held back arrive: followed, never vented
    assert [p[0] for _, p in board.take(2.36)] == [3.0]
    [(when_s, vent)] = board.take(2.86)  # then a real silence of 0.5 s: vented
    assert when_s == 2.86 and not vent.any() and board.silence_vents == 1
    board.receiver_behind(5.0)
    board.reset()  # a reset forgets the stall as well as the commands
    board.receive(np.full(9, 1.0), 0.0)
    board.take(0.01)
    assert board.take(0.52)[0][1].sum() == 0.0


def test_a_receiver_watch_tells_behind_from_stuck_and_counts_only_the_silence_its_thread_was_there_to_hear():
    """The clock of both ends of the simulated rig: sim_world's executor and the sim backend's bus thread."""
    watch = ReceiverWatch(stuck_s=5.0)
    assert not watch.behind(0.0)  # not started: nothing to be behind on
    watch.start(10.0)
    for now_s in np.arange(10.05, 11.0, 0.05):  # a healthy thread runs every 50 ms
        watch.ran(now_s)
        assert not watch.behind(now_s + 0.04)
    assert watch.stalls == 0 and watch.heard_silence_s(10.2) == pytest.approx(0.75)  # heard from 10.2 to 10.95
    assert watch.behind(10.95 + RECEIVER_BEHIND_S + 0.01) and watch.behind(15.9)
    assert not watch.behind(15.96) and watch.deaf_s(15.96) == pytest.approx(5.01)  # stuck: no longer "behind"
    watch.ran(11.8)  # it ran again 0.85 s late: resumed; the silence before was not heard
    assert watch.stalls == 1 and watch.resumed_s == 11.8
    watch.ran(11.85)
    assert watch.heard_silence_s(10.2) == pytest.approx(0.05) and watch.heard_silence_s(11.82) == pytest.approx(0.03)
    watch.ran(12.0)
    watch.ran(12.0 + RECEIVER_BEHIND_S)  # exactly the limit apart: not behind
    assert watch.stalls == 1


def test_a_command_dated_before_a_vent_the_board_applied_comes_after_it():
    """A command that arrived while the vent was applied is dated from the wake-up before: it follows the vent
    (the world refuses a command older than the last, and would stop)."""
    board = SimulatedBoard(joint_count=9, command_timeout_s=0.5)
    board.receive(np.full(9, 4.0), 0.99)
    board.take(1.0)
    [(vent_s, _)] = board.take(1.6)
    board.receive(np.full(9, 2.0), 1.599)
    [(when_s, command)] = board.take(1.61)
    assert when_s == vent_s == 1.6 and command[0] == 2.0


def test_commands_dated_and_applied_at_the_next_tick_move_the_world_as_commands_applied_as_they_came():
    """What sim_world relies on: with the supply line's delay (30 ms) longer than a control period (10 ms), a
    command applied at the next wake-up at the time it arrived is felt exactly as one applied on arrival."""
    from srs_ros.sim.config import load_sim_config
    from srs_ros.sim.world import SimWorld

    config = load_sim_config()
    assert config.muscles.transport_delay_s > config.physics.control_period_s
    times_s = np.arange(1, 120) * 0.004 + 0.002  # 250 commands a second, between the 10 ms ticks
    commands = [np.clip(4.0 * np.sin(np.arange(9) + 9.0 * t), 0.0, 4.0) for t in times_s]
    on_arrival, at_ticks = SimWorld(config), SimWorld(config)
    for when_s, command in zip(times_s, commands):
        on_arrival.advance_to(when_s)
        on_arrival.command_pressures(command, on_arrival.time_s)
    on_arrival.advance_to(0.5)
    board = SimulatedBoard(joint_count=9, command_timeout_s=0.5)
    pending = list(zip(times_s, commands))
    for tick_s in np.arange(1, 51) * 0.01:
        at_ticks.advance_to(tick_s)
        while pending and pending[0][0] <= tick_s + 1e-9:
            board.receive(pending[0][1], pending.pop(0)[0])
        for when_s, command in board.take(at_ticks.time_s):
            at_ticks.command_pressures(command, when_s)
    assert at_ticks.time_s == pytest.approx(on_arrival.time_s)
    assert at_ticks.muscles.state(0.5)[0] == pytest.approx(on_arrival.muscles.state(0.5)[0], abs=1e-12)
    assert at_ticks.state().nodes_m == pytest.approx(on_arrival.state().nodes_m, abs=1e-9)
