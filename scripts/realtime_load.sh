#!/usr/bin/env bash
# Real time under load: runs the node on core 0 with a chain of 1,000 particles at dt = 1 ms and
# real_time_factor 1 while a CPU hog spins on core 1, and reports the achieved real-time factor
# and the publish jitter of ~state (scripts/realtime_probe.py). Then asks for more than the
# machine can do (20,000 particles, the hog on the node's own core) to show the node saying it is
# behind and slowing sim time instead of dropping steps.
# Usage: scripts/realtime_load.sh [SECONDS]   (default 20 per case; about 1.5 minutes in all)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SECONDS_PER_CASE="${1:-20}"
LOG="$(mktemp)"
bash "$ROOT/scripts/build.sh" >"$LOG" 2>&1 || { cat "$LOG"; exit 1; }
set +u
source "$ROOT/build/ws/devel/setup.bash"
set -u
export ROS_MASTER_URI=http://localhost:11399
RATE=50
roscore -p 11399 >/dev/null 2>&1 &
CORE=$!
HOG=""
NODE=""
cleanup() {
  [[ -n "$NODE" ]] && kill "$NODE" 2>/dev/null || true
  [[ -n "$HOG" ]] && kill "$HOG" 2>/dev/null || true
  kill "$CORE" 2>/dev/null || true
  wait 2>/dev/null || true
}
trap cleanup EXIT
sleep 3

run_case() {  # label, node core, hog core, particles
  local label=$1 node_core=$2 hog_core=$3 particles=$4
  taskset -c "$hog_core" sh -c 'while :; do :; done' &
  HOG=$!
  taskset -c "$node_core" rosrun constrained_particles simulator_node __name:=simulator \
    _scenario:=chain _chain/num_particles:="$particles" _dt:=0.001 _real_time_factor:=1.0 \
    _integrator:=rk4 _stabilization:=projection _publish_rate:=$RATE _status_period:=0 \
    _max_particles:=100000 >/dev/null 2>&1 &
  NODE=$!
  /usr/bin/python3 "$ROOT/scripts/realtime_probe.py" "$label" "$SECONDS_PER_CASE" "$RATE"
  kill "$NODE" "$HOG"
  wait "$NODE" "$HOG" 2>/dev/null || true
  NODE=""
  HOG=""
}

run_case "1000 particles, node on core 0, hog on core 1" 0 1 1000
run_case "20000 particles, node and hog on core 0" 0 0 20000
