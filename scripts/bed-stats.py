#!/usr/bin/env python3
"""Bed figures of one frame of a grainflow particles.h5: height, packing fraction,
coordination number, speeds.

usage: scripts/bed-stats.py RUN_DIR/particles.h5 [--frame STEP_NAME] [--column R]

- Solid fraction profile: sphere volumes whose centres lie in horizontal slabs of a
  central column of radius R (default 0.4 m, inside the hopper's narrowest section), per
  slab volume. Slabs are 5 particle diameters high.
- Bed height: the top of the highest slab whose solid fraction is at least half of the
  profile's median over its lower half (the dense part).
- Mean packing fraction: mean of the slabs between 10 % and 80 % of the bed height.
- Coordination number: touching pairs (centre distance < r_i + r_j) per particle, over
  the particles below 80 % of the bed height, counted on a cell grid (numpy only).
Needs numpy and h5py (pip install h5py numpy).
"""
import argparse
import json

import h5py
import numpy as np


def touching_pairs(pos, rad):
    """Number of touching pairs each particle takes part in (cell grid of size 2 r_max)."""
    cell = 2.0 * rad.max()
    ijk = np.floor((pos - pos.min(axis=0)) / cell).astype(np.int64)
    dims = ijk.max(axis=0) + 3
    key = ((ijk[:, 0] + 1) * dims[1] + ijk[:, 1] + 1) * dims[2] + ijk[:, 2] + 1
    order = np.argsort(key, kind="stable")
    skey = key[order]
    counts = np.zeros(len(pos), dtype=np.int64)
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            for dz in (-1, 0, 1):
                off = (dx * dims[1] + dy) * dims[2] + dz
                if off < 0:
                    continue  # each neighbouring cell pair once
                lo = np.searchsorted(skey, key + off, side="left")
                hi = np.searchsorted(skey, key + off, side="right")
                n = hi - lo
                most = n.max() if len(n) else 0
                for k in range(most):
                    has = n > k
                    a = np.nonzero(has)[0]
                    b = order[lo[has] + k]
                    if off == 0:
                        keep = b > a
                        a, b = a[keep], b[keep]
                    d = np.linalg.norm(pos[a] - pos[b], axis=1)
                    touch = d < rad[a] + rad[b]
                    np.add.at(counts, a[touch], 1)
                    np.add.at(counts, b[touch], 1)
    return counts


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("file")
    ap.add_argument("--frame", help="frame group name (default: the last)")
    ap.add_argument("--column", type=float, default=0.4, help="column radius, m")
    args = ap.parse_args()
    with h5py.File(args.file, "r") as f:
        name = args.frame or sorted(k for k in f.keys() if k.startswith("step_"))[-1]
        g = f[name]
        time = float(g.attrs["time"])
        pos = g["position"][...]
        vel = g["velocity"][...]
        rad = g["radius"][...]
    d = 2.0 * rad.max()
    r_xy = np.hypot(pos[:, 0], pos[:, 1])
    inside = r_xy < args.column
    dz = 5.0 * d
    edges = np.arange(pos[:, 2].min(), pos[:, 2].max() + dz, dz)
    vol = 4.0 / 3.0 * np.pi * rad**3
    solid, _ = np.histogram(pos[inside, 2], bins=edges, weights=vol[inside])
    frac = solid / (np.pi * args.column**2 * dz)
    dense = np.median(frac[: max(1, len(frac) // 2)])
    top = np.nonzero(frac >= 0.5 * dense)[0].max()
    height = edges[top + 1]
    mid = (edges[:-1] + edges[1:]) / 2
    sel = (mid > 0.1 * height) & (mid < 0.8 * height)
    packing = float(frac[sel].mean()) if sel.any() else float("nan")
    below = pos[:, 2] < 0.8 * height
    coord = touching_pairs(pos[below], rad[below])
    speed = np.linalg.norm(vel, axis=1)
    out = {
        "frame": name,
        "time": time,
        "particles": int(len(pos)),
        "bed_height_m": float(height),
        "packing_fraction": packing,
        "coordination_number": float(coord.mean()),
        "rattlers_fraction": float((coord == 0).mean()),
        "mean_speed_m_s": float(speed.mean()),
        "mean_speed_in_bed_m_s": float(speed[below].mean()),
        "profile": [
            {"z": float(m), "solid_fraction": float(p)} for m, p in zip(mid, frac)
        ],
    }
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
