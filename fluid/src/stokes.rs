//! Steady Stokes solver for the Q1~/Q0 pair:
//!
//! `nu K u + B p = f`, `B^T u = 0` (`B` the discrete gradient, `-B^T` the divergence),
//!
//! by preconditioned conjugate gradients on the pressure Schur complement
//! `S = B^T A^{-1} B`, `A = nu K` with the Dirichlet faces eliminated (the "Uzawa-CG" of
//! Verfürth 1984, IMA J. Numer. Anal. 4:441; Elman, Silvester & Wathen 2014, "Finite
//! Elements and Fast Iterative Solvers", ch. 4). `S` is spectrally equivalent to
//! the pressure mass matrix `M_p / nu` for an inf-sup stable pair (Q1~/Q0 is, Rannacher &
//! Turek 1992), so the preconditioner `nu M_p^{-1}` (`M_p = diag(V)`) gives a
//! level-independent number of CG steps. Each application of `A^{-1}` is a [`FaceMg`]
//! solve per velocity component.
//!
//! With `u(p) = A^{-1} (f - B p)` (Dirichlet values kept) the divergence of `u(p + d)` is
//! `D u(p) + S d` (`D = -B^T`), so CG runs on `S d = -D u(p)` and updates `u` alongside
//! `p` without extra solves.

use crate::grid::Grid;
use crate::mg_cell::MgReport;
use crate::mg_face::FaceMg;
use crate::ops::{add_gradient, axpy, divergence, dot, remove_mean};
use std::time::Instant;

/// Report of one Stokes solve.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StokesReport {
    /// Schur-complement CG iterations.
    pub iterations: usize,
    /// Final / initial Euclidean norm of the discrete divergence `B^T u`.
    pub divergence_reduction: f64,
    /// Multigrid cycles of all velocity solves.
    pub momentum_cycles: usize,
    /// Mean reduction factor per cycle of the velocity solves (geometric mean).
    pub momentum_reduction: f64,
    /// Wall time, seconds.
    pub seconds: f64,
}

/// Steady Stokes solver on one grid level.
pub struct StokesSolver {
    grid: Grid,
    nu: f64,
    mg: FaceMg,
    /// Relative residual of each velocity solve.
    pub inner_rtol: f64,
    /// Maximum Schur-complement iterations.
    pub max_iterations: usize,
    /// Multigrid cycles and log-reduction summed over velocity solves.
    cycles: usize,
    log_reduction: f64,
}

impl StokesSolver {
    /// Solver for viscosity `nu` on `grid`; `mask` flags the faces with prescribed velocity
    /// (at least [`Grid::dirichlet_mask`], plus marked cells via [`Grid::mark_faces`]).
    pub fn new(grid: &Grid, nu: f64, mask: Vec<bool>) -> Self {
        StokesSolver {
            grid: grid.clone(),
            nu,
            mg: FaceMg::new(grid, 0.0, nu, mask),
            inner_rtol: 1e-10,
            max_iterations: 200,
            cycles: 0,
            log_reduction: 0.0,
        }
    }

    fn velocity_solve(&mut self, x: &mut [f64], b: &[f64]) {
        let rep: MgReport = self.mg.solve(x, b, self.inner_rtol, 100);
        self.cycles += rep.cycles;
        if rep.initial_residual > 0.0 && rep.final_residual > 0.0 {
            self.log_reduction += (rep.final_residual / rep.initial_residual).ln();
        }
    }

