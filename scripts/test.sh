#!/usr/bin/env bash
# Builds and runs every test (core gtests and rostests), then prints "N passed, M failed"
# counted from the JUnit results. Exits non-zero on any failure, including a build failure.
# Arguments go to catkin_make (scripts/sanitize.sh passes compiler flags).
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
WS="${CP_WORKSPACE:-$ROOT/build/ws}"
RESULTS="$WS/build/test_results"

fail() {
  echo "$1" >&2
  echo "0 passed, 1 failed"
  exit 1
}

bash "$ROOT/scripts/build.sh" "$@" || fail "build failed"
(cd "$WS" && catkin_make tests -DPYTHON_EXECUTABLE=/usr/bin/python3 -j2) ||
  fail "building the tests failed"
rm -rf "$RESULTS"
# CP_CPU_HOG=1 (CI's second pass): the tests run beside one busy loop per core, as on a busy
# machine; the loops are ours and stopped by PID
HOGS=()
stop_hogs() { ((${#HOGS[@]})) && kill "${HOGS[@]}" 2>/dev/null; HOGS=(); }
trap stop_hogs EXIT
if [[ "${CP_CPU_HOG:-0}" == 1 ]]; then
  for _ in $(seq "$(nproc)"); do
    (while :; do :; done) &
    HOGS+=($!)
  done
  echo "running the tests beside ${#HOGS[@]} busy loops (CP_CPU_HOG=1)"
fi
# catkin_make run_tests exits 0 even when tests fail: the XML results decide
(cd "$WS" && catkin_make run_tests -DPYTHON_EXECUTABLE=/usr/bin/python3 -j2) ||
  fail "building or running the tests failed"
stop_hogs

/usr/bin/python3 "$ROOT/scripts/count_test_results.py" "$RESULTS"
