#!/usr/bin/env bash
# Creates the project's virtual environment (.venv) and installs srs_ros into it, editable, with the
# ROS 2 Jazzy wheels from PyPI and the test tools, and the test harness srs_testing (test/pyproject.toml,
# editable: the benchmarks import it). Idempotent: re-installs only when setup.py or a pyproject changed.
# Needs only Python >= 3.10 and the package registries. Override: SRS_VENV=/path, PYTHON=python3.11.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="${SRS_VENV:-$root/.venv}"
python="${PYTHON:-$(command -v python3.11 || command -v python3)}"
if [ ! -x "$venv/bin/python" ]; then
  echo "srs_ros: creating $venv with $python" >&2
  "$python" -m venv "$venv"
fi
stamp="$venv/.srs_ros_installed"
if [ ! -f "$stamp" ] || [ "$root/setup.py" -nt "$stamp" ] || [ "$root/pyproject.toml" -nt "$stamp" ] \
    || [ "$root/test/pyproject.toml" -nt "$stamp" ]; then
  echo "srs_ros: installing srs_ros[wheels,test] into $venv (about a minute)" >&2
  "$venv/bin/python" -m pip install --quiet --upgrade pip >&2
  "$venv/bin/python" -m pip install --quiet -e "$root[wheels,test]" >&2
  "$venv/bin/python" -m pip install --quiet --no-deps -e "$root/test" >&2
  touch "$stamp"
fi
export SRS_VENV="$venv"
