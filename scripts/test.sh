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
rm -rf "$RESULTS"
# catkin_make run_tests exits 0 even when tests fail: the XML results decide
(cd "$WS" && catkin_make run_tests -DPYTHON_EXECUTABLE=/usr/bin/python3 -j2) ||
  fail "building or running the tests failed"

/usr/bin/python3 "$ROOT/scripts/count_test_results.py" "$RESULTS"
