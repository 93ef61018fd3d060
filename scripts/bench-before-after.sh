#!/usr/bin/env bash
# Throughput of two grainflow binaries on the benchmark hopper states, in alternating
# runs (A, B, A, B, ...), so that a machine whose speed drifts hits both alike: the
# check that a change keeps the speed (particle-steps/s, medians, and B / A per pair).
#
#   bash scripts/bench-before-after.sh OLD_BINARY NEW_BINARY
#
# Knobs: REPS [5], STEPS [the scene's: dense 3,000, loose 20,000], THREADS [1], STATES ["dense loose"], INTEGRATOR [gear], WORK
# [/var/tmp/dem-peers] (the harness's data files: scripts/bench-vs-lammps.sh prepares
# them), WAIT_IDLE / IDLE_PCT (the harness's wait for an idle machine before each run).
set -euo pipefail
A=$1
B=$2
REPS=${REPS:-5}
THREADS=${THREADS:-1}
STATES=${STATES:-"dense loose"}
INTEGRATOR=${INTEGRATOR:-gear}
STEPS=${STEPS:-}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
WORK=${WORK:-/var/tmp/dem-peers}
source "${SHARED:-$ROOT/../shared}/bench/lammps-hopper/common.sh"
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
rate() {
  "$1" run "$ROOT/cases/bench-hopper-$2.toml" --threads "$THREADS" --out "$OUT/run" ${STEPS:+--steps "$STEPS"} \
    --set "simulation.integrator=\"$INTEGRATOR\"" --set "lammps.0.file=\"$WORK/${2}_50000.data\"" >/dev/null 2>&1
  python3 -c "import json,sys;print(json.load(open(sys.argv[1]))['particle_steps_per_s'])" "$OUT/run/summary.json"
}
{
printf "state\trep\tA\tB\tB/A\tbusy_pct\n"
for st in $STATES; do
  for rep in $(seq 1 "$REPS"); do
    wait_idle
    a=$(rate "$A" "$st")
    wait_idle
    b=$(rate "$B" "$st")
    printf "%s\t%s\t%.4e\t%.4e\t%.4f\t%s\n" "$st" "$rep" "$a" "$b" "$(python3 -c "print($b/$a)")" "$BUSY"
  done
done
} | tee "$OUT/pairs.tsv"
python3 - "$OUT/pairs.tsv" <<'PY'
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1]), delimiter="\t"))
for st in sorted({r["state"] for r in rows}):
    r = [x for x in rows if x["state"] == st]
    a = statistics.median(float(x["A"]) for x in r)
    b = statistics.median(float(x["B"]) for x in r)
    q = statistics.median(float(x["B/A"]) for x in r)
    print(f"{st}: A {a/1e6:.3f} M, B {b/1e6:.3f} M particle-steps/s (medians of {len(r)}); median B/A per pair {q:.4f}")
PY
