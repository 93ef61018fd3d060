#!/usr/bin/env bash
# Stability of the particle update over density ratios: cases/settling-sphere.toml at
# level 2 (3 cells per diameter) with nu = 1 and dt_F = 0.05, so that dt_F is 0.4-2.4
# times the particle response time tau = (m + rho_f V / 2) / (6 pi mu r), for both
# `coupling.update`s and rho_p / rho_f = 1.001, 1.05, 1.17, 2.65, 8, to t = 1 s. Prints one
# markdown row per run: exit code, the run's failure message (if any, shortened), the
# last velocity and the wall seconds with the load.
#
#   scripts/coupling-stability.sh
#   RATIOS="1.001 8" UPDATES=fluid_momentum scripts/coupling-stability.sh --set fluid.dt=0.02
set -uo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
cargo build --release --quiet
BIN=${BIN:-${CARGO_TARGET_DIR:-$ROOT/target}/release/grainflow}
RATIOS=${RATIOS:-"1.001 1.05 1.17 2.65 8"}
UPDATES=${UPDATES:-"prescribed fluid_momentum"}
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
echo "| update | rho_p/rho_f | exit | failure | last speed (cm/s) | wall s (load) |"
echo "|---|---|---|---|---|---|"
for upd in $UPDATES; do
  for r in $RATIOS; do
    dir="$OUT/$upd-$r"
    load=$(cut -d' ' -f1 /proc/loadavg)
    start=$(date +%s.%N)
    "$BIN" run cases/settling-sphere.toml --out "$dir" --set fluid.level=2 \
      --set fluid.viscosity=1.0 --set fluid.dt=0.05 --set coupling.update="$upd" \
      --set materials.0.density="$r" --until 1.0 --threads 2 "$@" > "$dir.log" 2>&1
    code=$?
    wall=$(echo "$(date +%s.%N) - $start" | bc)
    failure=$(grep -o 'unstable at step [0-9]*[^:]*: [^;]*' "$dir.log" | head -1 | cut -c1-90)
    speed=$(tail -1 "$dir/coupling.csv" | awk -F, '{printf "%.3g", sqrt($6*$6+$7*$7+$8*$8)}')
    printf "| %s | %s | %s | %s | %s | %.0f (%s) |\n" "$upd" "$r" "$code" "${failure:--}" "$speed" "$wall" "$load"
  done
done
