"""A command plan run to the end although the host paused: disturbed parts found, set aside and run again (no ROS).

A rig's hardware vents by itself when its commands stop for its own timeout (sim_world's board 0.5 s, a CAN
board 0.1 s, an NI watchdog). A busy machine pauses a Python process for 0.2-0.4 s now and then, and after a pause
:func:`~srs_ros.core.actuation.identification.run_plan` sends the overdue commands at once: a step paused in
its hold may have been vented in the middle, and one whose start was overdue is held for less than planned.
Its settled length and its response are then not the step's, and a fit on them is wrong without a word. The
rig's side can pause too: a read-back that gives no new value while a step settles (sim_world's executor
starved on a busy machine; a board or node silent for a moment) leaves that step out of the static fit, and with
two such steps the fit has too few levels.

:func:`run_plan_through_pauses` runs the plan, and every *segment* of it (a block of non-zero commands and the
vent after it) in which a command went out later than that gap, or a step's settled window got no new read-back,
is set aside: its samples leave the
recording, its steps leave the plan, and the segments set aside are run again after the plan (after the
plan's opening vent), up to ``retries`` times. It returns the recording and the plan as they now belong
together; the caller fits on those.

Example::

    recording, plan = run_plan_through_pauses(io, plan, max_late_s=0.8 * backend.silence_vent_s, on_retry=print)
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from srs_ros.core.actuation.identification import CommandPlan, Recording, RigIO, Step, run_plan
from srs_ros.core.errors import HardwareError

#: How many times the segments a pause disturbed are run again before the run gives up.
DEFAULT_RETRIES = 3
#: Time between two runs joined into one recording (s): a vented line comes to rest within it (5 lags of 0.2 s).
JOIN_GAP_S = 1.0


def plan_segments(plan: CommandPlan) -> list[tuple[int, int]]:
    """Row ranges ``[first, end)`` of ``plan``: each block of non-zero commands and the vent that follows it."""
    active = np.any(plan.pressure_bar > 0.0, axis=1)
    starts = np.flatnonzero(active & ~np.concatenate([[False], active[:-1]]))
    ends = [*starts[1:], len(active)]
    return [(int(a), int(b)) for a, b in zip(starts, ends)]


def disturbed_segments(recording: Recording, plan: CommandPlan, max_late_s: float) -> tuple[list[int], float]:
    """Indexes of the segments with a command sent more than ``max_late_s`` late next to a non-zero one; worst (s).

    A late command after a non-zero one means the held pressure went unrefreshed (the rig may have vented);
    a late non-zero command means its step started or went on late, its hold shortened by the catch-up. A
    segment whose vent began late also takes the next one: its vent was cut short, so the next step starts
    from a pressure the fit's model of the commands does not know.
    """
    late_s = recording.command_s - plan.times_s
    active = np.any(plan.pressure_bar > 0.0, axis=1)
    beside = active | np.concatenate([[False], active[:-1]])
    rows = np.flatnonzero((late_s > max_late_s) & beside)
    if rows.size == 0:
        return [], 0.0
    segments = plan_segments(plan)
    firsts = np.array([first for first, _ in segments])
    touched = {int(np.searchsorted(firsts, row, side="right")) - 1 for row in rows} - {-1}
    for index in sorted(touched):
        first, end = segments[index]
        vent = first + int(np.argmin(active[first:end])) if not np.all(active[first:end]) else end
        if index + 1 < len(segments) and vent < end and late_s[vent] > max_late_s:
            touched.add(index + 1)
    return sorted(touched), float(late_s[rows].max())


def unmeasured_segments(recording: Recording, plan: CommandPlan) -> list[int]:
    """Indexes of the segments with a step whose settled window holds no new read-back (none when nothing is read).

    The recording keeps one sample per read-back (:func:`~srs_ros.core.actuation.identification.run_plan` drops a
    read-back seen again), so a read-back silent over a whole settled window leaves no sample in it.
    """
    values = recording.length_m if recording.length_m is not None else recording.pressure_bar
    if values is None:
        return []
    fresh_s = recording.sample_s[np.any(np.isfinite(values), axis=1)]
    return [index for index, (first, end) in enumerate(plan_segments(plan))
            if any(not np.any((fresh_s >= step.settled_s) & (fresh_s < step.end_s))
                   for step in _steps_within(plan, first, end))]


def _to_run_again(recording: Recording, plan: CommandPlan, max_late_s: float) -> tuple[list[int], str]:
    """The segments to run again (late commands or a silent read-back) and why, in words."""
    late, worst_s = disturbed_segments(recording, plan, max_late_s)
    silent = [index for index in unmeasured_segments(recording, plan) if index not in late]
    reasons = []
    if late:
        reasons.append(f"this process paused and sent a command {worst_s:.2f} s late (allowed: {max_late_s:g} s, "
                       "within the rig's own vent timeout)")
    if silent:
        reasons.append(f"the rig's read-back gave no new value while {len(silent)} part(s) settled (its node or "
                       "board fell silent for a moment)")
    return sorted(late + silent), "; ".join(reasons)


def _steps_within(plan: CommandPlan, first: int, end: int) -> list[Step]:
    start_s = plan.times_s[first]
    end_s = plan.times_s[end] if end < len(plan.times_s) else plan.times_s[-1] + 1e-9
    return [s for s in plan.steps if start_s - 1e-9 <= s.start_s < end_s - 1e-9]  # times are sums: a little off


def plan_of_segments(plan: CommandPlan, indexes: list[int]) -> CommandPlan:
    """The plan's opening vent followed by its segments ``indexes``, at its command rate, with their steps."""
    segments = plan_segments(plan)
    period_s = float(plan.times_s[1] - plan.times_s[0])
    rows = [np.arange(segments[0][0])]
    steps: list[Step] = []
    for index in indexes:
        first, end = segments[index]
        shift_s = len(np.concatenate(rows)) * period_s - plan.times_s[first]
        steps += [Step(s.joints, s.level_bar, s.start_s + shift_s, s.settled_s + shift_s, s.end_s + shift_s)
                  for s in _steps_within(plan, first, end)]
        rows.append(np.arange(first, end))
    taken = np.concatenate(rows)
    return CommandPlan(np.arange(len(taken)) * period_s, plan.pressure_bar[taken], tuple(steps),
                       f"{plan.description} (again: {len(indexes)} part(s) a pause disturbed)")


