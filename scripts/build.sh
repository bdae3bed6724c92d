#!/usr/bin/env bash
# Builds the package in build/ws (a catkin workspace whose src/ links to this checkout), or in
# $CP_WORKSPACE if set.
# Usage: scripts/build.sh [extra catkin_make arguments...]
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/install_deps.sh"

WS="${CP_WORKSPACE:-$ROOT/build/ws}"
PKG="$WS/src/constrained_particles"
# link each top-level entry but build/: a link to the root would let rosrun's and rostest's
# searches of the package loop through build/ws/src
[[ -L "$PKG" ]] && rm "$PKG"
mkdir -p "$PKG"
for entry in "$ROOT"/* "$ROOT"/.clang-format; do
  [[ "$(basename "$entry")" == build ]] && continue
  ln -sfn "$entry" "$PKG/$(basename "$entry")"
done
find "$PKG" -maxdepth 1 -xtype l -delete  # entries since removed
# the system python has catkin_pkg; a pyenv python3 first in PATH does not
cd "$WS"
# the benchmark and its peers only when asked (CP_BUILD_BENCH=ON, as scripts/bench.sh sets it)
catkin_make -DPYTHON_EXECUTABLE=/usr/bin/python3 -DCMAKE_BUILD_TYPE="${BUILD_TYPE:-Release}" \
  -DCP_BUILD_BENCH="${CP_BUILD_BENCH:-OFF}" "$@"
