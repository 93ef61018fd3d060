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

# core_round_trip: prints the median round trip, in ns, of a cache line passed back and
# forth between two threads (on two cores: both spin), five tries of 100,000 round trips.
# On a shared virtual machine the host moves the two vCPUs between its cores, and the
# round trip says how far apart they are. On the Zen 5 of 2026-12-02 it ranged from 55 to
# 450 ns within minutes; loose-state two-thread runs (velocity Verlet, same binary) made
# 260-300 M particle-steps/s when the larger of the round trips just before and just after
# the run stayed below about 350 ns, and 205-232 M in most runs where it reached 370-450 ns
# (docs/performance.md). The benchmark scripts record it beside each two-thread run, and
# count a run whose round trips before and after both stay below NEAR_ROUND_TRIP_NS as
# one with its vCPUs near each other.
NEAR_ROUND_TRIP_NS=350
core_round_trip() {
  if [[ ! -x $OUT/round_trip ]]; then
    cat > "$OUT/round_trip.c" <<'C'
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <time.h>
#define ROUNDS 100000L
static _Atomic long line;
static void *echo(void *arg) {
    (void)arg;
    for (long i = 0; i < ROUNDS; i++) {
        while (atomic_load_explicit(&line, memory_order_acquire) != 2 * i + 1) {}
        atomic_store_explicit(&line, 2 * i + 2, memory_order_release);
    }
    return 0;
}
int main(void) {
    double ns[5];
    for (int k = 0; k < 5; k++) {
        atomic_store(&line, 0);
        pthread_t t;
        pthread_create(&t, 0, echo, 0);
        struct timespec a, b;
        clock_gettime(CLOCK_MONOTONIC, &a);
        for (long i = 0; i < ROUNDS; i++) {
            atomic_store_explicit(&line, 2 * i + 1, memory_order_release);
            while (atomic_load_explicit(&line, memory_order_acquire) != 2 * i + 2) {}
        }
        clock_gettime(CLOCK_MONOTONIC, &b);
        pthread_join(t, 0);
        ns[k] = ((b.tv_sec - a.tv_sec) * 1e9 + (b.tv_nsec - a.tv_nsec)) / ROUNDS;
    }
    for (int i = 0; i < 5; i++)
        for (int j = i + 1; j < 5; j++)
            if (ns[j] < ns[i]) { double s = ns[i]; ns[i] = ns[j]; ns[j] = s; }
    printf("%.0f\n", ns[2]);
    return 0;
}
C
    gcc -O2 -pthread -o "$OUT/round_trip" "$OUT/round_trip.c"
  fi
  "$OUT/round_trip"
}

# round_trip_since BEFORE: the larger of the round trip BEFORE (taken before a run) and
# one taken now.
round_trip_since() {
  local now
  now=$(core_round_trip)
  echo $(( $1 > now ? $1 : now ))
}