    /// Solves for `u` (masked faces hold the prescribed velocities) and `p` from the
    /// initial guesses given, with the momentum load vector `f` (see
    /// [`crate::ops::add_boundary_pressure`] for do-nothing sides with a pressure), until
    /// the divergence residual fell by `rtol`.
    pub fn solve(
        &mut self,
        u: &mut [Vec<f64>; 3],
        p: &mut [f64],
        f: &[Vec<f64>; 3],
        rtol: f64,
    ) -> StokesReport {
        let start = Instant::now();
        self.cycles = 0;
        self.log_reduction = 0.0;
        let g = self.grid.clone();
        let nf = g.num_faces();
        let nc = g.num_cells();
        let singular = g.pressure_singular();
        let vol = g.cell_volume();
        let mask = self.mg.mask().to_vec();

        // u = A^{-1} (f - B p)
        let mut rhs = f.clone();
        {
            let [r0, r1, r2] = &mut rhs;
            add_gradient(&g, p, -1.0, [r0, r1, r2]);
        }
        for (ua, ra) in u.iter_mut().zip(&rhs) {
            self.velocity_solve(ua, ra);
        }
        // r = -D u
        let mut r = vec![0.0; nc];
        divergence(&g, [&u[0], &u[1], &u[2]], &mut r);
        r.iter_mut().for_each(|v| *v = -*v);
        let r0 = dot(&r, &r).sqrt();
        let nu = self.nu;
        let precondition = |r: &[f64], z: &mut Vec<f64>| {
            z.iter_mut().zip(r).for_each(|(z, r)| *z = nu * r / vol);
            if singular {
                remove_mean(z);
            }
        };
        let mut z = vec![0.0; nc];
        precondition(&r, &mut z);
        let mut d = z.clone();
        let mut rz = dot(&r, &z);
        let mut w = [0, 1, 2].map(|_| vec![0.0; nf]);
        let mut bd = [0, 1, 2].map(|_| vec![0.0; nf]);
        let mut sd = vec![0.0; nc];
        let mut rep = StokesReport::default();
        let mut rn = r0;
        while rep.iterations < self.max_iterations && rn > rtol * r0 && r0 > 0.0 {
            // w = A0^{-1} B d (homogeneous Dirichlet)
            for a in 0..3 {
                bd[a].iter_mut().for_each(|v| *v = 0.0);
                w[a].iter_mut().for_each(|v| *v = 0.0);
            }
            {
                let [b0, b1, b2] = &mut bd;
                add_gradient(&g, &d, 1.0, [b0, b1, b2]);
            }
            for a in 0..3 {
                let mut wa = std::mem::take(&mut w[a]);
                self.velocity_solve(&mut wa, &bd[a]);
                wa.iter_mut().zip(&mask).for_each(|(v, &m)| {
                    if m {
                        *v = 0.0;
                    }
                });
                w[a] = wa;
            }
            // S d = B^T w = -D w
            divergence(&g, [&w[0], &w[1], &w[2]], &mut sd);
            sd.iter_mut().for_each(|v| *v = -*v);
            let alpha = rz / dot(&d, &sd);
            axpy(alpha, &d, p);
            for a in 0..3 {
                axpy(-alpha, &w[a], &mut u[a]);
            }
            axpy(-alpha, &sd, &mut r);
            rn = dot(&r, &r).sqrt();
            rep.iterations += 1;
            precondition(&r, &mut z);
            let rz_new = dot(&r, &z);
            let beta = rz_new / rz;
            rz = rz_new;
            d.iter_mut().zip(&z).for_each(|(d, z)| *d = z + beta * *d);
        }
        if singular {
            remove_mean(p);
        }
        // the true divergence of the final velocity
        divergence(&g, [&u[0], &u[1], &u[2]], &mut r);
        rep.divergence_reduction = if r0 > 0.0 {
            dot(&r, &r).sqrt() / r0
        } else {
            0.0
        };
        rep.momentum_cycles = self.cycles;
        rep.momentum_reduction = if self.cycles > 0 {
            (self.log_reduction / self.cycles as f64).exp()
        } else {
            0.0
        };
        rep.seconds = start.elapsed().as_secs_f64();
        rep
    }
}

