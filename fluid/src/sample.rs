//! Cell-wise values of a Q1~/Q0 solution for the fluid-particle coupling: the cell that
//! holds a point, the cell mean of the velocity gradient and the cell's stress.
//!
//! The mean gradient over a cell `T` follows from the face mean values alone (Gauss):
//! `<grad u>_T = 1/|T| int_T grad u = 1/|T| sum_f u_f (x) n_f |f|`, the seed's
//! `<grad u> = 1/V int u (x) dA` ("Coupling of the phases", hydrodynamic forces) with the
//! cell as control volume. On a box cell, `<du_i/dx_a> = (u_i(upper a-face) -
//! u_i(lower a-face)) / h_a`.
use crate::grid::Grid;

/// The cell (coordinates) that contains `x`, points outside the box clamped onto its
/// nearest boundary cell.
pub fn cell_at(grid: &Grid, x: [f64; 3]) -> [usize; 3] {
    let h = grid.h();
    let n = grid.layout().n;
    [0, 1, 2].map(|d| {
        let s = ((x[d] - grid.lower[d]) / h[d]).floor();
        (s.max(0.0) as usize).min(n[d] - 1)
    })
}

/// Cell-centre velocity: the mean of the six face values (every Q1~ basis function is
/// 1/6 at the centre).
pub fn cell_velocity(grid: &Grid, u: [&[f64]; 3], c: [usize; 3]) -> [f64; 3] {
    let lay = grid.layout();
    let mut v = [0.0; 3];
    for a in 0..3 {
        for f in [lay.face(a, c), lay.face(a, lay.upper(a, c))] {
            for i in 0..3 {
                v[i] += u[i][f] / 6.0;
            }
        }
    }
    v
}

/// Velocity at `x`: trilinear interpolation of the cell-centre velocities (constant
/// extrapolation in the half cell along the box sides).
pub fn velocity_at(grid: &Grid, u: [&[f64]; 3], x: [f64; 3]) -> [f64; 3] {
    let h = grid.h();
    let n = grid.layout().n;
    let mut base = [0usize; 3];
    let mut frac = [0.0; 3];
    for d in 0..3 {
        let s = ((x[d] - grid.lower[d]) / h[d] - 0.5).clamp(0.0, (n[d] - 1) as f64);
        base[d] = (s.floor() as usize).min(n[d].saturating_sub(2));
        frac[d] = if n[d] > 1 { s - base[d] as f64 } else { 0.0 };
    }
    let mut v = [0.0; 3];
    for corner in 0..8 {
        let mut c = base;
        let mut w = 1.0;
        for d in 0..3 {
            let up = (corner >> d) & 1 == 1;
            if up {
                c[d] = (c[d] + 1).min(n[d] - 1);
            }
            w *= if up { frac[d] } else { 1.0 - frac[d] };
        }
        if w != 0.0 {
            let vc = cell_velocity(grid, u, c);
            for i in 0..3 {
                v[i] += w * vc[i];
            }
        }
    }
    v
}

/// `G[i][a] = <du_i/dx_a>_T`, the mean velocity gradient over cell `c`.
pub fn mean_gradient(grid: &Grid, u: [&[f64]; 3], c: [usize; 3]) -> [[f64; 3]; 3] {
    let lay = grid.layout();
    let h = grid.h();
    let mut g = [[0.0; 3]; 3];
    for a in 0..3 {
        let lo = lay.face(a, c);
        let hi = lay.face(a, lay.upper(a, c));
        for i in 0..3 {
            g[i][a] = (u[i][hi] - u[i][lo]) / h[a];
        }
    }
    g
}

/// Cauchy stress of the cell for density 1 (kinematic pressure `p`, kinematic viscosity
/// `nu`): `sigma = -p I + nu (G + G^T)` with the mean gradient `G` of [`mean_gradient`].
pub fn cell_stress(
    grid: &Grid,
    u: [&[f64]; 3],
    p: &[f64],
    nu: f64,
    c: [usize; 3],
) -> [[f64; 3]; 3] {
    let g = mean_gradient(grid, u, c);
    let pc = p[grid.layout().cell(c)];
    let mut s = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            s[i][j] = nu * (g[i][j] + g[j][i]);
        }
        s[i][i] -= pc;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::BoundaryKind::*;

    /// A linear field `u_i = sum_a A[i][a] x_a` has face means equal to its face-centre
    /// values, so the mean gradient must return `A` exactly, and the stress
    /// `-p I + nu (A + A^T)`.
    #[test]
    fn mean_gradient_is_exact_for_linear_fields() {
        let g = Grid::new([0.0; 3], [1.0, 2.0, 3.0], [2, 3, 4], 2, [[Dirichlet; 2]; 3]).unwrap();
        let lay = g.layout();
        let a = [[0.3, -1.2, 0.5], [2.0, 0.1, -0.7], [0.4, 0.9, -0.4]];
        let nf = g.num_faces();
        let mut u = [vec![0.0; nf], vec![0.0; nf], vec![0.0; nf]];
        for fam in 0..3 {
            for k in 0..lay.off[fam + 1] - lay.off[fam] {
                let x = g.face_centre(fam, lay.face_coords(fam, k));
                for i in 0..3 {
                    u[i][lay.off[fam] + k] = (0..3).map(|d| a[i][d] * x[d]).sum();
                }
            }
        }
        let p = vec![1.5; g.num_cells()];
        let c = cell_at(&g, [0.6, 1.1, 2.9]);
        assert_eq!(c, [2, 3, 7]);
        let s = cell_stress(&g, [&u[0], &u[1], &u[2]], &p, 0.1, c);
        for i in 0..3 {
            for j in 0..3 {
                let want = 0.1 * (a[i][j] + a[j][i]) - if i == j { 1.5 } else { 0.0 };
                assert!(
                    (s[i][j] - want).abs() < 1e-12,
                    "{i}{j}: {} vs {want}",
                    s[i][j]
                );
            }
        }
        assert_eq!(cell_at(&g, [-1.0, 9.0, 0.0]), [0, 5, 0]);
        // linear fields are reproduced at cell centres and interpolated exactly inside
        let x = [0.41, 1.23, 1.77];
        let v = velocity_at(&g, [&u[0], &u[1], &u[2]], x);
        for i in 0..3 {
            let want: f64 = (0..3).map(|d| a[i][d] * x[d]).sum();
            assert!((v[i] - want).abs() < 1e-12, "{i}: {} vs {want}", v[i]);
        }
    }
}
