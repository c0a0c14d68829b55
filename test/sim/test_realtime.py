"""Pacing the simulated world to a clock (bounded catch-up) and the simulated board's vent on silence."""

import numpy as np
import pytest

from srs_ros.sim.realtime import MAX_CATCH_UP_S, RealTimePacer, SimulatedBoard


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


def test_the_board_applies_each_new_command_once():
    board = SimulatedBoard(joint_count=9, command_timeout_s=0.5)
    assert board.take(0.0) is None  # vented from the start: nothing to time out
    board.receive(np.full(9, 2.0))
    board.receive(np.full(9, 3.0))  # the newest wins
    assert board.take(0.01) == pytest.approx(np.full(9, 3.0))
    assert board.take(0.02) is None


def test_the_board_vents_once_when_commands_stop_for_its_timeout_of_world_time():
    board = SimulatedBoard(joint_count=9, command_timeout_s=0.5)
    board.receive(np.full(9, 4.0))
    board.take(1.0)
    assert board.take(1.5) is None  # exactly the timeout: still holding
    vent = board.take(1.51)
    assert vent is not None and not vent.any() and board.vented_by_silence and board.silence_vents == 1
    assert board.take(3.0) is None  # vented once, not at every wake-up
    board.receive(np.full(9, 1.0))  # commands come back: the board follows them again
    assert board.take(3.01) == pytest.approx(np.full(9, 1.0)) and not board.vented_by_silence
    board.reset()
    assert board.take(10.0) is None and not board.vented_by_silence and board.silence_vents == 1
