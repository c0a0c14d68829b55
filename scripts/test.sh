#!/usr/bin/env bash
# The whole test suite (unit, property, lint, colcon build, nodes over real DDS in separate processes) in three
# pytest-xdist workers (the DDS tests wait on discovery and messages, so three keep two cores busy), a file to a
# worker, in test/conftest.py's order, then the `quiet` tests alone; SRS_TEST_WORKERS=0 runs it all in one process
# (README "Tests").
# Extra arguments go to pytest, e.g. `scripts/test.sh -k kinematics`, `scripts/test.sh -m "not ros"`.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$root/scripts/setup.sh"
cd "$root"
# The suite starts a few hundred Python processes (nodes, CLIs): let them cache the repo's bytecode in __pycache__
# (git ignores it) instead of compiling srs_ros again in each, even where the environment turns caching off.
unset PYTHONDONTWRITEBYTECODE
# Three workers and their node processes share two cores: one thread each for OpenBLAS, OpenMP and OpenCV, whose
# pools would otherwise spin on cores the others need (measured: 21 s less CPU per suite run; nothing tested
# depends on it). A caller's own setting wins.
export OPENBLAS_NUM_THREADS="${OPENBLAS_NUM_THREADS:-1}" OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}"
export OPENCV_FOR_THREADS_NUM="${OPENCV_FOR_THREADS_NUM:-1}"
"$SRS_VENV/bin/python" -m srs_testing.opencv46  # the OpenCV 4.6 venv of test/test_opencv46.py, made once
workers="${SRS_TEST_WORKERS:-3}"
if [ "$workers" = 0 ]; then  # one process, every test in test/conftest.py's order
  exec "$SRS_VENV/bin/python" -m pytest -n 0 "$@"
fi
# Two phases (test/conftest.py, SRS_TEST_PHASE): the workers run every test but the `quiet` ones; then one worker
# runs the `quiet` ones alone, tests that time a simulated world or a host's messaging and failed beside the other
# workers on a slow VM (README "Tests"). Both phases run; the suite passes when both pass. pytest's exit code 5 (no
# test selected, e.g. `-k` matched only one phase's tests) counts as a pass if the other phase ran tests.
set +e
SRS_TEST_PHASE=parallel "$SRS_VENV/bin/python" -m pytest -n "$workers" --dist loadfile --no-loadscope-reorder "$@"
parallel=$?
case "$parallel" in 2|3|4) exit "$parallel" ;; esac  # interrupted (Ctrl-C), internal or usage error: no second phase
echo "scripts/test.sh: the quiet phase: the tests marked quiet, alone in one worker"
SRS_TEST_PHASE=quiet "$SRS_VENV/bin/python" -m pytest -n 1 "$@"
quiet=$?
set -e
if [ "$parallel" = 5 ] && [ "$quiet" = 5 ]; then exit 5; fi
for code in "$parallel" "$quiet"; do
  if [ "$code" != 0 ] && [ "$code" != 5 ]; then
    echo "scripts/test.sh: failed (parallel phase exit $parallel, quiet phase exit $quiet)" >&2
    exit "$code"
  fi
done