/// Momentum load vector `M f` of a body force given by its face values (Q1~ interpolant),
/// one vector per component.
pub fn body_force_load(grid: &Grid, f: &[Vec<f64>; 3]) -> [Vec<f64>; 3] {
    let mass = crate::ops::FaceOperator::helmholtz(grid, 1.0, 0.0);
    [0, 1, 2].map(|a| {
        let mut out = vec![0.0; grid.num_faces()];
        mass.apply(&f[a], &mut out);
        out
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::{basis, GAUSS3};
    use crate::grid::BoundaryKind::*;
    use crate::ops::add_boundary_pressure;
    use std::f64::consts::PI;

    /// Fully developed flow in the duct -a < y < a, -b < z < b under the pressure
    /// gradient G = -dp/dx (White, "Viscous Fluid Flow", 3rd ed. 2006, ch. 3, rectangular duct; the
    /// series in ../shared/reference/fluid-benchmarks.md):
    /// `u = 16 a^2 G/(mu pi^3) sum_{n odd} (-1)^((n-1)/2) [1 - cosh(n pi z/(2a)) /
    /// cosh(n pi b/(2a))] cos(n pi y/(2a)) / n^3`, summed to n = 801 (alternating, terms
    /// below 4e-9 relative), cosh ratio as exp(|z| - b) (1 + e^(-2|z|)) / (1 + e^(-2b)) in
    /// scaled units to avoid overflow.
    fn duct_exact(y: f64, z: f64, a: f64, b: f64, g_over_mu: f64) -> f64 {
        let mut s = 0.0;
        let mut n = 1;
        while n <= 801 {
            let k = n as f64 * PI / (2.0 * a);
            let (zz, bb) = (k * z.abs(), k * b);
            let ratio = (zz - bb).exp() * (1.0 + (-2.0 * zz).exp()) / (1.0 + (-2.0 * bb).exp());
            let sign = if (n / 2) % 2 == 0 { 1.0 } else { -1.0 };
            s += sign * (1.0 - ratio) * (k * y).cos() / (n * n * n) as f64;
            n += 2;
        }
        16.0 * a * a * g_over_mu / PI.powi(3) * s
    }

    /// The transcription of the series satisfies -Laplace u = G/mu (central differences
    /// with step 1e-2, to 1e-3: the Laplacian of the truncated series converges like 1/N)
    /// and u = 0 on the walls (1e-7).
    #[test]
    fn duct_series_solves_the_poisson_problem() {
        let (a, b) = (0.5, 0.5);
        let e = 1e-2;
        for (y, z) in [(0.1, -0.2), (0.0, 0.0), (-0.3, 0.35)] {
            let u = |y, z| duct_exact(y, z, a, b, 1.0);
            let lap =
                (u(y + e, z) + u(y - e, z) + u(y, z + e) + u(y, z - e) - 4.0 * u(y, z)) / (e * e);
            assert!((lap + 1.0).abs() < 1e-3, "Laplace u = {lap}");
        }
        for t in [-0.4, 0.0, 0.3] {
            assert!(duct_exact(a, t, a, b, 1.0).abs() < 1e-7);
            assert!(duct_exact(t, b, a, b, 1.0).abs() < 1e-7);
        }
    }

    /// L2 norm of the error of the Q1~ velocity against `exact`, 27-point Gauss per cell.
    fn l2_error(g: &Grid, u: &[Vec<f64>; 3], exact: impl Fn([f64; 3]) -> [f64; 3]) -> f64 {
        let lay = g.layout();
        let h = g.h();
        let mut err2 = 0.0;
        for c in 0..lay.num_cells() {
            let cc = lay.cell_coords(c);
            let xc = g.cell_centre(cc);
            let faces = [0, 1, 2].map(|a| [lay.face(a, cc), lay.face(a, lay.upper(a, cc))]);
            for (x, wx) in GAUSS3 {
                for (y, wy) in GAUSS3 {
                    for (z, wz) in GAUSS3 {
                        let phi = basis([x, y, z]);
                        let pt = [0, 1, 2].map(|d| xc[d] + 0.5 * h[d] * [x, y, z][d]);
                        let ex = exact(pt);
                        for comp in 0..3 {
                            let mut uh = 0.0;
                            for a in 0..3 {
                                for s in 0..2 {
                                    uh += phi[2 * a + s] * u[comp][faces[a][s]];
                                }
                            }
                            err2 += wx * wy * wz * (uh - ex[comp]).powi(2);
                        }
                    }
                }
            }
        }
        (err2 * g.cell_volume() / 8.0).sqrt()
    }

    /// Square-duct Poiseuille flow driven by a pressure drop through do-nothing ends
    /// (no-slip walls y = +-1/2, z = +-1/2, nu = 0.1, G = 1): the discrete pressure is
    /// linear (max error 1e-7 of the drop), and the L2 velocity error against the exact
    /// series falls at second order over three levels (observed order >= 1.8).
    #[test]
    fn duct_poiseuille_converges_at_second_order() {
        let (a, b, nu, gdrop) = (0.5, 0.5, 0.1, 1.0);
        let bc = [[DoNothing; 2], [Dirichlet; 2], [Dirichlet; 2]];
        let mut errors = Vec::new();
        for level in 2..=4u32 {
            let g = Grid::new([0.0, -a, -b], [0.5, a, b], [1, 2, 2], level, bc).unwrap();
            let lx = 0.5;
            let nf = g.num_faces();
            let mut u = [0, 1, 2].map(|_| vec![0.0; nf]);
            let mut p = vec![0.0; g.num_cells()];
            let mut f = [0, 1, 2].map(|_| vec![0.0; nf]);
            {
                let [f0, f1, f2] = &mut f;
                add_boundary_pressure(&g, [[gdrop * lx, 0.0], [0.0; 2], [0.0; 2]], [f0, f1, f2]);
            }
            let mut solver = StokesSolver::new(&g, nu, g.dirichlet_mask());
            let rep = solver.solve(&mut u, &mut p, &f, 1e-9);
            let err = l2_error(&g, &u, |x| {
                [duct_exact(x[1], x[2], a, b, gdrop / nu), 0.0, 0.0]
            });
            let lay = g.layout();
            let perr = (0..g.num_cells())
                .map(|c| {
                    let x = g.cell_centre(lay.cell_coords(c));
                    (p[c] - gdrop * (lx - x[0])).abs()
                })
                .fold(0.0, f64::max);
            println!(
                "duct level {level} ({} DOFs): L2 error {err:.4e}, max pressure error {perr:.2e}, {} CG its, div reduction {:.1e}, {} MG cycles (rho {:.3}), {:.2} s",
                g.dofs(),
                rep.iterations,
                rep.divergence_reduction,
                rep.momentum_cycles,
                rep.momentum_reduction,
                rep.seconds
            );
            assert!(rep.divergence_reduction < 1e-8);
            assert!(perr < 1e-7 * gdrop * lx, "pressure error {perr}");
            errors.push(err);
        }
        for w in errors.windows(2) {
            let order = (w[0] / w[1]).log2();
            println!("observed order {order:.3}");
            assert!(order >= 1.8, "order {order}");
        }
    }

    /// The same duct made periodic along x and driven by the body force G/rho = 1 (load
    /// `M f` from [`body_force_load`]): the L2 error against the series also falls at
    /// second order (observed order >= 1.8 over three levels), the pressure stays constant.
    #[test]
    fn periodic_duct_with_body_force_converges_at_second_order() {
        let (a, b, nu, gforce) = (0.5, 0.5, 0.1, 1.0);
        let bc = [[Periodic; 2], [Dirichlet; 2], [Dirichlet; 2]];
        let mut errors = Vec::new();
        for level in 1..=3u32 {
            let g = Grid::new([0.0, -a, -b], [0.5, a, b], [2, 4, 4], level, bc).unwrap();
            let nf = g.num_faces();
            let mut u = [0, 1, 2].map(|_| vec![0.0; nf]);
            let mut p = vec![0.0; g.num_cells()];
            let force = [vec![gforce; nf], vec![0.0; nf], vec![0.0; nf]];
            let f = body_force_load(&g, &force);
            let mut solver = StokesSolver::new(&g, nu, g.dirichlet_mask());
            let rep = solver.solve(&mut u, &mut p, &f, 1e-9);
            let err = l2_error(&g, &u, |x| {
                [duct_exact(x[1], x[2], a, b, gforce / nu), 0.0, 0.0]
            });
            let pmax = p.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            println!(
                "periodic duct level {level}: L2 error {err:.4e}, max |p| {pmax:.1e}, {} CG its, {} MG cycles",
                rep.iterations, rep.momentum_cycles
            );
            assert!(pmax < 1e-8, "pressure {pmax}");
            errors.push(err);
        }
        for w in errors.windows(2) {
            let order = (w[0] / w[1]).log2();
            println!("observed order {order:.3}");
            assert!(order >= 1.8, "order {order}");
        }
    }

    /// Fictitious-boundary hook: a block of 2x2x2 marked cells (markers -1 inner, 1
    /// boundary) moving with u = (1, 0, 0) inside a closed box keeps its prescribed face
    /// velocities exactly, the discrete divergence vanishes (reduction 1e-9), and the fluid
    /// next to the block is dragged along (0 < u_x < 1 on the faces next to it).
    #[test]
    fn marked_cells_move_as_prescribed() {
        let bc = [[Dirichlet; 2]; 3];
        let g = Grid::new([0.0; 3], [1.0; 3], [2, 2, 2], 3, bc).unwrap();
        let lay = g.layout();
        let mut markers = vec![0; g.num_cells()];
        for k in 3..5 {
            for j in 3..5 {
                for i in 3..5 {
                    markers[lay.cell([i, j, k])] = if i == 3 { 1 } else { -1 };
                }
            }
        }
        let mut mask = g.dirichlet_mask();
        g.mark_faces(&markers, &mut mask);
        let mut body = g.dirichlet_mask();
        body.iter_mut().for_each(|m| *m = false);
        g.mark_faces(&markers, &mut body);
        let nf = g.num_faces();
        let mut u = [0, 1, 2].map(|_| vec![0.0; nf]);
        for i in 0..nf {
            if body[i] {
                u[0][i] = 1.0;
            }
        }
        let mut p = vec![0.0; g.num_cells()];
        let f = [0, 1, 2].map(|_| vec![0.0; nf]);
        let mut solver = StokesSolver::new(&g, 1.0, mask);
        let rep = solver.solve(&mut u, &mut p, &f, 1e-9);
        println!("marked block: {rep:?}");
        assert!(rep.divergence_reduction < 1e-9);
        for i in 0..nf {
            if body[i] {
                assert_eq!(u[0][i], 1.0);
                assert_eq!(u[1][i], 0.0);
            }
        }
        // the x-face just left and right of the block, same (j, k)
        for fx in [[2, 3, 3], [6, 4, 4]] {
            let v = u[0][lay.face(0, fx)];
            assert!(v > 0.0 && v < 1.0, "u_x at {fx:?} = {v}");
        }
    }
}
