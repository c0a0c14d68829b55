"""The test harness itself: what keeps one failed or hung test from spoiling the rest of the run."""

import os
import subprocess
import sys
import time
from pathlib import Path

from srs_testing import note_killed

#: A test process that starts a node and dies without any teardown, as the hang watchdog ends a worker.
DIES_WITHOUT_TEARDOWN = """
import os, time
from srs_testing.ros import NodeProcess, ros_args
node = NodeProcess("trajectory_server", ros_args({"generate_on_start": False}))
print(node.process.pid, flush=True)
end = time.monotonic() + 20.0
while "call ~/regenerate" not in node.output() and time.monotonic() < end:
    time.sleep(0.05)  # the node up and running, as a test's would be
os._exit(0)
"""


def _gone(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return True
    return state in ("Z", "X")


def test_a_node_dies_with_the_test_process_that_started_it(ros_env):
    """A worker ended by the hang watchdog skips every teardown: its nodes lived on, answering as /hardware_node in
    the domain given to the next test (a review of the harness)."""
    started = subprocess.run([sys.executable, "-c", DIES_WITHOUT_TEARDOWN], env=ros_env, capture_output=True,
                             text=True, timeout=60)
    pid = int(started.stdout.split()[0])
    deadline = time.monotonic() + 10.0
    while not _gone(pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    note_killed()  # its shared memory is left as a SIGKILL leaves it
    try:
        assert _gone(pid), f"trajectory_server (pid {pid}) outlived the process that started it"
    finally:
        if not _gone(pid):
            os.kill(pid, 9)


REPO = Path(__file__).resolve().parents[1]


def _collected(phase: str, *paths: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, SRS_TEST_PHASE=phase)
    env.pop("SRS_TEST_HANG_DIR", None)  # this run's own: the outer one lists this test's file as a worker that died
    return subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:xdist", *paths], cwd=REPO,
                          env=env, capture_output=True, text=True, timeout=120)


def test_the_two_phases_of_the_suite_split_its_tests_by_the_quiet_mark_and_a_wrong_phase_is_refused():
    """scripts/test.sh runs the ``quiet`` tests after the others, alone: each phase selects its own, none is lost."""
    files = ("test/tools/test_identify.py", "test/test_harness.py")
    quiet, parallel, every = (_collected(phase, *files) for phase in ("quiet", "parallel", ""))
    listed = {name: {line for line in run.stdout.splitlines() if "::" in line}
              for name, run in (("quiet", quiet), ("parallel", parallel), ("every", every))}
    assert listed["quiet"] == {"test/tools/test_identify.py::test_the_simulated_rig_is_identified_end_to_end_over_dds"}
    assert listed["quiet"] | listed["parallel"] == listed["every"] and not listed["quiet"] & listed["parallel"]
    assert len(listed["every"]) > 5
    wrong = _collected("both", *files)
    assert wrong.returncode == 4 and "SRS_TEST_PHASE='both': expected 'parallel', 'quiet' or unset" in wrong.stderr
