#!/usr/bin/env bash
# Renders rviz headless (Xvfb) with the simulator running and saves docs/screenshot.png.
# Usage: scripts/screenshot.sh [scenario, default surface_chain] [seconds to run first, default 6]
#        [output, default docs/screenshot.png]; CP_SCREENSHOT_PARAMS: the node's inline parameters
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SCENARIO="${1:-surface_chain}"
WAIT="${2:-6}"
OUT="${3:-$ROOT/docs/screenshot.png}"
DEFAULT_PARAMS="{chain: {num_particles: 6, link_length: 0.4}, force_scale: 0.04}"
PARAMS="${CP_SCREENSHOT_PARAMS:-$DEFAULT_PARAMS}"
DISPLAY_NUMBER=99
WITH_RVIZ=1 bash "$ROOT/scripts/install_deps.sh"
bash "$ROOT/scripts/build.sh" >/dev/null
set +u
source "$ROOT/build/ws/devel/setup.bash"
set -u

Xvfb ":$DISPLAY_NUMBER" -screen 0 1280x800x24 >/dev/null 2>&1 &
XVFB_PID=$!
cleanup() {
  [[ -n "${LAUNCH_PID:-}" ]] && kill -INT "$LAUNCH_PID" 2>/dev/null && wait "$LAUNCH_PID" 2>/dev/null
  kill "$XVFB_PID" 2>/dev/null || true
}
trap cleanup EXIT
export DISPLAY=":$DISPLAY_NUMBER"
sleep 1
roslaunch constrained_particles simulator.launch scenario:="$SCENARIO" rviz:=true \
  params:="$PARAMS" >/tmp/screenshot_launch.log 2>&1 &
LAUNCH_PID=$!
sleep "$WAIT"
SHOT="$(mktemp --suffix=.xwd)"
xwd -root -display ":$DISPLAY_NUMBER" -out "$SHOT"
mkdir -p "$(dirname "$OUT")"
# /usr/bin/convert is ImageMagick's; another convert may come first in PATH
/usr/bin/convert "$SHOT" "$OUT"
rm -f "$SHOT"
echo "wrote $OUT"
