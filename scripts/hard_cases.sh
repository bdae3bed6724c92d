#!/usr/bin/env bash
# Builds the tests and prints the measured figures of the hard cases (test/core/test_hard_cases.cpp),
# the source of docs/stability.md's "Hard cases" table. Exits non-zero if any hard case fails.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/build.sh" >/dev/null
(cd "$ROOT/build/ws" && make -C build test_hard_cases >/dev/null)
"$ROOT/build/ws/devel/lib/constrained_particles/test_hard_cases" | grep -E "^\[hard case\]|FAILED|PASSED"
