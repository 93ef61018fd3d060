#!/usr/bin/env python3
"""Speed of a long run from its log: particle-steps per second per core between
successive progress lines, against the particle count and against simulated time.

    python3 scripts/progress-rate.py LOG --threads N --out FILE.png [--title TEXT]

LOG is the run's stderr (the `INFO step K/N t = T s ... P particles` lines written every
10 s). The rate between two lines is (steps between them) x (mean particle count) /
(wall seconds between their time stamps) / N. Prints the figures as JSON (median rate per
core over each tenth of the particle range) and writes a PNG with two panels.
"""
import argparse
import datetime as dt
import json
import re
import sys

LINE = re.compile(
    r"^(\S+)Z\s+INFO step (\d+)/\d+ t = (\S+) s .* (\d+) particles"
)


def read(path):
    rows = []
    with open(path) as f:
        for line in f:
            m = LINE.match(line)
            if m:
                stamp = dt.datetime.fromisoformat(m.group(1))
                rows.append((stamp.timestamp(), int(m.group(2)), float(m.group(3)), int(m.group(4))))
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("log")
    ap.add_argument("--threads", type=int, required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--title", default="")
    a = ap.parse_args()
    rows = read(a.log)
    if len(rows) < 3:
        sys.exit(f"{a.log}: fewer than 3 progress lines")
    t_sim, count, rate = [], [], []
    for (w0, s0, _, p0), (w1, s1, t1, p1) in zip(rows, rows[1:]):
        if s1 <= s0 or w1 <= w0:
            continue
        t_sim.append(t1)
        count.append(0.5 * (p0 + p1))
        rate.append((s1 - s0) * 0.5 * (p0 + p1) / (w1 - w0) / a.threads)
    top = max(count)
    tenths = []
    for k in range(10):
        lo, hi = k / 10 * top, (k + 1) / 10 * top
        sel = sorted(r for c, r in zip(count, rate) if lo < c <= hi)
        if sel:
            tenths.append({"particles": [round(lo), round(hi)], "median_rate_per_core": sel[len(sel) // 2]})
    print(json.dumps({"intervals": len(rate), "wall_s": rows[-1][0] - rows[0][0], "tenths": tenths}, indent=1))

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(10, 3.6), dpi=90)
    ax0.plot(count, rate, ".", ms=2)
    ax0.set_xlabel("particles")
    ax0.set_ylabel("particle-steps / s / core")
    ax0.set_ylim(bottom=0)
    ax0.grid(alpha=0.3)
    ax1.plot(t_sim, rate, ".", ms=2, label="rate per core")
    ax1.set_xlabel("simulated time (s)")
    ax1.set_ylabel("particle-steps / s / core")
    ax1.set_ylim(bottom=0)
    ax1.grid(alpha=0.3)
    twin = ax1.twinx()
    twin.plot(t_sim, count, color="tab:orange", lw=1)
    twin.set_ylabel("particles", color="tab:orange")
    twin.set_ylim(bottom=0)
    if a.title:
        fig.suptitle(a.title, fontsize=10)
    fig.tight_layout()
    fig.savefig(a.out)
    print(f"wrote {a.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
