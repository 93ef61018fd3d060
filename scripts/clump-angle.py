#!/usr/bin/env python3
"""Angle of a clump's long axis to the horizontal over time, from particles.h5.

Usage: scripts/clump-angle.py RUN_DIR [--vertical x|y|z] [--body B] [--csv FILE]

Reads every frame of RUN_DIR/particles.h5 and prints time, the angle (degrees) between
the long principal axis of body B (the `axis` field of its members, default body 0) and
the plane perpendicular to the vertical axis (default x, the sedimentation box's
gravity direction), the body's centre along the vertical (mean of its member centres)
and its velocity along it. `--csv FILE` writes the same columns as CSV.
"""
import argparse
import math

import h5py
import numpy as np


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("run")
    ap.add_argument("--vertical", default="x", choices=["x", "y", "z"])
    ap.add_argument("--body", type=int, default=0)
    ap.add_argument("--csv")
    a = ap.parse_args()
    v = "xyz".index(a.vertical)
    rows = []
    with h5py.File(f"{a.run}/particles.h5", "r") as f:
        for name in sorted(k for k in f.keys() if k.startswith("step_")):
            g = f[name]
            members = np.asarray(g["clump"]) == a.body
            if not members.any():
                continue
            axis = np.asarray(g["axis"])[members][0]
            angle = math.degrees(math.asin(min(1.0, abs(axis[v]) / np.linalg.norm(axis))))
            centre = np.asarray(g["position"])[members].mean(axis=0)
            vel = np.asarray(g["velocity"])[members].mean(axis=0)
            rows.append((float(g.attrs["time"]), angle, centre[v], vel[v]))
    print("time angle_deg centre velocity")
    for r in rows:
        print(f"{r[0]:.4f} {r[1]:.3f} {r[2]:.4f} {r[3]:.4f}")
    if a.csv:
        with open(a.csv, "w") as out:
            out.write("time,angle_deg,centre,velocity\n")
            for r in rows:
                out.write(",".join(f"{x:.6g}" for x in r) + "\n")


if __name__ == "__main__":
    main()
