"""Offline runs on Dask: a real ``distributed.LocalCluster`` of worker processes gives the local records exactly.

Every run is counted as it finishes anywhere, a worker killed mid-sweep (SIGKILL) has its runs run again
(by Dask's scheduler, or by the runner when Dask gives up on them), the local pool survives a killed
process the same way, a worker with other code is refused, and every way of not reaching a cluster is a
clear error. ``srs_sweep --scheduler`` and ``--calibrate --scheduler`` write what the local pool writes.
"""

import contextlib
import multiprocessing
import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

import dask
import numpy as np
import pytest
import yaml
from distributed import Client, LocalCluster

from srs_ros.core.errors import ClusterError, InvalidInputError
from srs_ros.experiments import sweep
from srs_ros.experiments.cluster import DaskRunner, runner_for
from srs_ros.experiments.sweep import MAX_RESUBMITS, OfflineRunner, code_fingerprint
from srs_ros.sim.config import load_sim_config
from srs_ros.tools.sweep_cli import main

ROOT = Path(__file__).resolve().parents[2]
CELLS = [("inward_rolling", 4.0, 1.0), ("outward_rolling", 3.0, 0.5), ("serpentine", 2.0, 0.5),
         ("inward_rolling", 2.0, 0.25), ("outward_rolling", 4.0, 1.0), ("serpentine", 4.0, 1.0)]
DURATION_S = 2.0


def _cluster(n_workers=2, **config):
    with dask.config.set(config):
        return LocalCluster(n_workers=n_workers, processes=True, threads_per_worker=1, dashboard_address=":0")


@pytest.fixture(scope="module")
def config():
    return load_sim_config()


@pytest.fixture(scope="module")
def local_records(config):
    """The local run: every cell in this process."""
    with OfflineRunner(1) as runner:
        return runner.run(CELLS, DURATION_S, config)


@pytest.fixture(scope="module")
def cluster():
    with _cluster() as running:
        yield running


def _assert_identical(records, local_records):
    assert records == local_records  # every figure and status, exactly
    assert all(np.array_equal(a.track, b.track) for a, b in zip(records, local_records))


def _new_children(before):
    """This process's child processes started since ``before`` (pids): the runner's pool, not a cluster's."""
    return [child for child in multiprocessing.active_children() if child.pid not in before]


def _kill_busy_worker(client):
    """SIGKILL the process of a Dask worker that has runs in progress; its address and those runs."""
    processing = client.processing()
    address = next(a for a, keys in processing.items() if keys)
    os.kill(client.run(os.getpid)[address], signal.SIGKILL)
    return address, processing[address]


@pytest.mark.slow(seconds=47)  # with the module's LocalCluster start, in the whole suite, 2026-11-25
def test_a_dask_cluster_gives_the_local_records_exactly_and_counts_every_run(cluster, config, local_records):
    finished, logs = [], []
    with runner_for(cluster.scheduler_address, 2, log=logs.append) as runner:
        assert isinstance(runner, DaskRunner)
        records = runner.run(CELLS, DURATION_S, config, on_result=finished.append)
        ran = runner.client.run(sweep._cycle.cache_info)  # each worker's fitted cycles: the runs ran there
        assert runner.describe() == f"2 workers (2 threads) of the Dask cluster at {cluster.scheduler_address}"
    _assert_identical(records, local_records)
    assert sorted(r.cell for r in finished) == sorted(CELLS)  # each run counted once, as it finished
    assert sum(info.hits + info.misses for info in ran.values()) == len(CELLS)
    assert all(info.misses > 0 for info in ran.values())  # both workers took runs
    assert logs == []  # nothing lost, nothing to say
    with Client(cluster.scheduler_address) as client:
        assert len(client.scheduler_info()["workers"]) == 2  # the runner closed its client, not the cluster


