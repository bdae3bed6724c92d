#!/usr/bin/env bash
# Fuzzes the core with libFuzzer (clang, with ASan and UBSan): scene files, surface formulas,
# ~set_state payloads and ~set_chain/~set_surface values, through test/fuzz/fuzz_input.cpp.
# Usage: scripts/fuzz.sh [SECONDS]   (default 120)
# Seeds: config/scenes/*.yaml, a few formulas and test/fuzz/regressions/. Findings are written
# to build/fuzz/findings/; copy one to test/fuzz/regressions/ to make it a regression test
# (test_fuzz_regressions replays that folder in every test run).
# Ends with "fuzz: E executions in S s, F findings"; exits non-zero on a finding (libFuzzer stops
# at the first).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
RUN_SECONDS="${1:-120}"
WITH_FUZZ=1 bash "$ROOT/scripts/install_deps.sh"
OUT="$ROOT/build/fuzz"
mkdir -p "$OUT/corpus" "$OUT/findings"
BIN="$OUT/fuzz_core"
# the core as CMake builds it: every stage file, one file per integrator and per solve
SOURCES=("$ROOT"/src/core/*.cpp "$ROOT"/src/core/integrators/*.cpp "$ROOT"/src/core/solvers/*.cpp
  "$ROOT"/src/scenes/*.cpp "$ROOT/test/fuzz/fuzz_input.cpp" "$ROOT/test/fuzz/libfuzzer_main.cpp")
newest=$(ls -t "${SOURCES[@]}" "$ROOT"/src/core/*.hpp "$ROOT"/src/core/*/*.hpp \
  "$ROOT"/include/constrained_particles/*/*.hpp \
  "$ROOT"/include/constrained_particles/core/effects/*.hpp | head -1)
if [[ ! -x "$BIN" || "$newest" -nt "$BIN" ]]; then
  echo "building $BIN (clang, libFuzzer + ASan + UBSan)..." >&2
  clang++ -std=c++17 -O1 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined \
    -I"$ROOT/include" -I/usr/include/eigen3 "${SOURCES[@]}" -lyaml-cpp -o "$BIN"
fi
for scene in "$ROOT"/config/scenes/*.yaml; do
  { printf '\x00'; cat "$scene"; } >"$OUT/corpus/scene_$(basename "$scene" .yaml)"
done
printf '\x010.3*sin(2*x)*cos(y)' >"$OUT/corpus/formula_waves"
printf '\x01exp(-(x^2+y^2)/0.5) + tanh(x)*abs(y)^1.5' >"$OUT/corpus/formula_mixed"
LOG="$OUT/last_run.log"
started=$(date +%s)
set +e
"$BIN" -max_total_time="$RUN_SECONDS" -max_len=8192 -timeout=10 -rss_limit_mb=4096 \
  -print_final_stats=1 -artifact_prefix="$OUT/findings/" "$OUT/corpus" \
  "$ROOT/test/fuzz/regressions" >"$LOG" 2>&1
status=$?
set -e
elapsed=$(($(date +%s) - started))
executions=$(grep -o "stat::number_of_executed_units: *[0-9]*" "$LOG" | grep -o "[0-9]*$" || echo 0)
findings=$(find "$OUT/findings" -type f -newer "$BIN" | wc -l)
if ((status != 0)); then
  grep -B2 -A30 "ERROR\|fuzz finding\|runtime error" "$LOG" | head -60 >&2
fi
echo "fuzz: ${executions} executions in ${elapsed} s, ${findings} findings (log: $LOG)"
((status == 0 && findings == 0))
