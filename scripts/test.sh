#!/usr/bin/env bash
# The whole test suite (unit, property, lint, colcon build, nodes over real DDS in separate processes).
# Extra arguments go to pytest, e.g. `scripts/test.sh -k kinematics`.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$root/scripts/setup.sh"
cd "$root"
exec "$SRS_VENV/bin/python" -m pytest "$@"
