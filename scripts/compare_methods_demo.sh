#!/usr/bin/env bash
# Regenerates docs/accuracy.md's figures: starts a master and a
# simulator on a free port (stopped afterwards by their PIDs), asks it ~compare_methods through
# scripts/compare_methods.py and keeps the table, CSV and diagram in docs/compare_methods/, with
# the run's stamp (command, commit, date) beside the CSV; docs/accuracy.md's summary follows
# (scripts/performance_page.py).
# Usage: scripts/compare_methods_demo.sh [scenario, default surface_chain] [horizon s, default 1]
#        [target m, default 1e-6] [output dir, default docs/compare_methods]
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SCENARIO="${1:-surface_chain}"
HORIZON="${2:-1}"
TARGET="${3:-1e-6}"
OUT="${4:-$ROOT/docs/compare_methods}"
bash "$ROOT/scripts/install_deps.sh"
bash "$ROOT/scripts/build.sh" >/dev/null
set +u
source "$ROOT/build/ws/devel/setup.bash"
set -u
export PATH="/usr/bin:$PATH"  # Debian's python3, which has rospy
PORT="$(python3 -c 'import socket; s = socket.socket(); s.bind(("", 0)); print(s.getsockname()[1])')"
export ROS_MASTER_URI="http://localhost:$PORT"
LOGS="$(mktemp -d)"
roscore -p "$PORT" >"$LOGS/roscore.log" 2>&1 &
CORE_PID=$!
NODE_PID=""
cleanup() {
  [[ -n "$NODE_PID" ]] && kill -INT "$NODE_PID" 2>/dev/null && wait "$NODE_PID" 2>/dev/null
  kill -INT "$CORE_PID" 2>/dev/null && wait "$CORE_PID" 2>/dev/null
  rm -rf "$LOGS"
}
trap cleanup EXIT
rosrun constrained_particles simulator_node _scenario:="$SCENARIO" >"$LOGS/node.log" 2>&1 &
NODE_PID=$!
# the master and the node up first, so nothing but the study reaches the table
for _ in $(seq 600); do
  rosnode list 2>/dev/null | grep -qx /simulator && break
  sleep 0.1
done
mkdir -p "$OUT"
STAMP="\`bash scripts/compare_methods_demo.sh${*:+ $*}\` at $(python3 "$ROOT/scripts/performance_page.py" --stamp "$ROOT")"
rm -f "$OUT/${SCENARIO}_compare_methods.stamp"  # a failed study leaves no stamp over old files
python3 "$ROOT/scripts/compare_methods.py" --node /simulator --horizon "$HORIZON" \
  --target "$TARGET" --output "$OUT" | tee "$OUT/${SCENARIO}_compare_methods.txt"
echo "$STAMP" >"$OUT/${SCENARIO}_compare_methods.stamp"
python3 "$ROOT/scripts/performance_page.py"