@pytest.mark.slow(seconds=23)
def test_a_worker_killed_mid_sweep_has_its_runs_rescheduled_by_dask_with_identical_records(cluster, config,
                                                                                           local_records):
    """The module's cluster: its nanny starts the killed worker again, as `dask worker` does on a machine."""
    finished, killed, logs = [], [], []

    def kill_once(record):
        if not killed:
            killed.append(_kill_busy_worker(runner.client))
        finished.append(record)

    with runner_for(cluster.scheduler_address, 2, log=logs.append) as runner:
        records = runner.run(CELLS, DURATION_S, config, on_result=kill_once)
        workers_after = runner.client.scheduler_info()["workers"]
    assert logs == []  # Dask's scheduler moved the runs by itself: nothing was resubmitted
    address, in_progress = killed[0]
    assert in_progress and address not in workers_after  # it died with runs in progress and was removed
    _assert_identical(records, local_records)
    assert len(finished) == len(CELLS)


@pytest.mark.slow(seconds=9)
def test_runs_that_dask_gives_up_on_are_resubmitted_by_the_runner_with_a_message(config, local_records):
    """With no failure allowed, Dask fails a killed worker's runs (KilledWorker): the runner submits them again."""
    killed, logs = [], []

    def kill_once(_record):
        if not killed:
            killed.append(_kill_busy_worker(runner.client))

    cluster = _cluster(**{"distributed.scheduler.allowed-failures": 0})
    with cluster, runner_for(cluster.scheduler_address, 2, log=logs.append) as runner:
        records = runner.run(CELLS, DURATION_S, config, on_result=kill_once)
    _assert_identical(records, local_records)
    lost = [line for line in logs if "its worker was lost (KilledWorker" in line]
    assert lost and all(f"submitted again (attempt 2 of {MAX_RESUBMITS + 1})" in line for line in lost), logs


@pytest.mark.slow(seconds=5)
def test_a_local_worker_process_killed_mid_sweep_has_its_runs_resubmitted_to_a_new_pool(config, local_records):
    logs, killed = [], []
    before = {child.pid for child in multiprocessing.active_children()}

    def kill_once(_record):
        if not killed:
            killed.append(_new_children(before)[0].pid)
            os.kill(killed[0], signal.SIGKILL)

    with OfflineRunner(2, log=logs.append) as runner:
        records = runner.run(CELLS, DURATION_S, config, on_result=kill_once)
    _assert_identical(records, local_records)
    # which run broke the pool is not known: its runs go again one at a time, none charged an attempt
    assert killed and any("its worker pool broke (BrokenProcessPool" in line and "run again alone" in line
                          for line in logs), logs


@pytest.mark.slow(seconds=8)
@pytest.mark.parametrize("error", [ValueError("bad value(s) in fds_to_keep"),
                                   BrokenProcessPool("A child process terminated abruptly")])
def test_a_pool_that_breaks_while_it_starts_a_worker_loses_the_run_and_a_new_pool_runs_it(config, local_records,
                                                                                         monkeypatch, error):
    # A pool whose worker died refuses the next run (BrokenProcessPool), and CPython's pool, when a worker dies
    # while it spawns the next one, can fail the submission itself with the ValueError (seen in CI with
    # workers killed every 10 ms): either way a lost run like any other.
    failures = []

    class BreaksOnce(sweep.ProcessPoolExecutor):
        def submit(self, *args, **kwargs):
            if not failures:
                failures.append(1)
                raise error
            return super().submit(*args, **kwargs)

    monkeypatch.setattr(sweep, "ProcessPoolExecutor", BreaksOnce)
    logs = []
    with OfflineRunner(2, log=logs.append) as runner:
        records = runner.run(CELLS[:2], DURATION_S, config)
    _assert_identical(records, local_records[:2])
    lost = [line for line in logs if f"while it took the run ({type(error).__name__}: {error}" in line]
    assert len(lost) == 1 and "submitted again as it was" in lost[0], logs  # not charged: it broke nothing


