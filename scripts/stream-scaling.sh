#!/usr/bin/env bash
# What two cores of this machine give at all, without grainflow: the ceiling of the
# two-thread / one-thread ratio of a pass, set by the machine (docs/performance.md).
# Each probe does the same work once on one core, then split in two halves run at once
# on two cores, and prints the speed-up t_1 / t_2 (t_2: the slower half):
#   - 12 MiB: a streaming pass (b[i] += c a[i], vectorised as grainflow's passes are)
#     over a working set of the size of the loose benchmark state (50,000 particles),
#     which stays in the L3 cache: one core streams all of it, or two cores half each,
#     as a parallel pass over one array does;
#   - 256 MiB: the same from main memory;
#   - compute: a vectorised multiply-add loop with no memory traffic (what two busy
#     cores give compute-bound code: clock and power shared between them);
#   - swapped halves: two threads stream the 12 MiB set in halves, passes separated by a
#     barrier, once with each thread on its own half every pass and once with the halves
#     swapping threads every pass: how much slower a pass gets when its rows were last
#     written by the other core (why grainflow's passes keep one part per thread:
#     systems/src/team.rs).
# Usage: scripts/stream-scaling.sh [ROUNDS]   (needs gcc)
set -euo pipefail
rounds=${1:-5}
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
cat > "$dir/probe.c" <<'C'
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include <pthread.h>
#include <stdatomic.h>
static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}
/* Two threads, REPS passes of b += c a over halves of two arrays of N doubles, a barrier
   after each pass; SWAP: thread t takes half (t + pass) % 2 instead of half t. */
static long pn;
static int preps, pswap;
static double *pa, *pb;
static atomic_int arrived, generation;
static void barrier(void) {
    int g = atomic_load(&generation);
    if (atomic_fetch_add(&arrived, 1) == 1) {
        atomic_store(&arrived, 0);
        atomic_fetch_add(&generation, 1);
    } else {
        while (atomic_load(&generation) == g) {}
    }
}
static void *halves_worker(void *arg) {
    long t = (long)arg;
    for (int r = 0; r < preps; r++) {
        long half = pswap ? (t + r) % 2 : t;
        for (long i = half * pn / 2; i < (half + 1) * pn / 2; i++) pb[i] += 1.0001 * pa[i];
        barrier();
    }
    return 0;
}
/* probe stream N REPS: REPS passes of b += c a over two arrays of N doubles.
   probe compute REPS: REPS rounds of 16 independent multiply-adds, no memory.
   probe affinity N REPS SWAP: the two-thread passes above. */
int main(int argc, char **argv) {
    double t0, check = 0.0;
    if (argv[1][0] == 'a') {
        pn = atol(argv[2]);
        preps = atoi(argv[3]);
        pswap = atoi(argv[4]);
        pa = malloc(pn * sizeof *pa);
        pb = malloc(pn * sizeof *pb);
        for (long i = 0; i < pn; i++) { pa[i] = (double)i; pb[i] = 0.0; }
        pthread_t th[2];
        t0 = now();
        for (long t = 0; t < 2; t++) pthread_create(&th[t], 0, halves_worker, (void *)t);
        for (int t = 0; t < 2; t++) pthread_join(th[t], 0);
        check = pb[pn / 3];
    } else if (argv[1][0] == 's') {
        long n = atol(argv[2]);
        int reps = atoi(argv[3]);
        double *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b);
        for (long i = 0; i < n; i++) { a[i] = (double)i; b[i] = 0.0; }
        t0 = now();
        for (int r = 0; r < reps; r++)
            for (long i = 0; i < n; i++) b[i] += 1.0001 * a[i];
        check = b[n / 2];
    } else {
        long reps = atol(argv[2]);
        double x[16];
        for (int k = 0; k < 16; k++) x[k] = 1.0 + k * 1e-9;
        t0 = now();
        for (long r = 0; r < reps; r++)
            for (int k = 0; k < 16; k++) x[k] = x[k] * 0.9999999 + 1e-7;
        for (int k = 0; k < 16; k++) check += x[k];
    }
    printf("%.4f %g\n", now() - t0, check);
    return 0;
}
C
gcc -O3 -march=native -pthread -o "$dir/probe" "$dir/probe.c"
# alone ARGS... / halves ARGS...: seconds of one run, and of the slower of two at once.
alone() { "$dir/probe" "$@" | cut -d' ' -f1; }
halves() { ( "$dir/probe" "$@" & "$dir/probe" "$@"; wait ) | awk '$1 > t {t = $1} END {printf "%.4f", t}'; }
ratio() { awk -v a="$1" -v b="$2" 'BEGIN {printf "%.2fx (%.3f s one core, %.3f s two)", a / b, a, b}'; }
for round in $(seq "$rounds"); do
    line="round $round:"
    # MiB, doubles per array alone, passes
    for set in "12 786432 2000" "256 16777216 60"; do
        read -r mib n reps <<< "$set"
        t1=$(alone stream "$n" "$reps")
        t2=$(halves stream $((n / 2)) "$reps")
        line="$line  $mib MiB: $(ratio "$t1" "$t2")"
    done
    t1=$(alone compute 400000000)
    t2=$(halves compute 200000000)
    line="$line  compute: $(ratio "$t1" "$t2")"
    fixed=$(alone affinity 786432 2000 0)
    swapped=$(alone affinity 786432 2000 1)
    echo "$line  swapped halves: $(awk -v a="$swapped" -v b="$fixed" 'BEGIN {printf "%.2fx slower (%.3f s against %.3f s)", a / b, a, b}')"
done
