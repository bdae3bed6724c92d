#!/usr/bin/env bash
# Builds the package and runs the simulator: a short headless run of every built-in scenario.
# Usage: scripts/run.sh [simulated seconds per scenario, default 5]
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/build.sh" >/dev/null
exec "$ROOT/build/ws/devel/lib/constrained_particles/constrained_particles_demo" "${1:-5}"
