# Sourced by the benchmark scripts: the paths, the release binary and the states of the
# LAMMPS hopper harness. Sets ROOT, SHARED, HARNESS, WORK, BIN (the release binary, built
# here) and OUT (a temporary directory, removed at exit), and works in ROOT.
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
SHARED=${SHARED:-$ROOT/../shared}
HARNESS=$SHARED/bench/lammps-hopper
WORK=${WORK:-/var/tmp/dem-peers}
cd "$ROOT"
cargo build --release --quiet
BIN=$ROOT/target/release/grainflow
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT

# benchmark_state STATE N: prints the path of the harness's data file of STATE (dense or
# loose) with N particles, which its run_lammps.sh prepares (with LAMMPS) the first time.
benchmark_state() {
  local data=$WORK/${1}_$2.data
  [[ -s $data ]] || WORK=$WORK N=$2 STATES=$1 REPS=0 bash "$HARNESS/run_lammps.sh" >/dev/null
  echo "$data"
}
