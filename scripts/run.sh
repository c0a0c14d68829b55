#!/usr/bin/env bash
# The main job: the whole system on the mock robot (trajectory server, gait player, hardware node),
# streaming inward rolling at 4 bar, 1 Hz, with a live status line; Ctrl-C vents and exits.
# Arguments go to srs_bringup (see `scripts/run.sh --help`), e.g. --gait serpentine --amplitude-bar 3.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$root/scripts/setup.sh"
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
exec "$SRS_VENV/bin/srs_bringup" "$@"
