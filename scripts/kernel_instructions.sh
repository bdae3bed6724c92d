#!/usr/bin/env bash
# Instructions per particle-step of the engine's chain step (as it runs, and on its generic stages,
# StagePaths::Generic) and of the minimum-work kernel
# (bench/minimum_kernel.hpp), counted by valgrind's callgrind (Debian's valgrind): each runs
# twice, S1 and S2 steps, and the difference in instructions over N (S2 - S1) leaves out the
# set-up. The peer workload: pinned chain, RK4 + projection, dt = 1 ms.
# Usage: scripts/kernel_instructions.sh [N [S1 S2]]   (defaults 1000, 100, 300; about 2 minutes)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
N="${1:-1000}" S1="${2:-100}" S2="${3:-300}"
command -v valgrind >/dev/null || apt-get install -y valgrind
BIN="$ROOT/build/ws/devel/lib/constrained_particles/bench_kernel"
# always the incremental build: a binary from an older checkout would count another engine
LOG="$(mktemp)"
CP_BUILD_BENCH=ON bash "$ROOT/scripts/build.sh" >"$LOG" 2>&1 || { cat "$LOG"; exit 1; }
rm -f "$LOG"
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT
count() {  # which steps -> instructions
  valgrind --tool=callgrind --callgrind-out-file="$TMP/out" "$BIN" --profile "$1" "$N" "$2" \
    >/dev/null 2>"$TMP/err"
  grep -o "Collected : [0-9]*" "$TMP/err" | tail -1 | grep -o "[0-9]*$"
}
# the stamp scripts/performance_page.py shows over the counts
echo "# \`bash scripts/kernel_instructions.sh${*:+ $*}\` at $(python3 "$ROOT/scripts/performance_page.py" --stamp "$ROOT")"
for who in engine generic kernel; do
  a="$(count "$who" "$S1")"
  b="$(count "$who" "$S2")"
  echo "$who n = $N: $(( (b - a) / (N * (S2 - S1)) )) instructions per particle-step"
done
