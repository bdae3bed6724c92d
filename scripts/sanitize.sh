#!/usr/bin/env bash
# Builds the package with AddressSanitizer + UndefinedBehaviorSanitizer in build/asan and runs
# the fast tier there (core gtests and the rostests, whose node is then instrumented too;
# --long: the long tier). Any sanitizer report aborts the test that triggered it, so it counts
# as failed.
# Ends with "N passed, M failed"; exits non-zero on any failure.
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
FLAGS="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer"
export CP_WORKSPACE="$ROOT/build/asan"
export BUILD_TYPE=RelWithDebInfo
# leaks too; roscpp keeps a few process-lifetime allocations, suppressed by library name
export ASAN_OPTIONS="halt_on_error=1:detect_leaks=1"
export LSAN_OPTIONS="suppressions=$ROOT/scripts/lsan_suppressions.txt:print_suppressions=0"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
exec bash "$ROOT/scripts/test.sh" "$@" -DCP_BUILD_BENCH=OFF -DCMAKE_CXX_FLAGS="$FLAGS" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=address,undefined"
