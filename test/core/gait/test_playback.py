"""Playback of a gait cycle: ramps, live changes and takeover never make a setpoint jump."""

import re

import numpy as np
import pytest

from srs_ros.core.errors import InvalidInputError
from srs_ros.core.gait.interpolation import PeriodicTrajectory
from srs_ros.core.gait.playback import (
    GaitPlayback,
    PlaybackState,
    SmoothTransition,
    cycle_from_points,
    describe_frequency,
    smoothstep,
)

DT_S = 0.005  # 200 Hz
MAX_M = 0.065


def rolling_cycle(count=64, shift=0.0, amplitude_m=MAX_M):
    """Nine sinusoids 120 degrees apart per module: the exact joint-space shape of a rolling arc."""
    phase = np.arange(count)[:, None] / count + shift
    offsets = np.arange(9)[None, :] * 2 * np.pi / 3 + np.repeat([0.0, 1.0, 2.0], 3)[None, :] * np.pi / 3
    return 0.5 * amplitude_m * (1 + np.cos(2 * np.pi * phase - offsets))


def run(player, seconds, dt_s=DT_S):
    return [player.step(dt_s) for _ in range(round(seconds / dt_s))]


def positions(setpoints):
    return np.array([s.positions_m for s in setpoints])


def largest_step_m(setpoints):
    return float(np.max(np.abs(np.diff(positions(setpoints), axis=0))))


def steady_step_bound_m(frequency_hz, dt_s=DT_S):
    """Largest change of one tick while running steadily: max |d cycle / d phase| * f * dt, with margin."""
    slope = np.max(np.abs(PeriodicTrajectory(rolling_cycle()).derivatives(np.linspace(0, 1, 400))))
    return 1.5 * slope * frequency_hz * dt_s


def started(frequency_hz=1.0, ramp_time_s=0.5, **kwargs):
    player = GaitPlayback(ramp_time_s=ramp_time_s, **kwargs)
    player.load(rolling_cycle(), frequency_hz)
    player.start()
    return player


def test_smoothstep_and_transition_are_continuous():
    assert smoothstep(-1) == 0.0 and smoothstep(0.5) == pytest.approx(0.5) and smoothstep(2) == 1.0
    value = SmoothTransition(0.0)
    value.set_target(1.0, 1.0)
    trace = [value.step(0.01) for _ in range(50)]
    value.set_target(0.0, 1.0)  # reversed mid-way: continues from where it is
    trace += [value.step(0.01) for _ in range(150)]
    assert max(np.abs(np.diff(trace))) < 0.02 and trace[-1] == 0.0 and value.settled


def test_idle_player_outputs_zeros_and_start_needs_a_cycle():
    player = GaitPlayback()
    with pytest.raises(InvalidInputError, match="no cycle loaded"):
        player.start()
    player.load(rolling_cycle(), 1.0)
    setpoint = player.step(DT_S)
    assert setpoint.state is PlaybackState.IDLE and not np.any(setpoint.positions_m)


def test_soft_start_ramps_from_zero_then_follows_the_cycle_at_the_integrated_phase():
    player = started(frequency_hz=1.0, ramp_time_s=0.5)
    ramp = run(player, 0.5)
    assert np.max(ramp[0].positions_m) < 1e-4  # starts at (almost) zero
    gains = [s.gain for s in ramp]
    assert np.all(np.diff(gains) >= 0) and gains[-1] == pytest.approx(1.0)
    steady = run(player, 1.3)
    assert steady[-1].state is PlaybackState.RUNNING
    expected = PeriodicTrajectory(rolling_cycle()).values(steady[-1].phase)
    assert np.allclose(steady[-1].positions_m, expected)
    assert steady[-1].cycles_done == pytest.approx(1.8)
    assert largest_step_m(ramp + steady) <= steady_step_bound_m(1.0)


def test_velocities_match_the_change_of_positions():
    player = started(frequency_hz=0.75)
    trace = run(player, 1.0)
    finite = np.diff(positions(trace), axis=0) / DT_S
    reported = np.array([s.velocities_m_per_s for s in trace[1:]])
    assert np.max(np.abs(finite - reported)) < 0.01  # m/s, a small fraction of the ~0.15 m/s peak


