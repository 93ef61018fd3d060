#!/usr/bin/env bash
# How much two cores of this machine can give a memory-streaming loop: runs one copy of
# a streaming kernel (b[i] += c a[i] over two arrays, repeated) alone, then two copies at
# once, and prints the aggregate speed-up 2 t_1 / t_2 for a 16 MiB working set (inside
# the L3 of the machines we run on) and a 256 MiB one (DRAM). An upper bound, set by the
# machine, for the two-thread scaling of grainflow's memory-bound passes (docs/performance.md).
# Usage: scripts/stream-scaling.sh [ROUNDS]   (needs gcc)
set -euo pipefail
rounds=${1:-5}
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
cat > "$dir/stream.c" <<'C'
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}
int main(int argc, char **argv) {
    long n = atol(argv[1]);
    int reps = atoi(argv[2]);
    double *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b);
    for (long i = 0; i < n; i++) { a[i] = (double)i; b[i] = 0.0; }
    double t0 = now();
    for (int r = 0; r < reps; r++)
        for (long i = 0; i < n; i++) b[i] += 1.0001 * a[i];
    printf("%.4f %g\n", now() - t0, b[n / 2]);
    return 0;
}
C
gcc -O2 -o "$dir/stream" "$dir/stream.c"
one() { "$dir/stream" "$1" "$2" | cut -d' ' -f1; }
two() { ( "$dir/stream" "$1" "$2" & "$dir/stream" "$1" "$2"; wait ) | awk '{s += $1} END {printf "%.4f", s / 2}'; }
for round in $(seq "$rounds"); do
    line="round $round:"
    for set in "16 1048576 640" "256 16777216 40"; do
        read -r mib n reps <<< "$set"
        t1=$(one "$n" "$reps")
        t2=$(two "$n" "$reps")
        line="$line  ${mib} MiB: $(awk -v a="$t1" -v b="$t2" 'BEGIN {printf "%.2fx (%.3f s alone, %.3f s two at once)", 2 * a / b, a, b}')"
    done
    echo "$line"
done
