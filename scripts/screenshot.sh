#!/usr/bin/env bash
# Renders rviz headless (Xvfb) beside the simulator and saves a screenshot of the scene, framed by
# scripts/rviz_view.py on the node's ~view; then checks it with scripts/check_screenshot.py and
# fails (exit 1, with its message) if the picture is black, empty or cuts the scene off.
# Usage: scripts/screenshot.sh SCENE [OUT.png]
#   SCENE    a scene name from config/scenes, or a scene file path
#   OUT.png  default build/screenshots/SCENE.png (README's pictures are refreshed by naming docs/)
# Environment:
#   CP_SCREENSHOT_PARAMS  the node's inline parameters, e.g. "{chain: {num_particles: 1000}}"
#   CP_SCREENSHOT_WAIT    seconds of simulation before the shot (default 6)
#   CP_SCREENSHOT_DRAG    "PARTICLE X Y Z": drags that particle towards the point (scripts/drag.py)
#                         during the last 3 s before the shot, still held when it is taken
#   CP_SCREENSHOT_BESIDE  a command run from the repository beside the simulator, from its start
#                         until the shot, e.g. "python3 scripts/hand.py" (hold_the_rope's hand)
#   CP_SCREENSHOT_ROBOT   a URDF file for robot_description (simulator.launch's robot:=)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [[ $# -lt 1 || $# -gt 2 ]]; then
  sed -n '2,15p' "$0" >&2
  exit 2
fi
SCENARIO="$1"
NAME="$(basename "$SCENARIO" .yaml)"
OUT="${2:-$ROOT/build/screenshots/$NAME.png}"
WAIT="${CP_SCREENSHOT_WAIT:-6}"
PARAMS="${CP_SCREENSHOT_PARAMS:-}"
DRAG="${CP_SCREENSHOT_DRAG:-}"
BESIDE="${CP_SCREENSHOT_BESIDE:-}"
ROBOT="${CP_SCREENSHOT_ROBOT:-}"
WITH_RVIZ=1 bash "$ROOT/scripts/install_deps.sh"
bash "$ROOT/scripts/build.sh" >/dev/null
set +u
source "$ROOT/build/ws/devel/setup.bash"
set -u
export PATH="/usr/bin:$PATH"  # Debian's python3 (rospy) and ImageMagick's convert come first

LOGS="$(mktemp -d)"
# a free display and a free master port: other runs (or simulators) may share the machine
DISPLAY_NUMBER=99
while [[ -e "/tmp/.X11-unix/X$DISPLAY_NUMBER" || -e "/tmp/.X$DISPLAY_NUMBER-lock" ]]; do
  DISPLAY_NUMBER=$((DISPLAY_NUMBER + 1))
done
PORT="$(python3 -c 'import socket; s = socket.socket(); s.bind(("", 0)); print(s.getsockname()[1])')"
export ROS_MASTER_URI="http://localhost:$PORT"
Xvfb ":$DISPLAY_NUMBER" -screen 0 1280x800x24 >"$LOGS/xvfb.log" 2>&1 &
XVFB_PID=$!
LAUNCH_PID=""
DRAG_PID=""
BESIDE_PID=""
# stops what we started, by its process group (setsid below): SIGINT as Ctrl-C would, then
# SIGTERM, then SIGKILL, each after a wall-clock wait (a background job may ignore SIGINT)
# The whole group is waited for, not only its leader: a non-interactive shell's background jobs
# ignore SIGINT and outlive it. `|| true`: the leader's status after a signal (130) would end
# this EXIT trap under set -e before the launch is stopped (it left roslaunch and rviz running).
stop_group() {
  local pid="$1"
  for sig in INT TERM KILL; do
    kill "-$sig" -- "-$pid" 2>/dev/null || return 0
    for _ in $(seq 100); do
      if ! kill -0 "$pid" 2>/dev/null; then
        wait "$pid" 2>/dev/null || true  # reaped: a zombie leader would keep the group alive
        kill -0 -- "-$pid" 2>/dev/null || return 0
      fi
      sleep 0.1
    done
  done
}
cleanup() {
  [[ -n "$DRAG_PID" ]] && stop_group "$DRAG_PID"
  [[ -n "$BESIDE_PID" ]] && stop_group "$BESIDE_PID"
  [[ -n "$LAUNCH_PID" ]] && stop_group "$LAUNCH_PID"
  kill "$XVFB_PID" 2>/dev/null && { wait "$XVFB_PID" 2>/dev/null || true; }
  rm -rf "$LOGS"
}
trap cleanup EXIT
export DISPLAY=":$DISPLAY_NUMBER"
sleep 1
ARGS=(scenario:="$SCENARIO" rviz:=true rviz_args:="--hide-panels")
[[ -n "$PARAMS" ]] && ARGS+=(params:="$PARAMS")
[[ -n "$ROBOT" ]] && ARGS+=(robot:="$ROBOT")
setsid roslaunch -p "$PORT" constrained_particles simulator.launch "${ARGS[@]}" \
  >"$LOGS/launch.log" 2>&1 &
LAUNCH_PID=$!
# the node up (or gone: a scene it refuses) before the clock starts
for _ in $(seq 600); do
  rostopic list 2>/dev/null | grep -qx /simulator/view && break
  if ! kill -0 "$LAUNCH_PID" 2>/dev/null; then
    echo "screenshot.sh: the simulator did not start; its log:" >&2
    cat "$LOGS/launch.log" >&2
    exit 1
  fi
  sleep 0.1
done
if [[ -n "$BESIDE" ]]; then
  (cd "$ROOT" && exec setsid bash -c "$BESIDE") >"$LOGS/beside.log" 2>&1 &
  BESIDE_PID=$!
fi
if [[ -n "$DRAG" ]]; then
  sleep "$(python3 -c "print(max(0.0, $WAIT - 3.0))")"
  # shellcheck disable=SC2086  # PARTICLE X Y Z as separate words
  setsid python3 "$ROOT/scripts/drag.py" $DRAG --seconds 1.5 --hold 0 >"$LOGS/drag.log" 2>&1 &
  DRAG_PID=$!
  sleep 3
else
  sleep "$WAIT"
fi
if ! rosnode list 2>/dev/null | grep -qx /simulator; then
  echo "screenshot.sh: the simulator stopped; its log:" >&2
  cat "$LOGS/launch.log" >&2
  exit 1
fi
SHOT="$LOGS/shot.xwd"
xwd -root -display ":$DISPLAY_NUMBER" -out "$SHOT"
mkdir -p "$(dirname "$OUT")"
/usr/bin/convert "$SHOT" "$OUT"
echo "wrote $OUT"
python3 "$ROOT/scripts/check_screenshot.py" "$OUT"
