#!/usr/bin/env python3
"""Packing fraction and angle of repose of a heap in a hopper, from one frame of a
grainflow particles.h5 (spheres or clumps alike: every row is a sphere, a clump's members
overlapping).

usage: scripts/heap-stats.py RUN_DIR [--time T] [--region R Z0 Z1] [--cone R0]

- Packing fraction: the fraction of the points of a cubic lattice (spacing d/20, d the
  largest row diameter) inside the cylinder r < R, Z0 < z < Z1 about the z axis that lie
  in at least one sphere: the solid fraction of the union, so overlapping clump members
  count once (a midpoint rule on the lattice; the error is of order the spacing over d
  per surface, well below 1e-3 here).
- Free surface: rows moving slower than 0.2 m/s, in radial bins of width d about the axis
  and 8 sectors; per bin and sector the highest top (z + r); per bin the median over the
  sectors. The angle of repose is atan(-slope) of the least-squares line h(r) through the
  bins with 2 d < r < R_wall(h) - 3 d, R_wall(z) = R0 + z the radius of the 45-degree
  cone (R0 its outlet radius): away from the rounded apex and from the wall; its error
  is one standard error of the fitted slope.
Prints JSON. Needs numpy and h5py (pip install h5py numpy).
"""
import argparse
import json
import math
import os

import h5py
import numpy as np


def frame(path, time):
    """(name, time, position, velocity, radius) of the frame nearest `time` (default the
    last)."""
    with h5py.File(path, "r") as f:
        names = sorted(k for k in f.keys() if k.startswith("step_"))
        times = [float(f[n].attrs["time"]) for n in names]
        k = len(names) - 1 if time is None else int(np.argmin([abs(t - time) for t in times]))
        g = f[names[k]]
        return (
            names[k],
            times[k],
            g["position"][...].reshape(-1, 3),
            g["velocity"][...].reshape(-1, 3),
            g["radius"][...],
        )


def packing_fraction(pos, rad, radius, z0, z1, spacing):
    """Solid fraction of the union of the spheres in the cylinder r < radius, z0 < z < z1,
    by the lattice points (cell midpoints, `spacing` apart) covered by a sphere."""
    lo = np.array([-radius, -radius, z0])
    dims = np.ceil(np.array([2 * radius, 2 * radius, z1 - z0]) / spacing).astype(int)
    covered = np.zeros(dims, dtype=bool)
    axes = [lo[d] + (np.arange(dims[d]) + 0.5) * spacing for d in range(3)]
    for p, r in zip(pos, rad):
        a = np.maximum(np.floor((p - r - lo) / spacing).astype(int), 0)
        b = np.minimum(np.ceil((p + r - lo) / spacing).astype(int) + 1, dims)
        if np.any(a >= b):
            continue
        x = axes[0][a[0] : b[0]] - p[0]
        y = axes[1][a[1] : b[1]] - p[1]
        z = axes[2][a[2] : b[2]] - p[2]
        d2 = x[:, None, None] ** 2 + y[None, :, None] ** 2 + z[None, None, :] ** 2
        covered[a[0] : b[0], a[1] : b[1], a[2] : b[2]] |= d2 < r * r
    inside = (axes[0][:, None] ** 2 + axes[1][None, :] ** 2) < radius**2
    inside = np.broadcast_to(inside[:, :, None], dims)
    return float(covered[inside].mean()), int(inside.sum())


def surface(pos, vel, rad, d, cone_r0):
    """Radial bins (centre, height) of the free surface and the fitted line."""
    still = np.linalg.norm(vel, axis=1) < 0.2
    p, r = pos[still], rad[still]
    rxy = np.hypot(p[:, 0], p[:, 1])
    top = p[:, 2] + r
    sector = ((np.arctan2(p[:, 1], p[:, 0]) + math.pi) / (2 * math.pi) * 8).astype(int) % 8
    ring = (rxy / d).astype(int)
    bins = []
    for k in range(ring.max() + 1):
        highs = [top[(ring == k) & (sector == s)] for s in range(8)]
        highs = [h.max() for h in highs if len(h)]
        if len(highs) >= 6:
            bins.append(((k + 0.5) * d, float(np.median(highs))))
    rc = np.array([b[0] for b in bins])
    h = np.array([b[1] for b in bins])
    fit = (rc > 2 * d) & (rc < cone_r0 + h - 3 * d)
    (slope, intercept), cov = np.polyfit(rc[fit], h[fit], 1, cov=True)
    resid = h[fit] - (slope * rc[fit] + intercept)
    slope_error = float(math.sqrt(cov[0, 0]))
    return bins, fit, float(slope), slope_error, float(intercept), float(resid.std()), int(still.sum())


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir")
    ap.add_argument("--time", type=float, help="frame nearest this time (default the last)")
    ap.add_argument("--region", type=float, nargs=3, default=[0.2, 0.12, 0.3],
                    metavar=("R", "Z0", "Z1"), help="packing region, m (default 0.2 0.12 0.3)")
    ap.add_argument("--cone", type=float, default=0.147361, help="cone outlet radius R0, m")
    a = ap.parse_args()
    name, time, pos, vel, rad = frame(os.path.join(a.run_dir, "particles.h5"), a.time)
    d = 2.0 * rad.max()
    phi, points = packing_fraction(pos, rad, *a.region, d / 20.0)
    bins, fit, slope, slope_error, intercept, spread, still = surface(pos, vel, rad, d, a.cone)
    out = {
        "frame": name,
        "time": time,
        "rows": int(len(pos)),
        "packing_fraction": phi,
        "packing_region_m": {"radius": a.region[0], "z0": a.region[1], "z1": a.region[2]},
        "lattice_points": points,
        "angle_of_repose_deg": math.degrees(math.atan(-slope)),
        # one standard error of the fitted slope, as an angle: d(atan s) = ds / (1 + s^2)
        "angle_error_deg": math.degrees(slope_error / (1.0 + slope * slope)),
        "surface_fit": {"slope": slope, "height_at_axis_m": intercept,
                        "residual_m": spread, "bins": int(fit.sum())},
        "rows_at_rest": still,
        "surface": [{"r": b[0], "h": b[1], "fitted": bool(f)} for b, f in zip(bins, fit)],
    }
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
