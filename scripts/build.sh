#!/usr/bin/env bash
# Builds the package in build/ws (a catkin workspace whose src/ links to this checkout).
# Usage: scripts/build.sh [extra catkin_make arguments...]
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/install_deps.sh"

WS="$ROOT/build/ws"
mkdir -p "$WS/src"
ln -sfn "$ROOT" "$WS/src/constrained_particles"
# the system python has catkin_pkg; a pyenv python3 first in PATH does not
cd "$WS"
catkin_make -DPYTHON_EXECUTABLE=/usr/bin/python3 -DCMAKE_BUILD_TYPE="${BUILD_TYPE:-Release}" "$@"
