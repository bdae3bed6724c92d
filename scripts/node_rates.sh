#!/usr/bin/env bash
# Node throughput: runs the simulator node with a chain of 1,000, 10,000 and 100,000 particles at
# real_time_factor 100 (as fast as the machine allows) and prints a markdown table of steps/s,
# achieved real-time factor, /tf and ~state rates and node CPU (scripts/node_rates.py). Takes
# about 2 minutes after the build (3 x 10 s per size plus start-up and warm-up).
# Usage: scripts/node_rates.sh [--no-build] [node_rates.py options, e.g. --sizes 1000 --seconds 3
#                              --repeats 1 --publish-rate 60 --check-state-hz 10]
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [[ "${1:-}" == "--no-build" ]]; then
  shift
else
  LOG="$(mktemp)"
  bash "$ROOT/scripts/build.sh" -j2 >"$LOG" 2>&1 || { cat "$LOG"; exit 1; }
  rm -f "$LOG"
fi
exec /usr/bin/python3 "$ROOT/scripts/node_rates.py" "$@"
