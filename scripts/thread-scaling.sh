#!/usr/bin/env bash
# Two-thread scaling of grainflow (the foundation issue asks 2 threads >= 1.8x one), taken
# so that a shared, drifting machine hits both thread counts alike: the one-thread and the
# two-thread run of a state alternate in pairs, each pair gives its own ratio, and after
# every pair one round of the machine probe (scripts/stream-scaling.sh) measures what two
# cores give a streaming pass over a working set of the loose state's size in the same
# minute, and the core-to-core round trip around the two-thread run says where the host
# had put the two vCPUs (scripts/bench-common.sh).
#
#   bash scripts/thread-scaling.sh                       # loose and dense, Gear, 5 pairs
#   PAIRS=3 STATES=loose INTEGRATOR=velocity_verlet bash scripts/thread-scaling.sh
#
# Knobs: PAIRS [5], STATES ["loose dense"], INTEGRATOR [gear], STEPS [the case's own:
# 20,000 loose, 3,000 dense], SHARED [../shared], WORK [/var/tmp/dem-peers] (the harness's
# data files, prepared by shared/bench/lammps-hopper/run_lammps.sh the first time; LAMMPS:
# apt-get install -y lammps openmpi-bin). Prints every pair, the median pair ratio, the
# ratio of the medians, and the probes' median ratios (12 MiB stream, compute).
set -euo pipefail
source "$(dirname "$0")/bench-common.sh"
PAIRS=${PAIRS:-5}
STATES=${STATES:-"loose dense"}
INTEGRATOR=${INTEGRATOR:-gear}

for state in $STATES; do
  case $state in
    loose | dense) scene=cases/bench-hopper-$state.toml ;;
    *) echo "unknown state '$state' (expected loose or dense)" >&2; exit 2 ;;
  esac
  data=$(benchmark_state "$state" 50000)
  steps=()
  [[ -n ${STEPS:-} ]] && steps=(--steps "$STEPS")
  for pair in $(seq 1 "$PAIRS"); do
    line="$state $pair"
    for threads in 1 2; do
      if (( threads == 2 )); then before=$(core_round_trip); fi
      "$BIN" run "$scene" --threads "$threads" "${steps[@]}" --out "$OUT/t$threads" \
        --set "lammps.0.file=$data" --set "simulation.integrator=$INTEGRATOR" >/dev/null 2>&1
      rate=$(python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["particle_steps_per_s"])' \
        "$OUT/t$threads/summary.json")
      line="$line $rate"
    done
    # Where the host had the two vCPUs: the larger round trip of before and after.
    trip=$(round_trip_since "$before")
    probe=$(bash scripts/stream-scaling.sh 1)
    stream=$(sed -n 's/.*12 MiB: \([0-9.]*\)x.*/\1/p' <<< "$probe")
    compute=$(sed -n 's/.*compute: \([0-9.]*\)x.*/\1/p' <<< "$probe")
    echo "$line $stream $compute $trip" >> "$OUT/pairs.txt"
  done
done

python3 - "$OUT/pairs.txt" "$INTEGRATOR" "$NEAR_ROUND_TRIP_NS" <<'EOF'
import collections, statistics, sys
pairs = collections.defaultdict(list)
for line in open(sys.argv[1]):
    state, _, one, two, stream, compute, trip = line.split()
    pairs[state].append((float(one) / 1e6, float(two) / 1e6, float(stream), float(compute), float(trip)))
# Round trips below this (ns), before and after, count as the two vCPUs near each other
# (NEAR_ROUND_TRIP_NS of scripts/bench-common.sh).
NEAR = float(sys.argv[3])
print(f"# {sys.argv[2]}, M particle-steps/s; probes, one core against two: a 12 MiB streaming")
print("# pass (stream) and a loop with no memory traffic (compute); round trip: a cache line")
print("# passed between the two vCPUs, the larger of just before and just after the 2-thread run")
print("state  pair  1 thread  2 threads  2/1     stream  compute  round trip")
for state, rows in pairs.items():
    for k, (one, two, stream, compute, trip) in enumerate(rows, 1):
        print(f"{state:6s} {k:4d}  {one:8.2f}  {two:9.2f}  {two / one:.2f}x   {stream:.2f}x   "
              f"{compute:.2f}x   {trip:5.0f} ns")
    ones, twos = [r[0] for r in rows], [r[1] for r in rows]
    print(f"{state:6s} median pair ratio {statistics.median(r[1] / r[0] for r in rows):.2f}x, "
          f"ratio of medians {statistics.median(twos) / statistics.median(ones):.2f}x, "
          f"probes {statistics.median(r[2] for r in rows):.2f}x stream, "
          f"{statistics.median(r[3] for r in rows):.2f}x compute")
    near = [r[1] / r[0] for r in rows if r[4] < NEAR]
    if near:
        print(f"{state:6s} pairs with the vCPUs near each other (round trip < {NEAR:.0f} ns): {len(near)} of "
              f"{len(rows)}, median pair ratio {statistics.median(near):.2f}x")
EOF