def test_stop_ramps_to_zero_and_goes_idle():
    player = started(ramp_time_s=0.4)
    before = run(player, 1.0)
    player.stop()
    ramp = run(player, 0.45)
    assert ramp[-1].state is PlaybackState.IDLE and not np.any(ramp[-1].positions_m)
    assert np.all(np.diff([s.gain for s in ramp]) <= 0)
    assert largest_step_m(before + ramp) <= steady_step_bound_m(1.0)


def test_cycles_ramp_out_after_that_many():
    player = GaitPlayback(ramp_time_s=0.2)
    player.load(rolling_cycle(), 2.0)
    player.start(cycles=3)
    trace = run(player, 2.0)
    stop_at = next(i for i, s in enumerate(trace) if s.state is PlaybackState.STOPPING)
    assert trace[stop_at].cycles_done == pytest.approx(3.0, abs=2.0 * DT_S)
    assert trace[-1].state is PlaybackState.IDLE


@pytest.mark.parametrize("reverse", [False, True])
@pytest.mark.parametrize("stop_phase", [0.0, 0.25, 0.6])
def test_a_stop_at_a_phase_ramps_out_as_the_phase_passes_it_whenever_it_was_asked(stop_phase, reverse):
    player = started(frequency_hz=1.0)
    player.set_reverse(reverse)
    run(player, 2.0)
    asked_at = player.phase
    player.stop_at_phase(stop_phase)
    assert player.pending_stop_phase == stop_phase
    trace = run(player, 2.5)
    stop_at = next(i for i, s in enumerate(trace) if s.state is PlaybackState.STOPPING)
    played = (stop_phase - asked_at if not reverse else asked_at - stop_phase) % 1.0
    assert stop_at * DT_S == pytest.approx(played, abs=1.5 * DT_S)  # within the next cycle, not at once
    assert trace[stop_at].phase == pytest.approx(stop_phase, abs=1.5 * DT_S) or \
        abs(trace[stop_at].phase - stop_phase) == pytest.approx(1.0, abs=1.5 * DT_S)
    assert trace[-1].state is PlaybackState.IDLE and not np.any(trace[-1].positions_m)
    assert player.pending_stop_phase is None


def test_a_stop_overrides_a_pending_stop_at_a_phase_and_a_restart_forgets_it():
    player = started(frequency_hz=1.0)
    run(player, 2.0)
    player.stop_at_phase((player.phase + 0.9) % 1.0)
    player.stop()
    assert player.step(DT_S).state is PlaybackState.STOPPING and player.pending_stop_phase is None
    player.stop_at_phase(0.5)  # armed while ramping out: ramps out anyway, and a start from rest forgets it
    run(player, 2.0)
    player.start()
    trace = run(player, 3.0)
    assert all(s.state is not PlaybackState.STOPPING for s in trace)
    with pytest.raises(InvalidInputError, match="stop phase"):
        player.stop_at_phase(1.0)


@pytest.mark.parametrize("reverse", [False, True])
def test_a_start_from_idle_begins_at_the_phase_asked_and_at_0_by_default(reverse):
    player = started(frequency_hz=1.0, ramp_time_s=0.4)
    player.set_reverse(reverse)
    run(player, 1.5)
    player.stop()
    ended = run(player, 1.0)[-1]
    assert ended.state is PlaybackState.IDLE and 0.05 < ended.phase < 0.95
    player.start(phase=player.phase)  # where the ramp-out ended
    first = player.step(DT_S)
    step = DT_S * first.frequency_hz  # signed: negative played backward
    assert (step < 0.0) == reverse and first.phase == pytest.approx((ended.phase + step) % 1.0, abs=1e-9)
    assert first.cycles_done == pytest.approx(abs(step)) and np.max(first.positions_m) < 1e-4  # ramps in from 0
    player.stop()
    run(player, 1.0)
    player.start()
    assert player.step(DT_S).phase == pytest.approx(step % 1.0, abs=1e-9)
    player.stop()
    run(player, 1.0)
    with pytest.raises(InvalidInputError, match="phase"):
        player.start(phase=1.0)


