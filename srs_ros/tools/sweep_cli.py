"""``srs_sweep``: the paper's experiments in one command, to Table I, on the simulated robot or a real rig.

``srs_sweep [--gait G ...] [--amplitudes 1 2 3 4] [--frequencies 0.25 0.5 0.75 1] [--duration-s 15] --out DIR``
runs every cell offline on the simulated robot (faster than real time, one process per core, progress
on stderr), writes ``DIR/table.csv`` (with the paper's Table I values beside each cell), ``DIR/table.png``
and ``DIR/paths_<gait>.png``, and prints the table in the paper's layout. Without ``--gait`` it runs the
paper's three gaits (48 runs). ``--scheduler tcp://HOST:8786`` runs them on the workers of a running Dask
cluster instead of the local processes, with the same results (docs/cluster.md).

``--ros``: the same sweep against running nodes (any rig; start them first, e.g. ``srs_bringup``), each
run recorded as a rosbag2 directory in ``DIR/bags/``. On a rig with real regulators every run waits for
the operator's go (a prompt, or ``--yes``) before the hardware is armed; a run aborts on an e-stop or a
hardware error; ``--on-failure stop`` ends the sweep at the first failed run; Ctrl-C vents and keeps
what was recorded.

``--calibrate TABLE``: fit the simulation's uncertain parameters to a measured table
(``config/paper_table1.yaml`` or a lab's own in that format), print each cell's error before and after,
and write ``DIR/sim.yaml`` and each evaluation of the search, ``DIR/evaluations.csv`` (on the local pool, or
on a Dask cluster with ``--scheduler``).

Exit status: 0 done, 1 done with failed runs, 2 bad input or a rig that cannot be driven (nothing
written), 130 interrupted (a sweep writes what was done; ``--calibrate`` its evaluations so far,
``evaluations.csv``, and no ``sim.yaml``).
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from tqdm import tqdm

from srs_ros.core.errors import ConfigurationError, SrsError
from srs_ros.core.files import write_atomically
from srs_ros.core.gait.request import MAX_RUN_S
from srs_ros.experiments.calibration import (
    DEFAULT_FIT_BEYOND_FRICTION,
    DEFAULT_MAX_EVALUATIONS,
    FIT_PARAMETERS,
    Evaluation,
    calibrate,
    fit_parameters,
    format_cell_errors,
    model_limits,
    target_report,
    write_sim_yaml,
)
from srs_ros.experiments.cluster import add_runner_arguments, runner_from_args
from srs_ros.experiments.plots import plot_paths, plot_table
from srs_ros.experiments.sweep import OfflineRunner, SweepGrid
from srs_ros.experiments.table import (
    FAILED,
    ROS_SETTLE_S,
    SKIPPED,
    MeasuredTable,
    RunRecord,
    format_table,
    load_measured_table,
    paper_table,
    write_table_csv,
)
from srs_ros.sim.config import SimConfig, load_sim_config, with_friction
from srs_ros.tools.output import prepare_output

PROG = "srs_sweep"
#: Run time of the calibration's search runs by default (s): long enough for several cycles at 0.25 Hz.
DEFAULT_FIT_DURATION_S = 8.0
EXIT_OK, EXIT_FAILED_RUNS, EXIT_BAD_INPUT, EXIT_INTERRUPTED = 0, 1, 2, 130


def _number(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
    return value


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog=PROG, description=__doc__.splitlines()[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog="\n".join(__doc__.splitlines()[2:]))
    paper = SweepGrid.of_table(paper_table())  # the defaults: the grid of the paper's Table I
    grid = parser.add_argument_group("the grid (default: the paper's, config/paper_table1.yaml)")
    grid.add_argument("--gait", action="append", dest="gaits", metavar="GAIT",
                      help=f"a gait to run (repeat for several; default the paper's {', '.join(paper.gaits)})")
    grid.add_argument("--amplitudes", nargs="*", type=_number, default=list(paper.amplitudes_bar), metavar="BAR",
                      help=f"pressure amplitudes, bar (default {' '.join(f'{a:g}' for a in paper.amplitudes_bar)})")
    grid.add_argument("--frequencies", nargs="*", type=_number, default=list(paper.frequencies_hz), metavar="HZ",
                      help=f"cycle frequencies, Hz (default {' '.join(f'{f:g}' for f in paper.frequencies_hz)})")
    grid.add_argument("--duration-s", type=_number, default=paper.duration_s,
                      help=f"run time, s (default {paper.duration_s:g})")
    parser.add_argument("--out", required=True, help="output folder (created if missing)")
    parser.add_argument("--reference", help="measured table shown beside the runs (default the paper's Table I, "
                                            "config/paper_table1.yaml)")
    sim = parser.add_argument_group("offline (the simulated robot)")
    sim.add_argument("--sim-config", help="simulation YAML (default config/sim.yaml)")
    sim.add_argument("--friction", help="floor friction: isotropic | anisotropic | MU | ALONG,ACROSS (as srs_sim)")
    add_runner_arguments(sim)
    sim.add_argument("--no-progress", action="store_true", help="no progress bar")
    ros = parser.add_argument_group("--ros (running nodes on any rig)")
    ros.add_argument("--ros", action="store_true", help="drive running nodes instead of the offline simulation")
    ros.add_argument("--yes", action="store_true", help="the operator's go for every run on a rig with real "
                                                        "regulators (default: ask before each run)")
    ros.add_argument("--on-failure", choices=("continue", "stop"), default="continue",
                     help="after a failed run: go on with the next (default) or stop the sweep")
    ros.add_argument("--settle-s", type=_number, default=ROS_SETTLE_S,
                     help=f"wait after the vent before the end pose, s (default {ROS_SETTLE_S:g})")
    ros.add_argument("--namespace", default="", help="namespace of the rig's nodes (e.g. snake1)")
    ros.add_argument("--no-sim-reset", action="store_true",
                     help="on the simulated rig, do not put the robot back at its start before each run")
    cal = parser.add_argument_group("--calibrate (fit the simulation to a measured table)")
    cal.add_argument("--calibrate", metavar="TABLE", help="measured table to fit (e.g. config/paper_table1.yaml)")
    cal.add_argument("--fit", nargs="+", metavar="PARAM",
                     help=f"parameters to fit (default: the floor's friction, friction_coefficient or on an "
                          f"anisotropic floor friction_along_body and friction_across_body, then "
                          f"{', '.join(DEFAULT_FIT_BEYOND_FRICTION)}); any of {', '.join(FIT_PARAMETERS)}")
    cal.add_argument("--fit-duration-s", type=_number, default=DEFAULT_FIT_DURATION_S,
                     help=f"run time of the search's runs, s (default {DEFAULT_FIT_DURATION_S:g}; before and "
                          "after use the table's)")
    cal.add_argument("--max-evaluations", type=int, default=DEFAULT_MAX_EVALUATIONS,
                     help=f"largest number of cost evaluations (default {DEFAULT_MAX_EVALUATIONS})")
    return parser


#: What a sweep or a calibration writes in its --out folder: any found there is an earlier run's.
OUTPUT_NAMES = ("table.csv", "table.png", "bags", "sim.yaml", "table_before.csv", "table_after.csv",
                "calibration.txt")


def _fresh_output(path: str) -> Path:
    """The --out folder, writable and without an earlier sweep's results.

    A second sweep into it mixed its table with the first one's plots, and a --ros sweep refused a bag folder only
    after the runs before it had run (a helper's review).
    """
    out = prepare_output(path)
    earlier = sorted(name for name in OUTPUT_NAMES if (out / name).exists())
    earlier += sorted(p.name for p in out.glob("paths_*.png"))
    if earlier:
        raise ConfigurationError(f"--out {path} holds an earlier run's results ({', '.join(earlier)}); use a new "
                                 "folder, or remove them first.")
    return out


def _sim_config(args: argparse.Namespace) -> SimConfig:
    config = load_sim_config(args.sim_config)
    return with_friction(config, args.friction) if args.friction else config


def _progress(total: int, args: argparse.Namespace, desc: str) -> tqdm:
    return tqdm(total=total, desc=desc, unit="run", file=sys.stderr, disable=args.no_progress, dynamic_ncols=True)


def _write_outputs(out: Path, records: Sequence[RunRecord], reference: MeasuredTable, label: str) -> list[Path]:
    written = [write_table_csv(out / "table.csv", records, reference),
               plot_table(out / "table.png", records, reference, label)]
    for gait in dict.fromkeys(r.gait for r in records):
        written.append(plot_paths(out / f"paths_{gait}.png", records, gait))
    return written


def _finish(records: Sequence[RunRecord], reference: MeasuredTable, out: Path, label: str, wall_s: float,
            how: str) -> int:
    written = _write_outputs(out, records, reference, label)
    print(format_table(records, reference, label="sim" if label == "simulated" else label))
    failed = sum(r.outcome == FAILED for r in records)
    skipped = sum(r.outcome == SKIPPED for r in records)
    print(f"\n{len(records)} runs ({how}) in {wall_s:.1f} s wall time; {failed} failed"
          + (f", {skipped} skipped by the operator" if skipped else ""))
    print("written: " + ", ".join(str(p) for p in written))
    return EXIT_FAILED_RUNS if failed else EXIT_OK


def _runner(args: argparse.Namespace) -> OfflineRunner:
    """The local pool, or the Dask cluster of ``--scheduler`` (a ClusterError, exit 2, if it cannot be used)."""
    return runner_from_args(args, log=lambda text: tqdm.write(f"{PROG}: {text}", file=sys.stderr))


def _offline(args: argparse.Namespace, grid: SweepGrid, reference: MeasuredTable, out: Path,
             runner: OfflineRunner) -> int:
    config = _sim_config(args)
    started, done = time.perf_counter(), []
    how = f"simulated offline, {grid.duration_s:g} s each, {runner.describe()}, {config.contact.describe()}"

    def finished(record: RunRecord) -> None:
        done.append(record)
        bar.update()

    with _progress(len(grid), args, "simulated runs") as bar:
        try:
            records = runner.run(grid.cells(), grid.duration_s, config, on_result=finished)
        except KeyboardInterrupt:  # what was done is written, in the grid's order
            order = {cell: index for index, cell in enumerate(grid.cells())}
            done.sort(key=lambda r: order[r.cell])
            if done:
                _finish(done, reference, out, "simulated", time.perf_counter() - started, how + ", interrupted")
            raise
    return _finish(records, reference, out, "simulated", time.perf_counter() - started, how)


def _calibrate(args: argparse.Namespace, out: Path, runner: OfflineRunner) -> int:
    reference = load_measured_table(args.calibrate)
    config = _sim_config(args)
    bar: tqdm | None = None
    evaluations: list[Evaluation] = []

    def stage(text: str) -> None:
        nonlocal bar
        if bar is not None:
            bar.close()
            bar = None
        print(f"{PROG}: {text}", file=sys.stderr, flush=True)
        if text.startswith(("before", "after")):
            bar = _progress(len(reference.cells), args, text.split(":")[0])

    def evaluation(e: Evaluation) -> None:
        evaluations.append(e)
        values = ", ".join(f"{k} {v:g}" for k, v in e.values.items())
        print(f"  evaluation {e.index}/{args.max_evaluations}: error {e.error:.4f}  ({values}; {e.wall_time_s:.1f} s)",
              file=sys.stderr, flush=True)

    try:
        result = calibrate(reference, config, args.fit, args.fit_duration_s, args.max_evaluations, runner=runner,
                           on_evaluation=evaluation, on_stage=stage, on_result=lambda _r: bar and bar.update())
    except KeyboardInterrupt:  # the search so far is kept: hours of a cluster's work
        if evaluations:
            best = min(evaluations, key=lambda e: e.error)
            path = _write_evaluations(out / "evaluations.csv", evaluations)
            print(f"{PROG}: interrupted after {len(evaluations)} evaluations; the best so far, error {best.error:.4f} "
                  f"at {best.values}, was not checked by full-length runs: no sim.yaml; written: {path}",
                  file=sys.stderr)
        raise
    finally:
        if bar is not None:
            bar.close()
    report = _calibration_report(result, reference, config, runner)
    sim_yaml = write_sim_yaml(out / "sim.yaml", result, reference)
    written = [sim_yaml, write_table_csv(out / "table_before.csv", result.before, reference),
               write_table_csv(out / "table_after.csv", result.after, reference),
               _write_evaluations(out / "evaluations.csv", result.history),
               write_atomically(out / "calibration.txt", report + "\n")]
    print(report)
    print("\nwritten: " + ", ".join(str(p) for p in written))
    failed = sum(not r.ok for r in (*result.before, *result.after))
    return EXIT_FAILED_RUNS if failed else EXIT_OK  # every run failed: exit 1, as the sweep (it said 0)


def _calibration_report(result, reference: MeasuredTable, config: SimConfig, runner: OfflineRunner) -> str:
    """calibration.txt: each cell's error before and after, the fitted values, the goals, the model's limits."""
    lines = [f"Calibration of {config.source} to {reference.name} ({len(reference.cells)} cells, "
             f"{reference.duration_s:g} s runs)", "", format_cell_errors(reference, result.before, result.after), ""]
    lines.append(f"RMS log speed error: {result.error_before:.4f} before, {result.error_after:.4f} after "
                 f"({len(result.history)} evaluations of {len(result.fit_cells)} cells x {result.fit_duration_s:g} s; "
                 f"{result.wall_time_s:.0f} s wall time on {runner.describe()})")
    fitted = ", ".join(f"{k} {result.initial_values[k]:g} -> {v:g}" for k, v in result.fitted_values.items())
    lines.append(f"fitted: {fitted}" if result.accepted else
                 f"the best fit ({result.history and min(result.history, key=lambda e: e.error).values}) did not "
                 "lower the error of full-length runs: the starting values are kept")
    for name, records in (("before", result.before), ("after", result.after)):
        lines.append(f"\ngoals ({name}):")
        checks = target_report(records, reference)
        lines += [f"  [{'met' if c.met else 'NOT met'}] {c.goal}: {c.detail}" for c in checks]
    limits = model_limits(result.after, reference, result.config)
    if limits:
        lines.append("\nwhere the model cannot follow the measurements (a body rolling without slip covers "
                     "2 pi r per cycle at any frequency):")
        lines += [f"  {note}" for note in limits]
    return "\n".join(lines)


def _write_evaluations(path: Path, evaluations: Sequence[Evaluation]) -> Path:
    """``evaluations.csv``: the search's evaluations in order, their parameter values, RMS log error and time."""
    names = list(evaluations[0].values) if evaluations else []
    rows = [",".join(["index", *names, "error", "wall_time_s"])]
    rows += [",".join([str(e.index), *(f"{e.values[n]:.6g}" for n in names), f"{e.error:.6g}", f"{e.wall_time_s:.3f}"])
             for e in evaluations]
    return write_atomically(path, "\n".join(rows) + "\n")


def _ros(args: argparse.Namespace, grid: SweepGrid, reference: MeasuredTable, out: Path) -> int:
    """``--ros``: the grid against running nodes, a bag per run in ``out/bags``; then the table as offline."""
    from srs_ros.experiments.ros_sweep import RosSweep, RosSweepOptions

    options = RosSweepOptions(settle_s=args.settle_s, namespace=args.namespace, reset_sim=not args.no_sim_reset)
    sweep = RosSweep(options, log=lambda text: tqdm.write(text, file=sys.stderr))
    sweep.install_interrupt_handler()
    started = time.perf_counter()
    try:
        _discover_rig(sweep, args)
        bags = out / "bags"
        bags.mkdir(exist_ok=True)
        with _progress(len(grid), args, "runs") as bar:
            records, code = _run_cells(sweep, grid, bags, args, bar)
    finally:
        sweep.close()
    if not records:
        print(f"{PROG}: no run was made; nothing written", file=sys.stderr)
        return code or EXIT_FAILED_RUNS
    how = f"over ROS, {grid.duration_s:g} s each, rig {sweep.rig.rig if sweep.rig else '?'}, bags in {bags}"
    result = _finish(records, reference, out, "tracked", time.perf_counter() - started, how)
    if len(records) < len(grid):
        print(f"{len(grid) - len(records)} runs of the grid were not made")
    return code or result


def _discover_rig(sweep, args: argparse.Namespace) -> None:
    """Find the running rig (a ConfigurationError if it does not answer) and say what each run will need."""
    from srs_ros.experiments.ros_sweep import SweepStopped

    try:
        rig = sweep.discover()
    except SweepStopped as exc:
        raise ConfigurationError(str(exc)) from None
    go = "each run needs the operator's go" + (" (--yes given)" if args.yes else "")
    if rig.state != "active":
        what = f"hardware_node is {rig.state}, its rig not known yet: {go} (checked again before each run)"
    else:
        what = f"real regulators: {go}" if rig.requires_arm else "no arm needed"
    print(f"{PROG}: rig {rig.rig!r}: {what}" + ("; simulated world" if rig.simulated else ""), file=sys.stderr,
          flush=True)


def _run_cells(sweep, grid: SweepGrid, bags: Path, args: argparse.Namespace,
               bar: tqdm) -> tuple[list[RunRecord], int]:
    """Each cell in turn, a bag each, until done, stopped or interrupted: the records and the exit code so far."""
    from srs_ros.experiments.ros_sweep import SweepStopped

    go = _operator_go(args, grid, bar)
    records: list[RunRecord] = []
    for index, cell in enumerate(grid.cells(), start=1):
        bag = bags / f"{index:02d}_{cell[0]}_{cell[1]:g}bar_{cell[2]:g}hz"
        if bag.exists():
            raise ConfigurationError(f"{bag} exists already; use a new --out folder.")
        try:
            record = sweep.run(cell, grid.duration_s, bag, go)
        except SweepStopped as exc:
            records.append(RunRecord.failed(cell, str(exc)))
            tqdm.write(f"{PROG}: stopped: {exc}", file=sys.stderr)
            break
        except KeyboardInterrupt:
            kept = "its bag keeps what was recorded" if bag.exists() else "before its bag was opened: no bag"
            records.append(RunRecord.failed(cell, f"interrupted (Ctrl-C); {kept}"))
            return records, EXIT_INTERRUPTED
        records.append(record)
        bar.update()
        text = f"{record.speed_cm_s:.2f} cm/s" if record.ok else record.status
        tqdm.write(f"{PROG}: {cell[0]} {cell[1]:g} bar {cell[2]:g} Hz: {text}", file=sys.stderr)
        if record.outcome == FAILED and args.on_failure == "stop":  # an operator's "no" is not a failure
            tqdm.write(f"{PROG}: stopping at the first failed run (--on-failure stop)", file=sys.stderr)
            break
    return records, EXIT_OK


def _operator_go(args: argparse.Namespace, grid: SweepGrid, bar: tqdm):
    """Whether a cell may run on a real rig: always with ``--yes``, else the operator's answer (``q`` stops)."""
    from srs_ros.experiments.ros_sweep import SweepStopped

    def go(cell) -> bool:
        if args.yes:
            return True
        bar.clear()
        handler = signal.signal(signal.SIGINT, signal.default_int_handler)  # Ctrl-C at the prompt: quit
        try:
            answer = input(f"{PROG}: run {cell[0]} {cell[1]:g} bar {cell[2]:g} Hz for {grid.duration_s:g} s "
                           "on the real rig? Place the robot, then [y]es / [n]o, skip / [q]uit: ")
        except (EOFError, KeyboardInterrupt):
            answer = "q"
        finally:
            signal.signal(signal.SIGINT, handler)
        bar.refresh()
        if answer.strip().lower() in ("q", "quit"):
            raise SweepStopped("the operator stopped the sweep")
        return answer.strip().lower() in ("y", "yes")

    return go


#: The options each mode does not read (by dest): given, they were ignored without a word (a helper's review).
_ROS_ONLY = ("yes", "on_failure", "settle_s", "namespace", "no_sim_reset")
_CALIBRATE_ONLY = ("fit", "fit_duration_s", "max_evaluations")
UNUSED_OPTIONS = {"calibrate": ("gaits", "amplitudes", "frequencies", "duration_s", "reference", *_ROS_ONLY),
                  "ros": ("sim_config", "friction", "workers", *_CALIBRATE_ONLY),
                  "offline": (*_ROS_ONLY, *_CALIBRATE_ONLY)}


def _refuse_unused(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Exit 2 naming an option that the chosen mode would ignore, and a --ros settle time that cannot be."""
    names = {"calibrate": "--calibrate", "ros": "--ros", "offline": "the offline sweep"}
    mode = "calibrate" if args.calibrate else "ros" if args.ros else "offline"
    for dest in UNUSED_OPTIONS[mode]:
        if getattr(args, dest) != parser.get_default(dest):
            flag = "--gait" if dest == "gaits" else "--" + dest.replace("_", "-")
            readers = " and ".join(names[m] for m, unused in UNUSED_OPTIONS.items() if dest not in unused)
            parser.error(f"{flag}: {names[mode]} does not read it (only {readers}); leave it out")
    if args.ros and not (math.isfinite(args.settle_s) and args.settle_s >= 0.0):
        parser.error(f"--settle-s {args.settle_s:g}: expected seconds >= 0")


def main(argv: list[str] | None = None) -> int:
    """Console script ``srs_sweep``; see the module docstring for the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.ros and args.calibrate:
        parser.error("--ros and --calibrate: choose one (calibration runs the offline simulation)")
    if args.ros and args.scheduler:
        parser.error("--ros and --scheduler: choose one (a rig runs one run at a time; --scheduler runs the offline "
                     "simulation on a Dask cluster)")
    if args.workers is not None and args.workers < 1:
        parser.error(f"--workers {args.workers}: expected 1 or more")
    _refuse_unused(parser, args)
    try:
        if args.calibrate:
            if not os.path.isfile(args.calibrate):
                raise ConfigurationError(f"--calibrate {args.calibrate}: no such file (a measured table such as "
                                         "config/paper_table1.yaml).")
            load_measured_table(args.calibrate)  # a malformed table: exit 2 before the output folder is made
            _sim_config(args)
            if args.fit:
                fit_parameters(args.fit)  # bad names too
            if args.max_evaluations < 1:
                raise ConfigurationError(f"--max-evaluations {args.max_evaluations}: expected 1 or more.")
            if not 0.0 < args.fit_duration_s <= MAX_RUN_S:  # 0 was taken as "the table's run time"
                raise ConfigurationError(f"--fit-duration-s {args.fit_duration_s:g}: expected seconds in (0, "
                                         f"{MAX_RUN_S:g}] (leave it out for {DEFAULT_FIT_DURATION_S:g} s).")
            with _runner(args) as runner:  # an unreachable cluster: exit 2 before the output folder is made
                return _calibrate(args, _fresh_output(args.out), runner)
        gaits = args.gaits or paper_table().gaits
        grid = SweepGrid.create(gaits, args.amplitudes, args.frequencies, args.duration_s)
        reference = load_measured_table(args.reference)
        if args.ros:
            return _ros(args, grid, reference, _fresh_output(args.out))
        _sim_config(args)
        with _runner(args) as runner:
            return _offline(args, grid, reference, _fresh_output(args.out), runner)
    except SrsError as exc:
        print(f"{PROG}: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
