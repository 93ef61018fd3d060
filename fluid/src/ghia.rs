//! The lid-driven cavity of Ghia, Ghia & Shin (1982, J. Comput. Phys. 48:387): reference
//! centreline profiles, the cavity set-up and the sampling of a computed flow along the
//! centrelines, shared by the tests of [`crate::navier`] and `benches/cavity_error.rs`.
//!
//! The cavity is the unit square in x-y with the lid `y = 1` moving at `u = (1, 0, 0)`,
//! no-slip elsewhere, periodic in z (so the flow stays two-dimensional); `Re = 1 / nu`.

use crate::grid::{BoundaryKind::*, Grid};
use crate::navier::{NavierStokes, NsConfig};

/// Ghia et al. (1982), Re = 100, as transcribed in ../shared/reference/fluid-benchmarks.md:
/// `(y, u(0.5, y))` along the vertical centreline.
pub const GHIA_U_100: [(f64, f64); 15] = [
    (0.9766, 0.84123),
    (0.9688, 0.78871),
    (0.9609, 0.73722),
    (0.9531, 0.68717),
    (0.8516, 0.23151),
    (0.7344, 0.00332),
    (0.6172, -0.13641),
    (0.5000, -0.20581),
    (0.4531, -0.21090),
    (0.2813, -0.15662),
    (0.1719, -0.10150),
    (0.1016, -0.06434),
    (0.0703, -0.04775),
    (0.0625, -0.04192),
    (0.0547, -0.03717),
];

/// The same table, `(x, v(x, 0.5))` along the horizontal centreline.
pub const GHIA_V_100: [(f64, f64); 15] = [
    (0.9688, -0.05906),
    (0.9609, -0.07391),
    (0.9531, -0.08864),
    (0.9453, -0.10313),
    (0.9063, -0.16914),
    (0.8594, -0.22445),
    (0.8047, -0.24533),
    (0.5000, 0.05454),
    (0.2344, 0.17527),
    (0.2266, 0.17507),
    (0.1563, 0.16077),
    (0.0938, 0.12317),
    (0.0781, 0.10890),
    (0.0703, 0.10091),
    (0.0625, 0.09233),
];

/// Re = 400 column of the u table, at the `y` of [`GHIA_U_100`].
pub const GHIA_U_400: [f64; 15] = [
    0.75837, 0.68439, 0.61756, 0.55892, 0.29093, 0.16256, 0.02135, -0.11477, -0.17119, -0.32726,
    -0.24299, -0.14612, -0.10338, -0.09266, -0.08186,
];

/// Re = 400 column of the v table, at the `x` of [`GHIA_V_100`] (the misprinted value at
/// x = 0.9063 is NaN and skipped by [`v_deviation`]).
pub const GHIA_V_400: [f64; 15] = [
    -0.12146,
    -0.15663,
    -0.19254,
    -0.22847,
    f64::NAN,
    -0.44993,
    -0.38598,
    0.05186,
    0.30174,
    0.30203,
    0.28124,
    0.22965,
    0.20920,
    0.19713,
    0.18360,
];

/// The cavity on level `level` of a grid with `n x n` cells in x-y (`n` divisible by
/// `2^(level-1)`) and `coarse_z` coarse cells in z, the box `depth` thick; `cfg` gives the
/// viscosity `1/Re`, the time step and the scheme. Returns the solver at rest with the
/// lid velocity set.
pub fn cavity(n: usize, level: u32, coarse_z: usize, depth: f64, cfg: NsConfig) -> NavierStokes {
    let coarse = n >> (level - 1);
    assert_eq!(
        coarse << (level - 1),
        n,
        "n = {n} is not a level-{level} grid"
    );
    let bc = [[Dirichlet; 2], [Dirichlet; 2], [Periodic; 2]];
    let g = Grid::new(
        [0.0; 3],
        [1.0, 1.0, depth],
        [coarse, coarse, coarse_z],
        level,
        bc,
    )
    .expect("valid cavity grid");
    let mut ns = NavierStokes::new(&g, cfg, g.dirichlet_mask());
    ns.set_side_velocity(1, 1, |_| [1.0, 0.0, 0.0]);
    ns
}