@pytest.mark.slow
def test_a_run_lost_every_time_becomes_a_failed_record_after_the_resubmissions(config):
    stop, logs = threading.Event(), []
    before = {child.pid for child in multiprocessing.active_children()}

    def kill_every_worker():
        # Each worker is killed 0.2 s after it appears, once it is starting or running its run: a pool spawns
        # its workers together, within milliseconds. (CPython 3.11's pool itself can break or hang when a worker
        # dies while it spawns the next one, which no lab's sweep does on purpose.)
        seen = {}
        while not stop.is_set():
            now = time.monotonic()
            for child in _new_children(before):
                if now - seen.setdefault(child.pid, now) >= 0.2:
                    with contextlib.suppress(ProcessLookupError):  # it may have died already
                        os.kill(child.pid, signal.SIGKILL)
            time.sleep(0.01)

    killer = threading.Thread(target=kill_every_worker)
    killer.start()
    try:
        with OfflineRunner(2, log=logs.append) as runner:
            records = runner.run(CELLS[:2], DURATION_S, config)
    finally:
        stop.set()
        killer.join()
    attempts = MAX_RESUBMITS + 1
    assert [r.status.split(" (")[0] for r in records] == [f"failed: lost with its worker {attempts} times"] * 2
    assert sum("submitted again" in line for line in logs) == 2 * MAX_RESUBMITS
    assert sum("given up: a failed run" in line for line in logs) == 2


def test_without_a_scheduler_the_runner_is_the_local_pool_and_bad_requests_are_refused():
    with runner_for(None, 3) as runner:
        assert type(runner) is OfflineRunner and runner.describe() == "3 workers"
    with pytest.raises(InvalidInputError, match="give one"):
        OfflineRunner(2, executor=object())
    with pytest.raises(ClusterError, match=r"--scheduler 'foo' is not the address of a Dask scheduler .* expected "
                                           r"tcp://HOST:PORT"):
        runner_for("foo")
    with pytest.raises(InvalidInputError, match="workers: 0; expected 1 or more"):
        runner_for("tcp://127.0.0.1:8786", 0)


def test_a_worker_with_other_code_refuses_the_run_it_is_given(config):
    other = dict(code_fingerprint(), srs_ros="0.0.9 (code 000000000000)")
    with pytest.raises(ClusterError, match=r"runs other code than this machine \(srs_ros 0.1.0 \(code \w+\) there, "
                                           r"0.0.9 \(code 000000000000\) here\)"):
        sweep._run_task(CELLS[0], DURATION_S, config, False, other, 0)


@pytest.mark.parametrize("name", ["robot.yaml", "gaits.yaml", "rigs/mock.yaml"])
def test_every_config_file_a_run_reads_is_in_the_code_fingerprint(name, tmp_path, monkeypatch):
    """A worker whose config/rigs/mock.yaml had another command rate ran other numbers under the same fingerprint
    (inward rolling 4 bar 1 Hz, 2 s: v_x -3.20 against -2.52 cm/s at 200 and 50 Hz; a helper's review)."""
    import shutil

    copy = tmp_path / "config"
    shutil.copytree(sweep.config_dir(), copy)
    with (copy / name).open("a") as stream:
        stream.write("\n# changed on this worker\n")
    here = sweep.code_fingerprint()
    sweep.code_fingerprint.cache_clear()
    monkeypatch.setattr(sweep, "config_dir", lambda: copy)
    try:
        assert sweep.code_fingerprint()["srs_ros"] != here["srs_ros"]
    finally:
        sweep.code_fingerprint.cache_clear()


def test_dask_not_installed_is_a_clear_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # as if it were not installed: import fails
    with pytest.raises(ClusterError, match=r"needs Dask distributed, which is not installed here .* pip install "
                                           r"'srs_ros\[cluster\]'"):
        runner_for("tcp://127.0.0.1:8786")


def _free_port():
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def test_an_unreachable_scheduler_is_a_clear_error_within_the_timeout():
    address = f"tcp://127.0.0.1:{_free_port()}"
    started = time.monotonic()
    with pytest.raises(ClusterError, match=f"cannot reach the Dask scheduler at '{address}' .* expected a running "
                                           "`dask scheduler`"):
        runner_for(address, connect_timeout_s=1.0)
    assert time.monotonic() - started < 10.0


