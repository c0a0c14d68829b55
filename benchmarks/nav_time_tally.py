"""Where the navigator's time goes: its recorded progress, summed by what the robot was doing.

Reads the ``goal_NN_progress.jsonl`` files that ``bench_navigation_ros.py --record DIR`` keeps (one
``navigation_progress`` message per line) and sums the time between consecutive messages by activity: cruise,
cruise stop (the stop a cycle ahead, the ramp-out and the wait to rest), rest and look, three-point turn, edge
guard, creep (the fine approach), turn on the spot and move along the body's axis. The activity is read from the
message text, which names it (srs_ros/core/navigation/*.py, ``self._message``); a message none of the patterns
matches is shown as "other: ..." so a renamed message is seen, not miscounted. Also shown: the part of each
activity spent within ``--near-m`` of the goal (the end game) and the straight-line time at the speed the run's
``run.json`` gives for its physics (recordings from stop 57 on; older ones: ``--speed-cm-s``, default 9.3, the
default physics'), to set the sum against issue 20's target (a median of at most twice the straight-line time).
Then, from stop 55's recordings on, what the navigator had learned of the robot's turning at the end of each goal
(the progress's ``turn_rates_deg_per_cycle``) and each direction's fastest turn either way: a turn the body has but
the navigator unlearned shows there (docs/studies/navigation.md, "Turn rates unlearned by the body's swing").

Run: python benchmarks/nav_time_tally.py DIR [DIR ...] [--near-m 0.35] [--speed-cm-s CM_S]
"""

from __future__ import annotations

import argparse
import json
import math
from collections import Counter
from pathlib import Path

from bench_navigation_ros import RUN_FILE  # the record folder's run file, named once

#: (activity, substrings of the message that name it), tried in order.
ACTIVITIES = (
    ("three-point turn", ("backing away",)),
    ("turn on the spot", ("turning on the spot",)),
    ("move along the axis", ("along the body's axis",)),
    ("creep", ("creep",)),
    ("edge guard", ("edge of the camera's view",)),
    ("cruise stop", ("stopping",)),
    ("rest and look", ("whether it is at rest",)),
    # "came to rest N m from the goal; driving on" stays the message while the cruise drives on
    ("cruise", ("driving to ", "driving at it", "waypoint reached", "came to rest")),
)
FINISHED = {"reached", "failed", "idle", "cancelled", "pose_lost"}
#: The default physics' straight-line speed (cm/s, bench_navigation.gait_speed_m_s), for recordings without run.json.
DEFAULT_SPEED_CM_S = 9.3


def activity(message: str) -> str:
    """The activity a progress message names."""
    for name, patterns in ACTIVITIES:
        if any(pattern in message for pattern in patterns):
            return name
    return f"other: {message[:50]}"


def progress_rows(path: Path) -> list[dict]:
    """The progress messages of one recorded goal (blank lines skipped)."""
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def tally(folder: Path, near_m: float) -> tuple[Counter, Counter, list[float]]:
    """Seconds by activity (all, and within ``near_m`` of the goal) and each goal's start distance (m)."""
    total, near, distances = Counter(), Counter(), []
    for path in sorted(folder.glob("goal_*_progress.jsonl")):
        rows = progress_rows(path)
        if rows and rows[0]["distance_to_go_m"] is not None:  # None (NaN in JSON): no pose yet
            distances.append(float(rows[0]["distance_to_go_m"]))
        for row, following in zip(rows, rows[1:]):
            if row["state"] in FINISHED:
                continue
            seconds, name = following["elapsed_s"] - row["elapsed_s"], activity(row["message"])
            total[name] += seconds
            if row["distance_to_go_m"] is not None and row["distance_to_go_m"] < near_m:
                near[name] += seconds
    return total, near, distances


def learned_turns(folder: Path) -> list[tuple[int, dict[str, list[float]]]]:
    """Per recorded goal (numbered from 1), the turn rates of its last progress message that carries them."""
    found = []
    for number, path in enumerate(sorted(folder.glob("goal_*_progress.jsonl")), start=1):
        rates = [row["turn_rates_deg_per_cycle"] for row in progress_rows(path) if row.get("turn_rates_deg_per_cycle")]
        if rates:
            found.append((number, rates[-1]))
    return found


def describe_rates(direction: str, rates: list) -> str:
    """One direction's rates (deg per cycle per turn level) and its fastest turn either way; unknown ones as '?'."""
    known = [float(r) for r in rates if r is not None and math.isfinite(r)]
    shown = " ".join("?" if r is None or not math.isfinite(r) else f"{r:+.1f}" for r in rates)
    fastest = f"{max(known):+.1f} / {min(known):+.1f}" if known else "none known"
    return f"{direction} {shown} (fastest {fastest})"


def print_learned_turns(folder: Path) -> None:
    """Print the turn rates learned at the end of each goal recorded in ``folder``."""
    found = learned_turns(folder)
    if not found:
        print("  (none recorded: the progress carries them since stop 55)")
    for number, rates in found:
        print(f"  learned after goal {number}: " + "; ".join(describe_rates(d, r) for d, r in rates.items()))


def straight_speed_cm_s(folder: Path, given_cm_s: float | None) -> tuple[float, str]:
    """The straight-line speed to set the time against, and where it came from: ``--speed-cm-s``, the run's
    ``run.json`` (bench_navigation_ros.py writes the speed of the physics it ran), else the default physics'."""
    if given_cm_s is not None:
        return given_cm_s, "--speed-cm-s"
    run_file = folder / RUN_FILE
    if run_file.is_file():
        return float(json.loads(run_file.read_text())["straight_speed_cm_s"]), RUN_FILE
    return DEFAULT_SPEED_CM_S, f"no {RUN_FILE}: the default physics' speed"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", nargs="+", type=Path, help="folders written by bench_navigation_ros.py --record")
    parser.add_argument("--near-m", type=float, default=0.35, help="the end game: within this of the goal (m)")
    parser.add_argument("--speed-cm-s", type=float, default=None,
                        help="the cruise gait's speed for the straight time (default: the run's run.json, else "
                             f"{DEFAULT_SPEED_CM_S:g}, the default physics')")
    args = parser.parse_args(argv)
    for folder in args.folders:
        total, near, distances = tally(folder, args.near_m)
        if not distances:
            print(f"{folder}: no goal_*_progress.jsonl here (record with bench_navigation_ros.py --record DIR)")
            continue
        speed_cm_s, source = straight_speed_cm_s(folder, args.speed_cm_s)
        seconds, straight_s = sum(total.values()), sum(distances) / (speed_cm_s / 100.0)
        print(f"{folder}: {len(distances)} goals, {seconds:.0f} s in all ({seconds / straight_s:.2f} x the "
              f"straight-line {straight_s:.0f} s at {speed_cm_s:g} cm/s, {source}); within {args.near_m:g} m of "
              f"the goal {sum(near.values()):.0f} s")
        for name, value in total.most_common():
            print(f"  {name:22s} {value:6.1f} s  {100.0 * value / max(seconds, math.ulp(1.0)):5.1f} %   "
                  f"within {args.near_m:g} m: {near[name]:6.1f} s")
        print("  turn rates learned, deg per cycle at each turn level (fastest counter-clockwise / clockwise):")
        print_learned_turns(folder)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
