#!/usr/bin/env bash
# docs/testing.md's tier table: runs the fast tier (bash scripts/test.sh) and the long tier
# (bash scripts/test.sh --long), each timed on the wall clock with its (incremental) build, and
# sums the JUnit times of its gtests and rostests; writes docs/bench/tiers.csv with its stamp
# (command, commit, date) beside it, and scripts/performance_page.py fills the page's block.
# Usage: scripts/tier_times.sh    (about 12 minutes on 2 cores after a build)
# Exits non-zero if a tier failed; then nothing is written.
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
RESULTS="${CP_WORKSPACE:-$ROOT/build/ws}/build/test_results"
ROWS="$(mktemp)"
trap 'rm -f "$ROWS"' EXIT
for tier in fast long; do
  started=$(date +%s.%N)
  if [[ $tier == fast ]]; then
    counts=$(bash "$ROOT/scripts/test.sh" | tail -1)
  else
    counts=$(bash "$ROOT/scripts/test.sh" --long | tail -1)
  fi
  status=$?
  ended=$(date +%s.%N)
  echo "$tier tier: $counts"
  ((status == 0)) || { echo "tier_times: the $tier tier failed; nothing written" >&2; exit 1; }
  # the JUnit files' own times: gtest's <testsuites time>, rostest's <testsuite time>
  /usr/bin/python3 - "$RESULTS" "$tier" "$counts" "$started" "$ended" >>"$ROWS" <<'PY'
import pathlib, sys, xml.etree.ElementTree as ElementTree
results, tier, counts, started, ended = sys.argv[1:]
sums = {"gtest": 0.0, "rostest": 0.0}
for path in pathlib.Path(results).rglob("*.xml"):
    kind = path.name.split("-")[0]
    if kind in sums:
        sums[kind] += float(ElementTree.parse(path).getroot().get("time") or 0.0)
passed = counts.split()[0]
print(f"{tier},{passed},{float(ended) - float(started):.0f},{sums['gtest']:.0f},{sums['rostest']:.0f}")
PY
done
/usr/bin/python3 - "$ROOT" "$ROWS" <<'PY'
import csv, sys
sys.path.insert(0, sys.argv[1] + "/scripts")
from performance_page import write_measurement
rows = list(csv.reader(open(sys.argv[2])))
write_measurement(sys.argv[1], sys.argv[1] + "/docs/bench/tiers.csv",
                  ["tier", "tests_passed", "wall_s", "gtest_s", "rostest_s"], rows,
                  "`bash scripts/tier_times.sh`")
PY
