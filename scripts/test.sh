#!/usr/bin/env bash
# The whole test suite (unit, property, lint, colcon build, nodes over real DDS in separate processes) in two
# pytest-xdist workers, a file to a worker, the longest files first (test/conftest.py); SRS_TEST_WORKERS=0 runs it
# in one process (README "Tests").
# Extra arguments go to pytest, e.g. `scripts/test.sh -k kinematics`, `scripts/test.sh -m "not ros"`.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$root/scripts/setup.sh"
cd "$root"
exec "$SRS_VENV/bin/python" -m pytest -n "${SRS_TEST_WORKERS:-2}" --dist loadfile --no-loadscope-reorder "$@"
