#!/usr/bin/env bash
# Step cost of this core against an earlier commit's, in one process (bench/compare_cores.cpp):
# the earlier core's sources are taken from git, renamed to namespace cp_old, and compiled with
# this one's into one program, both with the Release flags (-O3 -DNDEBUG). Prints a table;
# with --csv FILE also writes it, and its stamp (command, commit, date) beside it as FILE.stamp,
# which scripts/performance_page.py shows over it. About 2 minutes to build and 1 to run on 2 cores.
# Usage: scripts/compare_cores.sh [BASE] [--quick] [--csv FILE]
#   BASE: the commit to compare with (default 6ecca4e, the core before the Model/Data redesign;
#   7861304 is the core before the fused chain stages)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BASE=6ecca4e
if [[ $# -gt 0 && "$1" != --* ]]; then
  BASE="$1"
  shift
fi
bash "$ROOT/scripts/install_deps.sh"
OUT="$ROOT/build/compare"
OLD="$OUT/old"
rm -rf "$OLD"
mkdir -p "$OLD"
git -C "$ROOT" archive "$BASE" include/constrained_particles/core src/core | tar -x -C "$OLD"
mv "$OLD/include/constrained_particles" "$OLD/include/cp_old"
find "$OLD" -type f \( -name '*.hpp' -o -name '*.cpp' \) -exec sed -i \
  -e 's|constrained_particles/core/|cp_old/core/|g' \
  -e 's|namespace constrained_particles|namespace cp_old|g' \
  -e 's|constrained_particles::|cp_old::|g' {} +
FLAGS=(-std=c++17 -O3 -DNDEBUG -I/usr/include/eigen3)
# one object per source, two at a time
objects=()
build() {  # build OBJECT SOURCE INCLUDES...
  local object="$1" source="$2"
  shift 2
  g++ "${FLAGS[@]}" "$@" -c "$source" -o "$object"
}
rm -rf "$OUT/new_objects" "$OUT/old_objects"
mkdir -p "$OUT/new_objects" "$OUT/old_objects"
pids=()
for source in "$ROOT"/src/core/*.cpp "$ROOT"/src/core/*/*.cpp; do
  object="$OUT/new_objects/$(echo "${source#$ROOT/src/core/}" | tr / _).o"
  objects+=("$object")
  build "$object" "$source" -I"$ROOT/include" -I"$ROOT/src/core" &
  pids+=($!)
  ((${#pids[@]} >= 2)) && { wait "${pids[0]}"; pids=("${pids[@]:1}"); }
done
# later cores keep integrators and solves in subfolders, with private headers beside them
for source in "$OLD"/src/core/*.cpp "$OLD"/src/core/*/*.cpp; do
  [[ -e "$source" ]] || continue
  object="$OUT/old_objects/$(echo "${source#$OLD/src/core/}" | tr / _).o"
  objects+=("$object")
  build "$object" "$source" -I"$OLD/include" -I"$OLD/src/core" &
  pids+=($!)
  ((${#pids[@]} >= 2)) && { wait "${pids[0]}"; pids=("${pids[@]:1}"); }
done
wait
# cores before the integrator table named integrators by an enum (parseIntegrator)
OLD_API=()
grep -rq parseIntegrator "$OLD/include" && OLD_API=(-DCP_OLD_PARSE_INTEGRATOR)
g++ "${FLAGS[@]}" "${OLD_API[@]}" -I"$ROOT/include" -I"$OLD/include" \
  "$ROOT/bench/compare_cores.cpp" "${objects[@]}" -o "$OUT/compare_cores"
echo "comparing $(git -C "$ROOT" rev-parse --short HEAD) (new) with $BASE (old)" >&2
"$OUT/compare_cores" "$@"
args=("$@")
for ((i = 0; i + 1 < ${#args[@]}; ++i)); do
  if [[ "${args[i]}" == --csv ]]; then
    echo "\`bash scripts/compare_cores.sh $BASE $*\` (old: $(git -C "$ROOT" rev-parse --short \
      "$BASE")) at $(python3 "$ROOT/scripts/performance_page.py" --stamp "$ROOT")" \
      >"${args[i + 1]%.csv}.stamp"
    # into docs/bench: the pages' generated blocks follow (test_docs checks they match)
    if [[ "$(cd "$(dirname "${args[i + 1]}")" && pwd)" == "$ROOT/docs/bench" ]]; then
      python3 "$ROOT/scripts/performance_page.py" "$ROOT"
    fi
  fi
done
