#!/usr/bin/env bash
# What accuracy costs: runs every benchmark and draws the diagrams into docs/bench/
# (CSV, PNG and summary.md), each CSV's stamp (NAME.stamp: command, commit, date) and the
# generated blocks of docs/*.md (scripts/performance_page.py). Installs the peers (ODE 0.16, MuJoCo 2.2.2) and matplotlib from
# Debian's packages. Takes about 15 minutes on 2 cores; progress goes to stderr.
# Usage: scripts/bench.sh [--quick]   (--quick: a small sweep for a smoke test, into build/bench)
#        scripts/bench.sh --scenes         (only the per-scene and solve-by-structure part, into
#                                          docs/bench, then the summary again: about 2 minutes)
#        scripts/bench.sh --stability      (only what stability costs on the fine-link chains:
#                                          docs/bench/stability.csv, about 2 minutes)
#        scripts/bench.sh --cores [BASE]   (only this core's step cost against commit BASE's,
#                                          scripts/compare_cores.sh, into docs/bench/cores.csv)
#        scripts/bench.sh --kernel         (only the chain step against the minimum-work
#                                          kernel, bench/kernel_ratio.cpp: docs/bench/kernel.csv
#                                          and kernel.txt, about 3 minutes)
#        scripts/bench.sh --contact        (only what contact costs: a chain lying on a plane,
#                                          bench/contact_chain.cpp: docs/bench/contact.csv and
#                                          contact.txt, about 3 minutes)
#        scripts/bench.sh --self-collision (only what self-collision costs: a rope folded on
#                                          itself on a floor, bench/self_collision.cpp:
#                                          docs/bench/self_collision.csv and .txt, 2 minutes)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
QUICK=()
OUT="$ROOT/docs/bench"
ONLY_SCENES=0
if [[ "${1:-}" == "--quick" ]]; then
  QUICK=(--quick)
  OUT="$ROOT/build/bench"
elif [[ "${1:-}" == "--scenes" ]]; then
  ONLY_SCENES=1
elif [[ "${1:-}" == "--stability" ]]; then
  ONLY_SCENES=2
elif [[ "${1:-}" == "--kernel" ]]; then
  ONLY_SCENES=3
elif [[ "${1:-}" == "--contact" ]]; then
  ONLY_SCENES=4
elif [[ "${1:-}" == "--self-collision" ]]; then
  ONLY_SCENES=5
elif [[ "${1:-}" == "--cores" ]]; then
  exec bash "$ROOT/scripts/compare_cores.sh" ${2:-} --csv "$OUT/cores.csv"
fi
WITH_BENCH=1 bash "$ROOT/scripts/install_deps.sh"
LOG="$(mktemp)"
CP_BUILD_BENCH=ON bash "$ROOT/scripts/build.sh" >"$LOG" 2>&1 || { cat "$LOG"; exit 1; }
rm -f "$LOG"
BIN="$ROOT/build/ws/devel/lib/constrained_particles"
mkdir -p "$OUT"
# stamp NAME...: the line scripts/performance_page.py shows over docs/bench/NAME.csv's tables
HOW="\`bash scripts/bench.sh${1:+ $1}\` at $(/usr/bin/python3 "$ROOT/scripts/performance_page.py" --stamp "$ROOT")"
# a part that fails leaves its CSVs without a stamp rather than under an older run's
unstamp() {
  for name in "$@"; do
    rm -f "$OUT/$name.stamp"
  done
}
stamp() {
  for name in "$@"; do
    echo "$HOW" >"$OUT/$name.stamp"
  done
  # docs/*.md's generated blocks, from docs/bench only (a --quick run writes elsewhere)
  if [[ "$OUT" == "$ROOT/docs/bench" ]]; then
    /usr/bin/python3 "$ROOT/scripts/performance_page.py" "$ROOT"
  fi
}
if ((ONLY_SCENES == 3)); then
  unstamp kernel
  "$BIN/bench_kernel" --out "$OUT" | tee "$OUT/kernel.txt"
  stamp kernel
  exit 0
fi
if ((ONLY_SCENES == 4)); then
  unstamp contact
  "$BIN/bench_contact" --out "$OUT" | tee "$OUT/contact.txt"
  stamp contact
  exit 0
fi
if ((ONLY_SCENES == 5)); then
  unstamp self_collision
  "$BIN/bench_self_collision" --out "$OUT" | tee "$OUT/self_collision.txt"
  stamp self_collision
  exit 0
fi
if ((ONLY_SCENES == 2)); then
  unstamp stability
  "$BIN/constrained_particles_bench" stability --out "$OUT"
  stamp stability
  echo "wrote $OUT/stability.csv" >&2
  exit 0
fi
if ((ONLY_SCENES)); then
  unstamp scenes trees
  "$BIN/constrained_particles_bench" scenes --out "$OUT"
  /usr/bin/python3 "$ROOT/scripts/bench_report.py" "$OUT" >/dev/null
  stamp scenes trees
  echo "wrote $OUT/scenes.csv, $OUT/trees.csv and $OUT/summary.md" >&2
  exit 0
fi

unstamp work_precision orders scaling scenes trees kernel peers stability
# every peer's rows from this run only: one whose library is missing leaves none behind
rm -f "$OUT"/peers_*.csv
"$BIN/constrained_particles_bench" work_precision --out "$OUT" "${QUICK[@]}"
"$BIN/constrained_particles_bench" scaling --out "$OUT" "${QUICK[@]}"
"$BIN/constrained_particles_bench" scenes --out "$OUT" "${QUICK[@]}"
# the chain step against the minimum-work kernel (how far from the machine)
"$BIN/bench_kernel" --out "$OUT" "${QUICK[@]}" | tee "$OUT/kernel.txt"
# peers, side by side in the same run
"$BIN/constrained_particles_bench" peers --out "$OUT" "${QUICK[@]}"
"$BIN/constrained_particles_bench" stability --out "$OUT" "${QUICK[@]}"
for peer in bench_peer_ode bench_peer_mujoco; do
  if [[ -x "$BIN/$peer" ]]; then
    "$BIN/$peer" --out "$OUT" "${QUICK[@]}"
  else
    echo "$peer not built (its library is missing): skipped" >&2
  fi
done
/usr/bin/python3 "$ROOT/scripts/bench_report.py" "$OUT"
stamp work_precision orders scaling scenes trees kernel peers stability
echo "wrote $OUT" >&2