def set_aside(recording: Recording, plan: CommandPlan, indexes: list[int]) -> tuple[Recording, CommandPlan]:
    """``recording`` without the samples of segments ``indexes``, and ``plan`` without their steps."""
    keep = np.ones(len(recording.sample_s), dtype=bool)
    dropped: list[Step] = []
    for index in indexes:
        first, end = plan_segments(plan)[index]
        until_s = recording.command_s[end] if end < len(recording.command_s) else np.inf
        keep &= ~((recording.sample_s >= recording.command_s[first]) & (recording.sample_s < until_s))
        dropped += _steps_within(plan, first, end)
    kept = Recording(recording.command_s, recording.command_bar, recording.sample_s[keep],
                     None if recording.pressure_bar is None else recording.pressure_bar[keep],
                     None if recording.length_m is None else recording.length_m[keep])
    return kept, CommandPlan(plan.times_s, plan.pressure_bar, tuple(s for s in plan.steps if s not in dropped),
                             plan.description)


def joined(first: tuple[Recording, CommandPlan], then: tuple[Recording, CommandPlan]) -> tuple[Recording, CommandPlan]:
    """Two runs as one: the second starts :data:`JOIN_GAP_S` after the first's last command or sample.

    The first run may have ended late (a pause near its end): times stay in order, and over the gap the
    fit's model of the commands comes to rest at the last (vented) command, as the rig did between the runs.
    """
    (a, plan_a), (b, plan_b) = first, then
    ends = [plan_a.duration_s, *a.command_s[-1:], *a.sample_s[-1:]]
    shift_s = float(max(ends)) + JOIN_GAP_S - float(plan_b.times_s[0])
    plan = CommandPlan(np.concatenate([plan_a.times_s, plan_b.times_s + shift_s]),
                       np.concatenate([plan_a.pressure_bar, plan_b.pressure_bar]),
                       plan_a.steps + tuple(Step(s.joints, s.level_bar, s.start_s + shift_s, s.settled_s + shift_s,
                                                 s.end_s + shift_s) for s in plan_b.steps),
                       plan_a.description)

    def stacked(x, y):
        return None if x is None or y is None else np.concatenate([x, y])

    recording = Recording(np.concatenate([a.command_s, b.command_s + shift_s]),
                          np.concatenate([a.command_bar, b.command_bar]),
                          np.concatenate([a.sample_s, b.sample_s + shift_s]),
                          stacked(a.pressure_bar, b.pressure_bar), stacked(a.length_m, b.length_m))
    return recording, plan


def run_plan_through_pauses(io: RigIO, plan: CommandPlan, max_late_s: float, retries: int = DEFAULT_RETRIES,
                            on_step: Callable[[int, Step], None] | None = None,
                            on_retry: Callable[[str], None] | None = None,
                            on_progress: Callable[[float], None] | None = None) -> tuple[Recording, CommandPlan]:
    """Run ``plan``, and again every part a pause (of the host or the read-back) disturbed; the recording and plan.

    Raises :class:`HardwareError` when parts are still disturbed after ``retries`` runs again.
    """
    recording = run_plan(io, plan, on_step, on_progress)
    todo, why = _to_run_again(recording, plan, max_late_s)
    result = set_aside(recording, plan, todo)
    for attempt in range(1, retries + 2):
        if not todo:
            return result
        if attempt > retries:
            break
        if on_retry is not None:
            on_retry(f"{len(todo)} part(s) of the plan disturbed: {why}; running them again ({attempt} of {retries})")
        again = plan_of_segments(plan, todo)
        recording = run_plan(io, again, on_step, on_progress)
        plan = again
        todo, why = _to_run_again(recording, plan, max_late_s)
        result = joined(result, set_aside(recording, plan, todo))
    raise HardwareError(f"the run was still disturbed after {retries} repeats: {why}. The machine is too busy to "
                        "measure the muscles, or the rig's read-back too slow for the steps' settled windows: stop "
                        "other programs and run it again, or hold the steps longer (--hold-s).")
