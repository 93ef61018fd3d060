#!/usr/bin/env python3
"""Mass flow through the sinks of a run: removed mass and the flow rate against time.

    python3 scripts/discharge-plot.py RUN_DIR --out FILE.png [--window S] [--reference W]

Reads RUN_DIR/sinks.csv and RUN_DIR/summary.json. The rate is the removed mass's change
over a sliding window of S seconds (default 0.05). The steady rate of summary.json
(`sinks[].discharge_rate`, over its `discharge_window`) is drawn as a line. A correlation's
value can be drawn as a dashed line with --reference W (kg/s).
"""
import argparse
import csv
import json
import os
import sys


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir")
    ap.add_argument("--out", required=True)
    ap.add_argument("--window", type=float, default=0.05)
    ap.add_argument("--reference", type=float)
    ap.add_argument("--reference-label", default="correlation")
    a = ap.parse_args()
    path = os.path.join(a.run_dir, "sinks.csv")
    try:
        rows = list(csv.DictReader(open(path)))
        summary = json.load(open(os.path.join(a.run_dir, "summary.json")))
    except OSError as e:
        sys.exit(f"{a.run_dir}: {e}")
    if not rows:
        sys.exit(f"{path}: no particle left through a sink")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(10, 3.6), dpi=90)
    for s, sink in enumerate(summary["sinks"]):
        t = [float(r["time"]) for r in rows if int(r["sink"]) == s]
        m = [float(r["removed_mass"]) for r in rows if int(r["sink"]) == s]
        if not t:
            continue
        ax0.plot(t, m, label=sink["name"])
        tc, rate, j = [], [], 0
        for i in range(len(t)):
            while t[i] - t[j] > a.window:
                j += 1
            if t[i] - t[j] >= 0.5 * a.window:
                tc.append(0.5 * (t[i] + t[j]))
                rate.append((m[i] - m[j]) / (t[i] - t[j]))
        ax1.plot(tc, rate, lw=1, label=f"{sink['name']}, {a.window:g} s window")
        if sink.get("discharge_rate") is not None:
            w0, w1 = sink["discharge_window"]
            ax1.plot([w0, w1], [sink["discharge_rate"]] * 2, "k-", lw=2,
                     label=f"steady {sink['discharge_rate']:.3g} kg/s")
    if a.reference is not None:
        ax1.axhline(a.reference, color="tab:red", ls="--",
                    label=f"{a.reference_label} {a.reference:.3g} kg/s")
    ax0.set_xlabel("time (s)")
    ax0.set_ylabel("removed mass (kg)")
    ax1.set_xlabel("time (s)")
    ax1.set_ylabel("mass flow rate (kg/s)")
    ax1.set_ylim(bottom=0)
    for ax in (ax0, ax1):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(a.out)
    print(f"wrote {a.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
