#!/usr/bin/env bash
# The contact benchmark of the friction models (issue 3): particle-steps per second on one
# thread with Hertz + tangential friction (mu_s = 0.5) + rolling resistance (mu_r = 0.1)
# against the frictionless rate, on the dense states of the small hopper (N = 20,000,
# cases/bench-hopper-small-dense.toml) and of the benchmark hopper (N = 50,000,
# cases/bench-hopper-dense.toml); the two runs of a state alternate, so that a drift of
# the machine hits both alike.
#
#   bash scripts/bench-friction.sh                 # both states, 7 runs each, 1,000 steps
#   REPS=3 STATES="small" bash scripts/bench-friction.sh
#
# Knobs: REPS [7], STEPS [1000], THREADS [1], STATES ["small dense"], SHARED [../shared],
# WORK [/var/tmp/dem-peers] (the harness's data files). The states are prepared by
# shared/bench/lammps-hopper/run_lammps.sh (LAMMPS: apt-get install -y lammps openmpi-bin)
# the first time. Prints the medians (with the range), their ratio, and the memory per
# contact of the friction runs from summary.json.
set -euo pipefail
source "$(dirname "$0")/bench-common.sh"
REPS=${REPS:-7}
STEPS=${STEPS:-1000}
THREADS=${THREADS:-1}
STATES=${STATES:-"small dense"}
FRICTION=(--set materials.0.friction=0.5 --set materials.0.rolling_friction=0.1)


for state in $STATES; do
  case $state in
    small) n=20000; scene=cases/bench-hopper-small-dense.toml ;;
    dense) n=50000; scene=cases/bench-hopper-dense.toml ;;
    *) echo "unknown state '$state' (expected small or dense)" >&2; exit 2 ;;
  esac
  data=$(benchmark_state dense "$n")
  for rep in $(seq 1 "$REPS"); do
    for kind in friction frictionless; do
      args=()
      [[ $kind == friction ]] && args=("${FRICTION[@]}")
      "$BIN" run "$scene" --threads "$THREADS" --steps "$STEPS" --out "$OUT/$kind" \
        --set "lammps.0.file=$data" "${args[@]}" >/dev/null 2>&1
      python3 - "$OUT/$kind/summary.json" "$state" "$kind" >> "$OUT/runs.txt" <<'EOF'
import json, sys
s = json.load(open(sys.argv[1]))
print(sys.argv[2], sys.argv[3], s["particle_steps_per_s"], s["contact_store_bytes_per_pair"])
EOF
    done
  done
done

python3 - "$OUT/runs.txt" "$THREADS" "$STEPS" <<'EOF'
import collections, statistics, sys
runs = collections.defaultdict(list)
memory = {}
for line in open(sys.argv[1]):
    state, kind, rate, mem = line.split()
    runs[state, kind].append(float(rate) / 1e6)
    if kind == "friction":
        memory[state] = f"{float(mem):.1f}"
print(f"# {sys.argv[2]} thread(s), {sys.argv[3]} steps, M particle-steps/s: median (range) of the runs")
print("state    friction+rolling        frictionless            ratio   contact store B/pair")
for state in dict.fromkeys(s for s, _ in runs):
    f, n = runs[state, "friction"], runs[state, "frictionless"]
    cell = lambda v: f"{statistics.median(v):6.2f} ({min(v):.2f}-{max(v):.2f})"
    ratio = statistics.median(f) / statistics.median(n)
    print(f"{state:8s} {cell(f):23s} {cell(n):23s} {100 * ratio:5.1f} %  {memory.get(state, '-')}")
EOF