@pytest.mark.parametrize("new_hz", [0.25, 2.5])
def test_live_frequency_change_is_phase_continuous(new_hz):
    player = started(frequency_hz=1.0)
    trace = run(player, 1.2)
    player.set_frequency_override(new_hz)
    trace += run(player, 1.5)
    assert trace[-1].frequency_hz == pytest.approx(new_hz)
    assert largest_step_m(trace) <= steady_step_bound_m(max(1.0, new_hz))
    player.set_frequency_override(0.0)  # back to the trajectory's own
    assert run(player, 1.0)[-1].frequency_hz == pytest.approx(1.0)


def test_live_amplitude_change_is_smooth():
    player = started()
    trace = run(player, 1.0)
    player.set_amplitude_scale(0.3)
    trace += run(player, 1.0)
    assert trace[-1].gain == pytest.approx(0.3)
    assert largest_step_m(trace) <= steady_step_bound_m(1.0)
    with pytest.raises(InvalidInputError, match=r"\[0, 1\]"):
        player.set_amplitude_scale(1.5)


@pytest.mark.parametrize("scale", [0.0, 0.2])
def test_a_scale_set_while_idle_or_still_ramping_at_the_stop_is_never_overshot_by_the_next_start(scale):
    """The scale's ramp and the ramp-in multiplied: set to 0 while idle, the next start gave a gain of 0.25 (1 bar of a
    4 bar gait) at 0.5 s; set to 0.2, 0.31 (a helper's review)."""
    player = GaitPlayback(ramp_time_s=1.0)
    player.load(rolling_cycle(), 1.0)
    player.set_amplitude_scale(scale)  # idle, as the node does at start-up with -p amplitude_scale:=...
    player.start()
    trace = run(player, 2.0)
    assert max(s.gain for s in trace) <= scale + 1e-12 and trace[-1].gain == pytest.approx(scale)
    assert np.max(positions(trace)) <= scale * MAX_M + 1e-12
    player.set_amplitude_scale(1.0)
    run(player, 1.0)
    player.stop()
    run(player, 0.5)
    player.set_amplitude_scale(scale)  # while ramping out: its 1 s ramp is half done when the playback goes idle
    run(player, 0.6)
    assert player.state is PlaybackState.IDLE
    player.start()
    assert max(s.gain for s in run(player, 2.0)) <= scale + 1e-12


def test_a_stop_just_after_a_raised_scale_only_lowers_the_gain():
    """A stop 0.3 s after amplitude_scale 0.2 -> 1: the falling start-stop envelope times the still rising scale went
    up by half (0.365 -> 0.574 of the gait, about 2.2 -> 3.4 bar) before it fell (a helper's review)."""
    player = started(ramp_time_s=1.0)
    player.set_amplitude_scale(0.2)
    run(player, 3.0)
    player.set_amplitude_scale(1.0)
    at_stop = run(player, 0.3)[-1].gain
    player.stop()
    gains = [at_stop] + [s.gain for s in run(player, 1.5)]
    assert np.all(np.diff(gains) <= 1e-12) and gains[-1] == 0.0 and player.state is PlaybackState.IDLE


@pytest.mark.parametrize("scale", [0.0, 0.5])
def test_a_start_during_a_stop_moves_the_gain_straight_to_the_scale_set_meanwhile(scale):
    """A restart during the ramp-out after amplitude_scale 0 rose to 0.21 of the gait: the ramp-in envelope times the
    scale's own ramp down from 1 (the idle-only fix did not cover a start while stopping; a helper's review)."""
    player = started(ramp_time_s=1.0)
    run(player, 2.0)
    player.stop()
    run(player, 0.9)
    player.set_amplitude_scale(scale)
    at_start = run(player, 0.05)[-1].gain
    assert player.state is PlaybackState.STOPPING
    player.start()
    gains = [at_start] + [s.gain for s in run(player, 2.0)]
    steps = np.diff(gains)
    assert np.all(steps <= 1e-12) if scale < at_start else np.all(steps >= -1e-12)  # straight there, no bump
    assert max(gains) <= max(at_start, scale) + 1e-12 and gains[-1] == pytest.approx(scale)


