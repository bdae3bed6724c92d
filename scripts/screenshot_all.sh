#!/usr/bin/env bash
# Screenshots every shipped scene (config/scenes/*.yaml) with scripts/screenshot.sh into OUTDIR
# (default build/screenshots) and checks each (scripts/check_screenshot.py: not black or empty,
# the whole scene in view). Prints a line per scene and exits 1 if any failed. About 20 s a scene.
# Usage: scripts/screenshot_all.sh [OUTDIR]
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
OUT="${1:-$ROOT/build/screenshots}"
failed=0
for file in "$ROOT"/config/scenes/*.yaml; do
  scene="$(basename "$file" .yaml)"
  if line="$(bash "$ROOT/scripts/screenshot.sh" "$scene" "$OUT/$scene.png" 2>&1 | tail -1)" &&
    [[ "$line" != *"cut off"* && "$line" != *"empty"* ]]; then
    echo "ok    $line"
  else
    echo "FAIL  $scene: $line"
    failed=1
  fi
done
exit "$failed"
