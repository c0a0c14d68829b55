#!/usr/bin/env bash
# The main job: the whole system on the simulated robot (trajectory server, gait player, hardware node on the
# sim rig, sim_world (MuJoCo), the camera tracker on its overhead camera and the navigator), patrolling
# waypoints inside the camera's view in a closed loop (the navigator steers the rolling gaits by the camera's
# pose), with a live status line (goal, distance to go, tracked vs true speed); Ctrl-C vents and exits.
# Arguments go to srs_bringup (see `scripts/run.sh --help`): --gait inward_rolling (or any gait) plays that gait
# open loop instead, as before; --navigate waits for goals (RViz's 2D Goal Pose); --video run.avi saves the view.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$root/scripts/setup.sh"
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
mode=(--patrol)  # unless the arguments choose: open loop (--gait), goals (--navigate, --patrol), another rig
for arg in "$@"; do
  case "$arg" in
    --gait | --gait=* | --navigate | --patrol | --rig | --rig=* | --backend | --backend=*) mode=() ;;
    --ros-args) break ;;
  esac
done
exec "$SRS_VENV/bin/srs_bringup" "${mode[@]}" "$@"
