#!/usr/bin/env bash
# The full stress sweep of test/core/test_stability.cpp: the fast tier's 50 chains
# (StressSweep) and the long tier's 4 (LongStressSweep: pinned chains of 100 and 1,000
# particles, mass ratio 1e6, links of 1 mm and 1 cm: the stiff fallback carries them). About 7 minutes on a busy 2-core machine.
# Ends with gtest's verdict; exits non-zero on a failure.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/build.sh" >/dev/null
(cd "$ROOT/build/ws" && make -C build test_stability >/dev/null)
"$ROOT/build/ws/devel/lib/constrained_particles/test_stability" \
  --gtest_filter='*StressSweep.*'