def test_new_cycle_takes_over_without_a_jump():
    player = started(blend_time_s=0.3)
    trace = run(player, 1.0)
    other = rolling_cycle(shift=0.5, amplitude_m=0.04)  # half a period off: a hard switch would jump ~4 cm
    hard_jump = np.max(np.abs(PeriodicTrajectory(other).values(player.phase) - trace[-1].positions_m))
    assert hard_jump > 0.03
    player.load(other, 1.5)
    trace += run(player, 1.0)
    assert largest_step_m(trace) <= steady_step_bound_m(1.5)
    assert np.allclose(trace[-1].positions_m, PeriodicTrajectory(other).values(trace[-1].phase))
    player.load(rolling_cycle(), 1.0)  # a takeover interrupted by another one
    trace += run(player, 0.1)
    player.load(other, 1.0)
    trace += run(player, 1.0)
    assert largest_step_m(trace) <= steady_step_bound_m(1.5)


def test_takeover_keeps_the_joint_count():
    player = started()
    with pytest.raises(InvalidInputError, match="joint count"):
        player.load(np.zeros((16, 3)), 1.0)


NAMES = [f"m{i}_pma{j}" for i in (1, 2, 3) for j in (1, 2, 3)]


def test_cycle_from_points_reads_a_closed_period_in_any_joint_order():
    samples = rolling_cycle(16)
    closed = np.vstack([samples, samples[:1]])
    times = np.arange(17) * (2.0 / 16)  # 0.5 Hz
    order = NAMES[::-1]
    read, frequency_hz = cycle_from_points(order, times, closed[:, ::-1], NAMES, MAX_M)
    assert frequency_hz == pytest.approx(0.5) and np.allclose(read, samples)
    open_read, open_hz = cycle_from_points(NAMES, times[:16], samples, NAMES, MAX_M)
    assert open_hz == pytest.approx(0.5) and np.allclose(open_read, samples)


@pytest.mark.parametrize(("names", "times", "scale", "match"), [
    (NAMES[:8] + ["tail"], None, 1.0, "missing"),
    (NAMES, np.r_[0.0, np.cumsum(np.r_[np.full(8, 0.1), 0.3, np.full(7, 0.1)])], 1.0, "equally spaced"),
    (NAMES, None, 3.0, "must lie in"),
])
def test_cycle_from_points_rejects_bad_messages(names, times, scale, match):
    samples = rolling_cycle(17) * scale
    times = np.arange(17) * 0.1 if times is None else times
    with pytest.raises(InvalidInputError, match=match):
        cycle_from_points(names, times, samples, NAMES, MAX_M)


def test_spline_undershoot_is_never_a_negative_length():
    # A cycle with a sharp corner at 0: its periodic spline dips below 0 next to the corner.
    phase = np.arange(16) / 16
    samples = np.maximum(np.sin(2 * np.pi * phase), 0.0)[:, None] * 0.03
    player = GaitPlayback(ramp_time_s=0.05)
    player.load(samples, frequency_hz=1.0)
    assert PeriodicTrajectory(samples).values(np.linspace(0, 1, 1000)).min() < 0  # the undershoot exists
    player.start()
    positions = np.array([player.step(0.001).positions_m for _ in range(2000)])
    assert positions.min() >= 0.0


GOOD_TIMES = np.arange(17) * 0.1
GOOD = rolling_cycle(17)
NAN_POINT = GOOD.copy()
NAN_POINT[3, 4] = np.nan


