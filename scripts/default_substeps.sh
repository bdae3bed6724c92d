#!/usr/bin/env bash
# The peer chain (n particles, 0.1 m links, 0.1 kg, first pinned, released along +x, dt = 1 ms,
# 10 s) and a chain of 20 pulled taut between two pins under gravity, run by the headless demo at
# the node's default settings (max_substeps 1024), where docs/performance.md's peer table runs each integrator
# unsplit (the unsplit_ cases: max_substeps 1). Prints each run's last line: energy drift over
# 10 s and the largest link error.
# Usage: scripts/default_substeps.sh [--csv FILE] [case ...]
#   cases: peer_<n>_<integrator>, unsplit_<n>_<integrator>, taut_chain_gravity
# (default: the semi-implicit Euler chains of 10 and 100, Verlet on 100, the taut chain)
# --csv FILE: also writes the runs there and the stamp beside it (FILE with .stamp for .csv);
#   in docs/bench, docs/physics.md's generated block follows (scripts/performance_page.py)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/build.sh" >/dev/null
DEMO="$ROOT/build/ws/devel/lib/constrained_particles/constrained_particles_demo"
DIR="$(mktemp -d)"
trap 'rm -rf "$DIR"' EXIT

peer_chain() {  # prefix n integrator max_substeps
  cat >"$DIR/$1_$2_$3.yaml" <<SCENE
name: $1_$2_$3
description: "the peer chain: $2 particles, 0.1 m links, 0.1 kg, pinned, released along +x"
chains:
  - {particles: $2, link_length: 0.1, particle_mass: 0.1, start: [0, 0, 0], direction: [1, 0, 0], pin_first: true}
forces:
  - {type: gravity}
solver: {integrator: $3, dt: 0.001, max_substeps: $4}
SCENE
}
taut_chain() {  # 20 particles in a straight line, pinned at both ends, 0.1 m links, rk4
  {
    echo 'name: taut_chain_gravity'
    echo 'description: "a chain of 20 pulled taut between two pins, under gravity"'
    echo 'particles:'
    for i in $(seq 0 19); do echo "  - {mass: 0.1, position: [$(awk "BEGIN{print $i*0.1}"), 0, 0]}"; done
    echo 'constraints:'
    echo '  - {type: pin, particle: 0}'
    echo '  - {type: pin, particle: 19}'
    for i in $(seq 0 18); do echo "  - {type: link, first: $i, second: $((i + 1)), length: 0.1}"; done
    echo 'forces:'
    echo '  - {type: gravity}'
    echo 'solver: {integrator: rk4, dt: 0.001}'
  } >"$DIR/taut_chain_gravity.yaml"
}

CSV=""
if [[ "${1:-}" == "--csv" ]]; then
  [[ -n "${2:-}" ]] || { echo "--csv needs a file" >&2; exit 2; }
  CSV="$2"
  shift 2
fi
ARGS=("$@")
CASES=("$@")
((${#CASES[@]})) || CASES=(peer_10_semi_implicit_euler peer_100_semi_implicit_euler
  peer_100_velocity_verlet taut_chain_gravity)
for case in "${CASES[@]}"; do
  if [[ "$case" =~ ^peer_([0-9]+)_(.+)$ ]]; then
    peer_chain peer "${BASH_REMATCH[1]}" "${BASH_REMATCH[2]}" 1024
  elif [[ "$case" =~ ^unsplit_([0-9]+)_(.+)$ ]]; then
    peer_chain unsplit "${BASH_REMATCH[1]}" "${BASH_REMATCH[2]}" 1
  elif [[ "$case" == taut_chain_gravity ]]; then
    taut_chain
  else
    echo "unknown case '$case': peer_<n>_<integrator>, unsplit_<n>_<integrator> or" \
      "taut_chain_gravity" >&2
    exit 2
  fi
  line="$("$DEMO" 10 "$DIR/$case.yaml" | tail -2 | head -1)"
  echo "$case: $line"
  echo "$case: $line" >>"$DIR/lines.txt"
done
if [[ -n "$CSV" ]]; then
  # the demo's last line: "t = T s  energy = E J (drift D J)  max error = P m, V m/s"
  /usr/bin/python3 - "$ROOT" "$CSV" "$DIR/lines.txt" "${ARGS[@]}" <<'PY'
import re, shlex, sys
sys.path.insert(0, sys.argv[1] + "/scripts")
from performance_page import write_measurement
LINE = re.compile(r"^(\S+): t = (\S+) s .*\(drift (\S+) J\)\s+max error = (\S+) m, (\S+) m/s")
rows = [LINE.match(line).groups() for line in open(sys.argv[3])]
write_measurement(sys.argv[1], sys.argv[2],
                  ["case", "sim_seconds", "energy_drift_J", "max_position_error_m",
                   "max_velocity_error_m_per_s"], rows,
                  "`" + shlex.join(["bash", "scripts/default_substeps.sh", "--csv", sys.argv[2],
                                    *sys.argv[4:]]) + "`")
PY
fi
