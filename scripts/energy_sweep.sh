#!/usr/bin/env bash
# Runs the long tier's energy sweep (test/core/test_energy_sweep.cpp: every shipped scene x
# integrator x stabilisation, 60 s of sim time each at the default step settings) and writes
# its rows to docs/bench/energy_sweep.csv and its table to docs/energy_sweep.md
# (scripts/energy_sweep_table.py). Exits non-zero if the sweep fails.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/build.sh" >/dev/null
(cd "$ROOT/build/ws" && make -C build test_energy_sweep >/dev/null)
CSV="$ROOT/docs/bench/energy_sweep.csv"
STAMP="\`bash scripts/energy_sweep.sh\` at $(/usr/bin/python3 "$ROOT/scripts/performance_page.py" --stamp "$ROOT")"
rm -f "${CSV%.csv}.stamp"  # a failed sweep leaves no stamp over its rows
CP_ENERGY_SWEEP_CSV="$CSV" "$ROOT/build/ws/devel/lib/constrained_particles/test_energy_sweep" |
  grep -E "^\[energy sweep\]|FAILED|PASSED"
echo "$STAMP" >"${CSV%.csv}.stamp"
/usr/bin/python3 "$ROOT/scripts/energy_sweep_table.py" "$CSV" >"$ROOT/docs/energy_sweep.md"
/usr/bin/python3 "$ROOT/scripts/performance_page.py"  # docs/physics.md's summary of it
echo "wrote $CSV and $ROOT/docs/energy_sweep.md"
