#!/usr/bin/env bash
# The main job: the whole system on the simulated robot (trajectory server, gait player, hardware node on the
# sim rig, sim_world (MuJoCo) and the camera tracker on its overhead camera),
# streaming inward rolling at 4 bar, 1 Hz, with a live status line (tracked vs true speed); Ctrl-C vents and exits.
# Arguments go to srs_bringup (see `scripts/run.sh --help`), e.g. --gait serpentine --video run.avi.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$root/scripts/setup.sh"
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
exec "$SRS_VENV/bin/srs_bringup" "$@"
