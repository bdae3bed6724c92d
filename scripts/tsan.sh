#!/usr/bin/env bash
# Builds the package with ThreadSanitizer in build/tsan and runs the rostests there: the node's
# physics thread, ROS callbacks (services, publishing timers) and dynamic_reconfigure interleave
# while the tests drive it, the fuzz test hardest. Any race report stops the node (so its test
# fails) and is kept in build/tsan/reports/.
# Ends with "races: R" and "N passed, M failed"; exits non-zero on any race or failure.
# Takes about 10 minutes on 2 cores. Not part of scripts/test.sh.
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export CP_WORKSPACE="$ROOT/build/tsan"
export BUILD_TYPE=RelWithDebInfo
REPORTS="$CP_WORKSPACE/reports"
FLAGS="-fsanitize=thread -fno-omit-frame-pointer"
bash "$ROOT/scripts/build.sh" -DCMAKE_CXX_FLAGS="$FLAGS" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=thread" \
  -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=thread" >"$CP_WORKSPACE.log" 2>&1 ||
  { tail -50 "$CP_WORKSPACE.log"; echo "build failed"; exit 1; }
rm -rf "$REPORTS" "$CP_WORKSPACE/build/test_results"
mkdir -p "$REPORTS"
# ROS's own libraries are not instrumented: their accesses are invisible, their locks are not
export TSAN_OPTIONS="ignore_noninstrumented_modules=1:halt_on_error=1:exitcode=66:second_deadlock_stack=1:log_path=$REPORTS/tsan:suppressions=$ROOT/scripts/tsan_suppressions.txt"
(cd "$CP_WORKSPACE" && catkin_make run_tests_constrained_particles_rostest -DPYTHON_EXECUTABLE=/usr/bin/python3 -j2 \
  >>"$CP_WORKSPACE.log" 2>&1)
races=$(cat "$REPORTS"/tsan.* 2>/dev/null | grep -c "WARNING: ThreadSanitizer" || true)
for report in "$REPORTS"/tsan.*; do
  [[ -e "$report" ]] && { echo "== $report"; head -60 "$report"; }
done
echo "races: $races"
/usr/bin/python3 "$ROOT/scripts/count_test_results.py" "$CP_WORKSPACE/build/test_results"
status=$?
((races == 0)) && exit $status
exit 1
