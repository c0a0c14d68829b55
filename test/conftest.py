"""Test-wide isolation (a private ROS_DOMAIN_ID, localhost-only discovery, a private log folder), the DDS
fixtures, and the markers: every test that uses a DDS fixture is marked ``ros`` here.

``scripts/test.sh -m "not ros"`` runs what needs no DDS (core, sim, backends without a node, tools offline,
lint, the OpenCV 4.6 run); ``-m "not ros and not slow"`` the fast core alone. ``slow`` sits on the tests
measured at more than about 3 s on the 2-core machine (2 s for those without DDS; ``@pytest.mark.slow``
beside each). The README's "Tests" section has the figures.
"""

from __future__ import annotations

import faulthandler
import os
import tempfile
from pathlib import Path

import pytest
from srs_testing import (
    NodeProcess,
    RosClient,
    RosSession,
    allocate_domain,
    fastdds_shm_clean,
    fastdds_shm_clean_if_killed,
    release_domain,
)

_LOG_DIR = tempfile.mkdtemp(prefix="srs_ros_test_logs_")
os.environ["ROS_LOG_DIR"] = _LOG_DIR
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.pop("ROS_STATIC_PEERS", None)
os.environ.setdefault("RCUTILS_COLORIZED_OUTPUT", "0")
os.environ["PYTHONUNBUFFERED"] = "1"
os.environ["MPLBACKEND"] = "Agg"

#: A test that uses one of these talks over real DDS (and most start node processes): marker ``ros``.
ROS_FIXTURES = frozenset({"ros_domain", "ros_env", "ros_client", "launch_node", "ros_sessions"})


#: What a test counts for when files are ordered (s): a ``slow`` one without a measured figure, one over DDS,
#: any other (measured on the 2-core machine: most DDS tests take about a second, most others a few ms).
SLOW_TEST_S, ROS_TEST_S, OTHER_TEST_S = 5.0, 1.0, 0.02


def pytest_collection_modifyitems(config, items) -> None:
    """Mark ``ros`` every test whose fixtures (directly or through other fixtures) include a DDS fixture, and
    order the files for ``-n 2 --dist loadfile --no-loadscope-reorder`` (scripts/test.sh): first the files that
    load the machine on purpose (``busy``: a minute beside busy processes), then the files without DDS, then
    those with a DDS test, each group longest first. So the other worker runs tests that time nothing while one loads
    the machine, and no worker waits alone for a long file at the end. A file counts the ``seconds`` of its
    ``slow`` marks (``@pytest.mark.slow(seconds=60)``, measured on the 2-core machine; :data:`SLOW_TEST_S`
    without a figure) and an estimate for its other tests. Each file's tests keep their order."""
    file_s: dict[str, float] = {}
    group: dict[str, int] = {}
    for item in items:
        path = item.nodeid.split("::")[0]
        if ROS_FIXTURES & set(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.ros)
        is_ros, slow = item.get_closest_marker("ros") is not None, item.get_closest_marker("slow")
        if slow is not None:
            estimate_s = float(slow.kwargs.get("seconds", SLOW_TEST_S))
        else:
            estimate_s = ROS_TEST_S if is_ros else OTHER_TEST_S
        file_s[path] = file_s.get(path, 0.0) + estimate_s
        busy, had = item.get_closest_marker("busy") is not None, group.get(path, 1)
        group[path] = 0 if busy or had == 0 else 2 if is_ros or had == 2 else 1  # a file with one DDS test: DDS
    items.sort(key=lambda item: (group[item.nodeid.split("::")[0]], -file_s[item.nodeid.split("::")[0]]))
    _select_phase(config, items)


#: The phase of scripts/test.sh this pytest runs: ``parallel`` leaves out the ``quiet`` tests, ``quiet`` runs only
#: them; unset (plain pytest, ``SRS_TEST_WORKERS=0``), every test.
PHASE_VARIABLE = "SRS_TEST_PHASE"


def _select_phase(config, items) -> None:
    """Deselect what the other phase runs. ``quiet`` sits on tests that time a simulated world or the host's messaging
    and failed beside the suite's other workers on a slow VM (docs/testing.md, "Stop 61"): they run after, alone."""
    phase = os.environ.get(PHASE_VARIABLE, "")
    if phase not in ("parallel", "quiet"):
        if phase:
            raise pytest.UsageError(f"{PHASE_VARIABLE}={phase!r}: expected 'parallel', 'quiet' or unset")
        return
    wanted = phase == "quiet"
    keep = [item for item in items if (item.get_closest_marker("quiet") is not None) == wanted]
    left = [item for item in items if (item.get_closest_marker("quiet") is not None) != wanted]
    if left:
        config.hook.pytest_deselected(items=left)
        items[:] = keep