def test_a_cluster_without_enough_workers_is_a_clear_error():
    with LocalCluster(n_workers=0, processes=False, protocol="tcp", dashboard_address=":0") as empty:
        with pytest.raises(ClusterError, match=r"has 0 workers after 1 s; expected 2\. Start `dask worker tcp://"):
            runner_for(empty.scheduler_address, 2, worker_wait_s=1.0)


@pytest.mark.slow
def test_a_dask_worker_running_a_changed_copy_of_srs_ros_is_refused_before_any_run(tmp_path):
    for folder in ("srs_ros", "config"):
        shutil.copytree(ROOT / folder, tmp_path / folder, ignore=shutil.ignore_patterns("__pycache__"))
    with (tmp_path / "srs_ros" / "sim" / "model.py").open("a") as model:
        model.write("\n# a local change on one machine\n")
    env = dict(os.environ, PYTHONPATH=str(tmp_path))
    with LocalCluster(n_workers=0, processes=False, protocol="tcp", dashboard_address=":0") as scheduler_only:
        address = scheduler_only.scheduler_address
        worker = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1",
                                   "--no-nanny", "--no-dashboard"], env=env, cwd=tmp_path,  # -m puts the cwd first
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            with pytest.raises(ClusterError, match=r"the Dask worker tcp://\S+ runs other code than this machine "
                                                   r"\(srs_ros 0.1.0 \(code \w+\) there, 0.1.0 \(code \w+\) here\)"):
                runner_for(address, 1, worker_wait_s=60.0)
        finally:
            worker.terminate()
            worker.wait(timeout=30)


