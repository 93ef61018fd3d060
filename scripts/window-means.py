#!/usr/bin/env python3
"""Window means of a particle's settling velocity (-v_z) from `coupling.csv` of runs.

    scripts/window-means.py RUN_DIR [RUN_DIR ...] [--id N] [--windows 0.1-0.2,0.2-0.3]

Prints one markdown row per run: the mean of -v_z over the records (one per fluid step)
whose time lies in each window, in the run's velocity unit. The default windows are
those of docs/coupling.md ("Settling sphere"): 0.1-0.2, 0.2-0.3, 0.3-0.4, 0.35-0.45.
"""
import argparse
import csv
import sys

p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
p.add_argument("runs", nargs="+")
p.add_argument("--id", type=int, default=0)
p.add_argument("--windows", default="0.1-0.2,0.2-0.3,0.3-0.4,0.35-0.45")
a = p.parse_args()
windows = [tuple(float(x) for x in w.split("-")) for w in a.windows.split(",")]
print("| run | " + " | ".join(f"t = {lo:g}-{hi:g}" for lo, hi in windows) + " |")
print("|---" * (len(windows) + 1) + "|")
for run in a.runs:
    try:
        rows = [r for r in csv.DictReader(open(f"{run}/coupling.csv")) if int(r["id"]) == a.id]
    except OSError as e:
        sys.exit(f"{run}: {e}")
    cells = []
    for lo, hi in windows:
        v = [-float(r["vz"]) for r in rows if lo <= float(r["time"]) <= hi]
        cells.append(f"{sum(v) / len(v):.2f}" if v else "-")
    print(f"| {run} | " + " | ".join(cells) + " |")
