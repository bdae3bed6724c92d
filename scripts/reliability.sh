#!/usr/bin/env bash
# docs/reliability.md's table: runs each part's own command and keeps its result line in
# docs/bench/reliability_<part>.txt with the run's stamp (command, commit, date) beside it as
# .stamp; scripts/performance_page.py then fills the page's generated block from them.
# Usage: scripts/reliability.sh [part ...]   (default: every part, about 30 minutes on 2 cores)
#   fuzz_services  10,000 service calls (rostest fuzz_services.test), about 1 minute
#   fuzz           the core under libFuzzer + ASan + UBSan for 300 s (scripts/fuzz.sh 300)
#   tsan           every rostest under ThreadSanitizer (scripts/tsan.sh), 15 to 25 minutes
#   realtime       1,000 and 20,000 particles beside a busy loop (scripts/realtime_load.sh)
# A part that fails leaves no result and no stamp (its old ones are removed) and makes the
# script exit non-zero after the other parts ran; the pages are refilled after each part. Run it on an otherwise idle machine: the
# realtime part measures jitter.
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
OUT="$ROOT/docs/bench"
PARTS=("$@")
((${#PARTS[@]})) || PARTS=(fuzz_services fuzz tsan realtime)
STAMP="$(/usr/bin/python3 "$ROOT/scripts/performance_page.py" --stamp "$ROOT")"
LOG="$(mktemp -d)"
trap 'rm -rf "$LOG"' EXIT
status=0

run_part() {  # part: runs it, prints its result lines (the ones the page shows) on stdout
  case "$1" in
    fuzz_services)
      bash "$ROOT/scripts/build.sh" >"$LOG/build.log" 2>&1 || { tail -30 "$LOG/build.log" >&2; return 1; }
      (
        set +u
        source "$ROOT/build/ws/devel/setup.bash"
        CP_FUZZ_SUMMARY="$LOG/fuzz_services_summary.txt" rostest constrained_particles \
          fuzz_services.test >"$LOG/rostest.log" 2>&1
      ) || { tail -40 "$LOG/rostest.log" >&2; return 1; }
      cat "$LOG/fuzz_services_summary.txt"
      ;;
    fuzz) bash "$ROOT/scripts/fuzz.sh" 300 | grep "^fuzz:" | sed 's/ (log: .*)//' ;;
    tsan) bash "$ROOT/scripts/tsan.sh" | grep -E "^races: |passed, .* failed$" ;;
    realtime) bash "$ROOT/scripts/realtime_load.sh" | grep -E "particles, " ;;
    *)
      echo "unknown part '$1': fuzz_services, fuzz, tsan or realtime" >&2
      return 2
      ;;
  esac
}

for part in "${PARTS[@]}"; do
  # the old result stands while the part runs (the tsan part runs the docs test, which checks
  # the page against these files), and goes when the part fails
  echo "reliability: $part ..." >&2
  if run_part "$part" >"$LOG/$part.txt" && [[ -s "$LOG/$part.txt" ]]; then
    cp "$LOG/$part.txt" "$OUT/reliability_$part.txt"
    echo "\`bash scripts/reliability.sh $part\` at $STAMP" >"$OUT/reliability_$part.stamp"
    cat "$LOG/$part.txt"
  else
    rm -f "$OUT/reliability_$part.txt" "$OUT/reliability_$part.stamp"
    echo "reliability: $part failed" >&2
    status=1
  fi
  /usr/bin/python3 "$ROOT/scripts/performance_page.py"
done
exit $status