def pytest_sessionfinish() -> None:
    """Whatever a test killed, no Fast DDS shared-memory file outlives the run."""
    fastdds_shm_clean()


#: A test (setup, call and teardown) still running after this long ends its process, every thread's stack written
#: first. setup.cfg's pytest-timeout (300 s) ends a test stuck in Python; it cannot end one stuck in C with the GIL
#: held, as a Fast DDS deadlock inside ``create_client`` was (2026-11-29: a worker hung 13 min, the CI run would have
#: hung to its limit). faulthandler's watchdog is a C thread: it needs no GIL. xdist reports the test failed
#: ("node down") and starts another worker.
HANG_S = 420.0
_HANG_DIR = Path(os.environ.setdefault("SRS_TEST_HANG_DIR", tempfile.mkdtemp(prefix="srs_ros_test_hangs_")))


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    path = _HANG_DIR / f"{os.getpid()}.txt"
    with path.open("w") as stream:
        stream.write(f"{item.nodeid}: still running after {HANG_S:g} s; its process was ended. Every thread:\n")
        stream.flush()
        faulthandler.dump_traceback_later(HANG_S, exit=True, file=stream)
        try:
            yield
        finally:
            faulthandler.cancel_dump_traceback_later()
    path.unlink()


def pytest_terminal_summary(terminalreporter) -> None:
    """The stacks of any test the watchdog ended (written by its worker process; with one process, ``-n 0``, the
    run ends there and the stacks stay in ``SRS_TEST_HANG_DIR``). A file with its first line only: the worker died
    in that test by something else (a crash, a kill)."""
    for path in sorted(_HANG_DIR.glob("*.txt")):
        text = path.read_text(errors="replace")
        hung = "Timeout (" in text
        title = "a hung test, ended by the watchdog" if hung else "a worker died in this test (not the watchdog)"
        terminalreporter.write_sep("=", f"{title} ({path})")
        terminalreporter.write_line(text[-8000:] if hung else text.splitlines()[0].partition(": ")[0])
    if os.environ.get("PYTEST_XDIST_WORKER") is None and not any(_HANG_DIR.iterdir()):
        _HANG_DIR.rmdir()


@pytest.fixture
def ros_domain():
    """A fresh DDS domain for one test; released afterwards (Fast DDS shm cleaned if a process was killed)."""
    domain = allocate_domain()
    try:
        yield domain
    finally:
        release_domain(domain)
        fastdds_shm_clean_if_killed()


@pytest.fixture
def ros_env(ros_domain):
    """Environment for node processes on the test's domain."""
    env = os.environ.copy()
    env["ROS_DOMAIN_ID"] = str(ros_domain)
    return env


@pytest.fixture
def ros_client(ros_domain):
    """An rclpy client node on the test's domain (closed in teardown)."""
    client = RosClient(ros_domain)
    try:
        yield client
    finally:
        client.close()


@pytest.fixture
def launch_node(ros_env, tmp_path):
    """Start console-script nodes on the test's domain; every one is stopped in teardown, pass or fail.

    Usage: ``proc = launch_node("gait_player", ros_args({"rate_hz": 200}))``; ``prefix`` runs it through a
    command that execs it (e.g. ``ip netns exec NS``).
    """
    started: list[NodeProcess] = []

    def _launch(script: str, args=(), env_overrides: dict[str, str] | None = None, prefix=()) -> NodeProcess:
        env = dict(ros_env, **(env_overrides or {}))
        proc = NodeProcess(script, args, env=env, log_dir=tmp_path, prefix=prefix)
        started.append(proc)
        return proc

    yield _launch
    for proc in started:
        proc.stop()


@pytest.fixture(scope="module")
def ros_sessions(tmp_path_factory):
    """Sessions (a private domain, a client, node processes) that live for a whole test module.

    For node processes that several tests share: ``session = ros_sessions()``; each test brings the shared
    node back to a known state first (``SharedNode.prepare`` in srs_testing.hardware_rig). Closed at the end of
    the module, pass or fail.
    """
    sessions: list[RosSession] = []

    def _open(client_name: str = "srs_test_client") -> RosSession:
        sessions.append(RosSession(tmp_path_factory.mktemp("ros_session"), client_name))
        return sessions[-1]

    yield _open
    for session in sessions:
        session.close()
