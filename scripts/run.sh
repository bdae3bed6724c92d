#!/usr/bin/env bash
# Builds the package and launches the simulator: rviz when a display is available; headless,
# the node prints a one-line status every second. Extra arguments go to roslaunch, e.g.
#   scripts/run.sh scenario:=bead params:="{surface: {type: waves}}"
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [[ -n "${DISPLAY:-}" ]]; then
  WITH_RVIZ=1 bash "$ROOT/scripts/install_deps.sh"
fi
LOG="$(mktemp)"
if ! bash "$ROOT/scripts/build.sh" >"$LOG" 2>&1; then
  cat "$LOG"
  echo "build failed" >&2
  exit 1
fi
rm -f "$LOG"
set +u
source "$ROOT/build/ws/devel/setup.bash"
set -u
# headless, nothing shows the simulation: a status line per second instead (off by default)
STATUS=()
[[ -z "${DISPLAY:-}" ]] && STATUS=(status_period:=1.0)
exec roslaunch constrained_particles simulator.launch "${STATUS[@]}" "$@"