@pytest.mark.slow
def test_a_lost_scheduler_stops_the_runs_with_a_clear_error(config):
    """Without it, a client that lost its scheduler takes the lost runs again and waits for them forever."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "cwd": ROOT}
    scheduler = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                                  "--port", str(port), "--dashboard-address", ":0"], **quiet)
    worker = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1",
                               "--no-nanny", "--no-dashboard"], **quiet)
    killed = []

    def kill_the_scheduler(_record):
        if not killed:
            scheduler.kill()
            killed.append(time.monotonic())

    try:
        with runner_for(address, 1, connect_timeout_s=30.0) as runner:
            with pytest.raises(ClusterError, match=rf"lost the Dask scheduler at {address} \(the connection is "
                                                   r"\w+\): it stopped, or the network .* Start it again"):
                runner.run(CELLS, DURATION_S, config, on_result=kill_the_scheduler)
        assert time.monotonic() - killed[0] < 30.0
    finally:
        for process in (worker, scheduler):
            process.kill()
            process.wait(timeout=30)


def _lab_table(path, rows, duration_s=1.5):
    path.write_text(yaml.safe_dump({"measured_table": {
        "name": "a lab's table", "velocity_definition": "displacement / run time", "duration_s": duration_s,
        "signed": False, "columns": ["gait", "amplitude_bar", "frequency_hz", "vx_cm_s", "vy_cm_s"], "rows": rows}}))
    return path


@pytest.mark.slow(seconds=5)
def test_srs_sweep_with_a_scheduler_writes_the_local_table(cluster, tmp_path, capsys):
    grid = ["--gait", "outward_rolling", "--amplitudes", "2", "4", "--frequencies", "0.5", "1", "--duration-s", "1.5"]
    assert main([*grid, "--workers", "2", "--out", str(tmp_path / "local")]) == 0
    capsys.readouterr()
    assert main([*grid, "--scheduler", cluster.scheduler_address, "--out", str(tmp_path / "dask")]) == 0
    printed = capsys.readouterr()
    assert (tmp_path / "dask" / "table.csv").read_text() == (tmp_path / "local" / "table.csv").read_text()
    assert f"4 runs (simulated offline, 1.5 s each, 2 workers (2 threads) of the Dask cluster at " \
           f"{cluster.scheduler_address}" in printed.out
    assert "4/4" in printed.err  # the progress bar counted the cluster's runs


@pytest.mark.slow(seconds=5)
def test_srs_sweep_calibrate_with_a_scheduler_fits_what_the_local_pool_fits(cluster, tmp_path, capsys):
    table = _lab_table(tmp_path / "lab.yaml", [["inward_rolling", 4.0, 1.0, 5.61, 10.11],
                                               ["outward_rolling", 4.0, 0.5, 6.56, 6.75]])
    fit = ["--calibrate", str(table), "--fit", "friction_coefficient", "--max-evaluations", "2", "--fit-duration-s",
           "1", "--no-progress"]
    assert main([*fit, "--workers", "2", "--out", str(tmp_path / "local")]) == 0
    local = capsys.readouterr().out
    assert main([*fit, "--scheduler", cluster.scheduler_address, "--out", str(tmp_path / "dask")]) == 0
    remote = capsys.readouterr().out
    for name in ("table_before.csv", "table_after.csv"):
        assert (tmp_path / "dask" / name).read_text() == (tmp_path / "local" / name).read_text()
    fitted = [next(line for line in out.splitlines() if line.startswith(("fitted:", "the best fit")))
              for out in (local, remote)]
    assert fitted[0] == fitted[1]
    assert f"of the Dask cluster at {cluster.scheduler_address})" in remote


def test_srs_sweep_with_an_unreachable_scheduler_exits_2_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["--gait", "serpentine", "--amplitudes", "2", "--frequencies", "1", "--duration-s", "1",
                 "--scheduler", "nowhere", "--out", str(out)]) == 2
    assert "--scheduler 'nowhere' is not the address of a Dask scheduler" in capsys.readouterr().err
    assert not out.exists()
    with pytest.raises(SystemExit):
        main(["--ros", "--scheduler", "tcp://127.0.0.1:8786", "--out", str(out)])
    assert "--ros and --scheduler: choose one" in capsys.readouterr().err


class _KillsItsWorker(str):
    """A gait name that kills the worker process it is sent to (unpickled there as os._exit(1)): a run that kills
    its worker every time, as a segfault or the OOM killer would."""

    def __reduce__(self):
        return os._exit, (1,)


@pytest.mark.slow(seconds=10)
def test_a_run_that_kills_its_worker_every_time_fails_alone_and_the_runs_beside_it_are_done(config, local_records):
    """A broken pool fails every run in it: all were charged an attempt, and healthy runs queued beside a run that
    kills its worker reached the limit with it (4 of 5 sweeps in a helper's review). They now go again one at a
    time, alone in a fresh pool, where the run that breaks it is known."""
    killer = (_KillsItsWorker(CELLS[0][0]), *CELLS[0][1:])
    logs = []
    with OfflineRunner(2, log=logs.append) as runner:
        records = runner.run([killer, *CELLS[1:3]], DURATION_S, config)
    assert records[0].status.startswith(f"failed: lost with its worker {sweep.MAX_RESUBMITS + 1} times"), logs
    assert records[1:] == local_records[1:3]


def test_an_unexpected_error_from_a_clusters_worker_is_a_cluster_error_that_says_what_to_do(monkeypatch):
    """A worker that joined after the check with an older srs_ros raised a TypeError traceback in srs_sweep, not exit 2
    with the reason (a helper's review). Any executor stands in for a cluster's here: a thread pool."""
    from concurrent.futures import ThreadPoolExecutor

    def older_code(*_args, **_kwargs):
        raise TypeError("_run_task() takes 5 positional arguments but 6 were given")

    monkeypatch.setattr(sweep, "run_cell", older_code)
    config = load_sim_config()
    with ThreadPoolExecutor(1) as pool, OfflineRunner(executor=pool) as runner:
        with pytest.raises(ClusterError, match=r"inward_rolling 2 bar 1 Hz failed on a worker of the cluster "
                                               r"\(TypeError: _run_task\(\) takes .*install the same srs_ros on every "
                                               r"worker"):
            runner.run([("inward_rolling", 2.0, 1.0)], 1.0, config)
    monkeypatch.setattr(sweep, "run_cell", older_code)
    with OfflineRunner(1) as runner, pytest.raises(TypeError):  # the local pool runs this code: a bug, raised as is
        runner.run([("inward_rolling", 2.0, 1.0)], 1.0, config)
