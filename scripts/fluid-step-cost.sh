#!/usr/bin/env bash
# The cost of a fluid step at a CFL number U dt/h of about 0.5-1, on 2 threads: the seed's
# sedimentation box as a fluid-only channel (cases/channel-10x2x2.toml, inflow peak
# 1 cm/s) and the single settling sphere (cases/sedimentation-single.toml with
# rho/rho_f = 1.2: 8 cm/s at t = 0.1, 12 at t = 0.3), at levels 3 and 4. Prints one
# markdown row per case: the medians over REPS runs (alternating cases) of the wall
# seconds of a fluid step (`median_step_s` of summary.json, the median over the run's
# steps, which leaves out the first steps' allocations; the mean beside it), the multigrid cycles per
# step, the momentum and pressure seconds per step, ns per DOF per step and per cycle
# (momentum: per face and component cycle; pressure: per cell), the load (`uptime`)
# before each run and the sphere's velocity over the last tenth of the run.
#
#   scripts/fluid-step-cost.sh                  # all cases, REPS=3
#   REPS=1 CASES="ch3 sed3" scripts/fluid-step-cost.sh
#   scripts/fluid-step-cost.sh --set fluid.scheme=fractional_step   # extra --set for every run
#
# Cases: ch3 / ch4 (channel, level 3 dt 0.1 / level 4 dt 0.05: U dt/h = 1, 8 / 6 steps
# from rest), sed3 / sed4 (sphere, level 3 dt 0.0075 to t = 0.3, 40 steps, U dt/h up to
# 0.9 / level 4 dt 0.005 to t = 0.1, 20 steps, up to about 0.8; from rest; DEM dt 1e-5).
# sed3h / sed4h: the same at half the fluid step (80 / 40 steps, U dt/h up to 0.45 / 0.4),
# for the one-substep schemes (`--set fluid.scheme=backward_euler`).
# The binary: $BIN, or $CARGO_TARGET_DIR (or target)/release/grainflow.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
cargo build --release --quiet
BIN=${BIN:-${CARGO_TARGET_DIR:-$ROOT/target}/release/grainflow}
REPS=${REPS:-3}
CASES=${CASES:-"ch3 ch4 sed3 sed4"}
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT

# run_case NAME DIR: one run of case NAME into DIR (extra arguments of the script appended)
run_case() {
  local name=$1 dir=$2
  shift 2
  case $name in
    ch3) "$BIN" run cases/channel-10x2x2.toml --set fluid.level=3 --set fluid.dt=0.1 \
           --set simulation.dt=0.1 --steps 8 --threads 2 --out "$dir" "$@" ;;
    ch4) "$BIN" run cases/channel-10x2x2.toml --set fluid.level=4 --set fluid.dt=0.05 \
           --set simulation.dt=0.05 --steps 6 --threads 2 --out "$dir" "$@" ;;
    sed3) "$BIN" run cases/sedimentation-single.toml --set materials.0.density=1.2 \
           --set fluid.level=3 --set fluid.dt=0.0075 --set simulation.dt=1e-5 \
           --set simulation.output_interval=1 --until 0.3 --threads 2 --out "$dir" "$@" ;;
    sed4) "$BIN" run cases/sedimentation-single.toml --set materials.0.density=1.2 \
           --set fluid.level=4 --set fluid.dt=0.005 --set simulation.dt=1e-5 \
           --set simulation.output_interval=1 --until 0.1 --threads 2 --out "$dir" "$@" ;;
    sed3h) "$BIN" run cases/sedimentation-single.toml --set materials.0.density=1.2 \
           --set fluid.level=3 --set fluid.dt=0.00375 --set simulation.dt=1e-5 \
           --set simulation.output_interval=1 --until 0.3 --threads 2 --out "$dir" "$@" ;;
    sed4h) "$BIN" run cases/sedimentation-single.toml --set materials.0.density=1.2 \
           --set fluid.level=4 --set fluid.dt=0.0025 --set simulation.dt=1e-5 \
           --set simulation.output_interval=1 --until 0.1 --threads 2 --out "$dir" "$@" ;;
    *) echo "unknown case $name" >&2; exit 1 ;;
  esac >/dev/null 2>&1
}

for rep in $(seq 1 "$REPS"); do
  for name in $CASES; do
    load=$(uptime | sed 's/.*load average: //' | cut -d, -f1)
    run_case "$name" "$OUT/$name-$rep" "$@"
    echo "$load" > "$OUT/$name-$rep/load"
  done
done

python3 - "$OUT" "$REPS" $CASES <<'PY'
import json, statistics, sys
out, reps, cases = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
coarse_cells = 25 * 5 * 5
print("| case | level | DOFs | dt | steps | s/step (median step) | runs | mean s/step | loads | momentum cycles/step | pressure cycles/step | momentum s/step | pressure s/step | ns/DOF/step | momentum ns/face/cycle | pressure ns/cell/cycle | sphere u_x end (cm/s) |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
for name in cases:
    runs = []
    for r in range(1, reps + 1):
        d = f"{out}/{name}-{r}"
        s = json.load(open(f"{d}/summary.json"))
        runs.append((s, open(f"{d}/load").read().strip()))
    step = lambda s: s["fluid"].get("median_step_s", s["fluid"]["mean_step_s"])
    med = sorted(runs, key=lambda x: step(x[0]))[(reps - 1) // 2][0]
    f = med["fluid"]
    cells = coarse_cells * 8 ** (f["level"] - 1)
    faces = (f["dofs"] - cells) / 3
    mc, pc = f["momentum"]["cycles_per_step"], f["pressure"]["cycles_per_step"]
    nan = float("nan")  # binaries before the split of the seconds
    ms, ps = f["momentum"].get("seconds_per_step", nan), f["pressure"].get("seconds_per_step", nan)
    obs = med.get("observables") or {}
    v = obs.get("terminal_velocity_vector")
    print(f"| {name} | {f['level']} | {f['dofs']:,} | {f['dt']:g} | {f['steps']} | **{step(med):.3f}** | "
          f"{', '.join('%.3f' % step(x[0]) for x in runs)} | {f['mean_step_s']:.3f} | {', '.join(x[1] for x in runs)} | "
          f"{mc:.1f} | {pc:.1f} | {ms:.3f} | {ps:.3f} | {step(med) / f['dofs'] * 1e9:.0f} | "
          f"{ms / max(mc, 1e-9) / faces * 1e9:.1f} | {ps / max(pc, 1e-9) / cells * 1e9:.1f} | "
          f"{'-' if v is None else '%.3f' % v[0]} |")
PY
