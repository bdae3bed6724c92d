#!/usr/bin/env bash
# Builds the tests and prints the measured figures of the hard cases (test/core/test_hard_cases.cpp,
# both tiers' cases), one "[hard case]" line each: the figures under docs/stability.md's "Hard
# cases" table. Exits non-zero if any hard case fails.
# Usage: scripts/hard_cases.sh [--csv FILE]
#   --csv FILE: also writes the lines there (case, figures) with the run's stamp beside it (FILE
#   with .stamp for .csv); in docs/bench, the page's generated block follows
#   (scripts/performance_page.py). A failed case writes nothing.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
CSV=""
if [[ "${1:-}" == "--csv" ]]; then
  [[ -n "${2:-}" ]] || { echo "--csv needs a file" >&2; exit 2; }
  CSV="$2"
fi
bash "$ROOT/scripts/build.sh" >/dev/null
(cd "$ROOT/build/ws" && make -C build test_hard_cases >/dev/null)
LINES="$(mktemp)"
trap 'rm -f "$LINES"' EXIT
"$ROOT/build/ws/devel/lib/constrained_particles/test_hard_cases" | grep -E "^\[hard case\]|FAILED|PASSED" |
  tee "$LINES"
grep -q "FAILED" "$LINES" && exit 1
if [[ -n "$CSV" ]]; then
  /usr/bin/python3 - "$ROOT" "$CSV" "$LINES" <<'PY'
import sys
sys.path.insert(0, sys.argv[1] + "/scripts")
from performance_page import write_measurement
rows = [line[len("[hard case] "):].rstrip("\n").split(": ", 1) for line in open(sys.argv[3])
        if line.startswith("[hard case] ")]
write_measurement(sys.argv[1], sys.argv[2], ["case", "figures"], rows,
                  f"`bash scripts/hard_cases.sh --csv {sys.argv[2]}`")
PY
fi