/// `u` on the vertical centreline `x = 0.5` at height `y`.
pub fn centreline_u(ns: &NavierStokes, y: f64) -> f64 {
    centreline(ns, 0, y)
}

/// `v` on the horizontal centreline `y = 0.5` at abscissa `x`.
pub fn centreline_v(ns: &NavierStokes, x: f64) -> f64 {
    centreline(ns, 1, x)
}

/// Largest `|u(0.5, y_k) - u_ref[k]|` over the `y_k` of [`GHIA_U_100`] (NaN entries of
/// `u_ref` skipped).
pub fn u_deviation(ns: &NavierStokes, u_ref: &[f64; 15]) -> f64 {
    deviation(ns, 0, &GHIA_U_100, u_ref)
}

/// Largest `|v(x_k, 0.5) - v_ref[k]|` over the `x_k` of [`GHIA_V_100`] (NaN entries of
/// `v_ref` skipped).
pub fn v_deviation(ns: &NavierStokes, v_ref: &[f64; 15]) -> f64 {
    deviation(ns, 1, &GHIA_V_100, v_ref)
}

/// [`u_deviation`] from the Re = 100 table.
pub fn ghia_u_deviation(ns: &NavierStokes) -> f64 {
    u_deviation(ns, &GHIA_U_100.map(|(_, u)| u))
}

/// [`v_deviation`] from the Re = 100 table.
pub fn ghia_v_deviation(ns: &NavierStokes) -> f64 {
    v_deviation(ns, &GHIA_V_100.map(|(_, v)| v))
}

fn deviation(ns: &NavierStokes, comp: usize, at: &[(f64, f64); 15], want: &[f64; 15]) -> f64 {
    at.iter()
        .zip(want)
        .filter(|(_, w)| w.is_finite())
        .fold(0.0f64, |m, (&(s, _), w)| {
            m.max((centreline(ns, comp, s) - w).abs())
        })
}

/// Component `comp` along the centreline through the `comp`-faces at coordinate 0.5
/// (`comp` 0: u on x = 0.5 as a function of y; 1: v on y = 0.5 as a function of x),
/// averaged over z and interpolated linearly between face centres, with the wall
/// values (0, and the lid value 1 for u at y = 1) at the ends.
fn centreline(ns: &NavierStokes, comp: usize, s: f64) -> f64 {
    let g = ns.grid();
    let lay = g.layout();
    let n = lay.n;
    let t = 1 - comp; // the coordinate varied along the line
    let h = g.h()[t];
    let value = |m: isize| -> f64 {
        if m < 0 {
            return 0.0;
        }
        if m as usize >= n[t] {
            return if comp == 0 { 1.0 } else { 0.0 };
        }
        let mut sum = 0.0;
        for k in 0..n[2] {
            let mut f = [0, 0, k];
            f[comp] = n[comp] / 2;
            f[t] = m as usize;
            sum += ns.u[comp][lay.face(comp, f)];
        }
        sum / n[2] as f64
    };
    // face centres at (m + 1/2) h; the walls at "m = -1/2" and "m = n - 1/2"
    let m0 = (s / h - 0.5).floor();
    let at = |m: isize| -> (f64, f64) {
        // (position, value), clamping the virtual points onto the walls
        if m < 0 {
            (0.0, value(-1))
        } else if m as usize >= n[t] {
            (1.0, value(n[t] as isize))
        } else {
            ((m as f64 + 0.5) * h, value(m))
        }
    };
    let (x0, v0) = at(m0 as isize);
    let (x1, v1) = at(m0 as isize + 1);
    if (x1 - x0).abs() < 1e-15 {
        v0
    } else {
        v0 + (v1 - v0) * (s - x0) / (x1 - x0)
    }
}