@pytest.mark.parametrize(("names", "times", "points", "match"), [
    (NAMES, GOOD_TIMES, [list(row) for row in GOOD[:5]] + [[0.01] * 8] + [list(row) for row in GOOD[6:]],
     "point 5 has 8 positions"),  # ragged
    (NAMES, GOOD_TIMES, NAN_POINT, "finite"),
    (NAMES, [], [], "expected 5 to"),  # empty
    (NAMES, [0.0], GOOD[:1], "expected 5 to"),  # one point
    (NAMES, np.r_[0.0, 0.2, 0.1, 0.3, 0.4, 0.5], GOOD[:6], "strictly increasing"),  # non-monotonic
    (NAMES, np.r_[0.0, 0.1, 0.1, 0.2, 0.3, 0.4], GOOD[:6], "strictly increasing"),  # duplicate times
    (NAMES[:8] + ["m4_pma1"], GOOD_TIMES, GOOD, "unknown"),
    (NAMES, GOOD_TIMES, GOOD - 0.001, "must lie in"),  # below 0
    (NAMES, GOOD_TIMES, GOOD + (MAX_M + 0.0009 - GOOD.max()), "must lie in"),  # 0.0659 m: no tolerance any more
    (NAMES, np.arange(3000) * 0.001, np.full((3000, 9), 0.01), "expected 5 to"),  # very large
    (NAMES, GOOD_TIMES * 1e-3, GOOD, "cycle frequency"),  # 588 Hz
    (NAMES, GOOD_TIMES * 1e9, GOOD, "cycle frequency"),  # a 51-year period
])
def test_malformed_trajectories_are_refused_with_the_reason(names, times, points, match):
    with pytest.raises(InvalidInputError, match=match):
        cycle_from_points(names, times, points, NAMES, MAX_M)


def test_setpoints_never_leave_the_stroke_even_where_the_spline_overshoots():
    # A square wave within [0, 0.065] m: its periodic cubic spline overshoots to about 0.072 m.
    samples = np.repeat(np.r_[np.zeros(8), np.full(8, MAX_M)], 1)[:, None] * np.ones((1, 9))
    assert PeriodicTrajectory(samples).values(np.linspace(0, 1, 2000)).max() > MAX_M + 0.005  # the overshoot
    player = GaitPlayback(ramp_time_s=0.05, max_length_m=MAX_M)
    player.load(samples, frequency_hz=1.0)
    player.start()
    positions = np.array([player.step(0.001).positions_m for _ in range(3000)])
    assert positions.max() <= MAX_M and positions.min() >= 0.0
    assert positions.max() == pytest.approx(MAX_M)  # and it does reach the top


def test_reverse_plays_the_cycle_backward_without_a_jump():
    player = GaitPlayback(ramp_time_s=0.5)
    player.load(rolling_cycle(), frequency_hz=1.0)
    player.start()
    forward = run(player, 2.0)
    player.set_reverse(True)
    turning = run(player, 0.5)
    backward = run(player, 1.0)
    assert player.reverse and backward[-1].frequency_hz == pytest.approx(-1.0)
    assert forward[-1].frequency_hz == pytest.approx(1.0)
    # the signed frequency passes smoothly through 0; no setpoint jumps on the way
    frequencies = [s.frequency_hz for s in forward + turning + backward]
    assert np.max(np.abs(np.diff(frequencies))) < 0.05
    positions = np.array([s.positions_m for s in forward + turning + backward])
    assert np.max(np.abs(np.diff(positions, axis=0))) < 0.003
    phases = np.array([s.phase for s in backward])
    assert np.all(((phases[1:] - phases[:-1]) % 1.0) > 0.5)        # the phase runs backward
    assert backward[-1].cycles_done > forward[-1].cycles_done        # cycles played keep counting up


def test_a_status_says_the_frequency_ramps_or_reverses_until_it_is_reached():
    """The status line's frequency (srs_bringup): a reversal ramps the signed frequency through 0, shown as such."""
    player = started(frequency_hz=1.0, ramp_time_s=0.4)
    run(player, 1.0)
    assert describe_frequency(player.frequency_hz, player.target_frequency_hz) == "1 Hz"
    player.set_reverse(True)
    run(player, 0.1)
    text = describe_frequency(player.frequency_hz, player.target_frequency_hz)
    assert player.frequency_hz > 0.0 and player.target_frequency_hz == -1.0
    assert re.fullmatch(r"0\.\d+ Hz, reversing \(then 1 Hz\)", text), text
    run(player, 0.5)
    assert describe_frequency(player.frequency_hz, player.target_frequency_hz) == "1 Hz"
    player.set_frequency_override(0.25)
    run(player, 0.1)
    assert re.fullmatch(r"0\.\d+ Hz, ramping to 0\.25 Hz", describe_frequency(
        player.frequency_hz, player.target_frequency_hz))
    assert describe_frequency(0.0, 1.0) == "0 Hz, ramping to 1 Hz"  # a start from rest is no reversal
