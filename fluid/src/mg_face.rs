//! Geometric multigrid for the scalar Q1~ problem `(alpha M + nu K) u = f` (one velocity
//! component: the building block of the momentum / Burgers solves).
//!
//! * Prolongation: the canonical interpolation of the coarse Q1~ function into the fine
//!   space, i.e. the fine face mean values of the coarse function, averaged over the two
//!   coarse cells where a fine face lies on a coarse face (the coarse function is
//!   discontinuous there). This is the "averaging" prolongation for nonconforming
//!   elements of Turek 1999 ("Efficient solvers for incompressible flow problems",
//!   multigrid chapter) written out for Q1~ with face means. On the reference coarse cell
//!   `[-1,1]^3` (exact integration of the basis of [`crate::element`] over the sub-faces,
//!   derivation in the comments of `FaceTransfer::new`):
//!   - fine face on the coarse face `a+` in the quadrant with signs `s_b, s_c` of the
//!     tangential coordinates: `u_{a+} + s_b/4 (u_{b+} - u_{b-}) + s_c/4 (u_{c+} - u_{c-})`;
//!   - fine face inside the coarse cell (on the plane `xi_a = 0`) in quadrant `s_b, s_c`:
//!     `1/2 (u_{b,s_b} + u_{c,s_c})`.
//! * Restriction: the transpose of the prolongation.
//! * Smoother: Gauss-Seidel in six colours (face family `a`, parity of the face index along
//!   `a`): faces of one colour never share a cell, so each colour is updated in parallel
//!   exactly as the in-place sweep would; the colours run x0 x1 y0 y1 z0 z1 before and in
//!   reverse order after the coarse-grid correction, written in place, the two colours of
//!   a family in one pass (`FaceOperator::gauss_seidel_family`).
//! * Coarse operators: rediscretised on each level; coarse-grid correction with adaptive
//!   step length as in [`crate::mg_cell`]; coarsest level: conjugate gradients.
//! * Momentum (Oseen) problems `alpha M_l + nu K + N(w)` ([`FaceMg::set_operator`],
//!   [`FaceMg::set_convection`]): the convecting velocity `w` is carried to the coarse
//!   levels by the mean of the four fine faces that make up a coarse face (exact for the
//!   face-mean degrees of freedom), and each level rediscretises `N(w)`
//!   ([`crate::ops::Convection`]). The operator is then non-symmetric: the step length
//!   of the coarse-grid correction minimises the residual, `alpha = (r, Av)/(Av, Av)`,
//!   and the coarsest level is solved by BiCGStab (van der Vorst 1992, SIAM J. Sci. Stat.
//!   Comput. 13:631) to 1e-10 relative.
//!
//! Dirichlet faces (box sides of kind Dirichlet on every level, plus any extra mask given
//! for the finest level such as fictitious-boundary markers) keep their values: they have
//! zero residual and receive no correction.
//!
//! `FaceMg<M>` solves `M` problems with the same operator at once (the three velocity
//! components of a momentum step, [`FaceMg::solve_all`]): the level vectors hold the `M`
//! values of a face side by side ([`crate::ops::Lanes`]), so each smoothing sweep,
//! residual and transfer reads the operator's tables and the transfer's index lists once
//! for all `M`. Every vector sees the arithmetic of a one-vector solve; the step length of
//! the coarse-grid correction and the coarsest-level solve are per vector, and the cycles
//! run until every vector has met the tolerance.

use crate::grid::Grid;
use crate::mg_cell::MgReport;
use crate::ops::{min_rows, others, serial_dot, FaceOperator, CHUNK};
use rayon::prelude::*;
use std::time::Instant;

/// Multigrid cycle type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cycle {
    /// One coarse-grid visit per level.
    V,
    /// Two coarse-grid visits per level.
    W,
}

/// Sparse rows `(coarse index, weight)` of the prolongation, one row per fine face. The
/// weights (1, 1/2, +-1/4, +-1/8) are exact in `f32`: stored so, an entry takes 8 bytes
/// instead of 16 (a transfer reads about five per fine face) for the same arithmetic.
struct FaceTransfer {
    start: Vec<usize>,
    entries: Vec<(u32, f32)>,
    /// Transpose: for each coarse face its `(fine index, weight)` in increasing fine index.
    t_start: Vec<usize>,
    t_entries: Vec<(u32, f32)>,
}

impl FaceTransfer {
    /// The prolongation from `coarse` to `fine` (`fine` one level finer), empty rows on the
    /// faces masked in `fine_mask`.
    ///
    /// Derivation (reference coarse cell `[-1,1]^3`, basis
    /// `phi_{a+-} = 1/6 +- xi_a/2 + (2 xi_a^2 - xi_b^2 - xi_c^2)/4`, means over the quadrant
    /// `xi_b in [0,1], xi_c in [0,1]` where `mean(xi) = 1/2`, `mean(xi^2) = 1/3`):
    /// on `xi_a = 1`: `phi_{a+} = 1/6 + 1/2 + (2 - 2/3)/4 = 1`, `phi_{a-} = 0`,
    /// `phi_{b+-} = 1/6 +- 1/4 + (2/3 - 1 - 1/3)/4 = +-1/4`;
    /// on `xi_a = 0`: `phi_{a+-} = 1/6 - (2/3)/4 = 0`,
    /// `phi_{b+-} = 1/6 +- 1/4 + (2/3 - 1/3)/4 = 1/4 +- 1/4`. Other quadrants by symmetry.
    fn new(coarse: &Grid, fine: &Grid, fine_mask: &[bool]) -> Self {
        let cl = coarse.layout();
        let fl = fine.layout();
        let mut start = vec![0];
        let mut entries: Vec<(u32, f32)> = Vec::new();
        for a in 0..3 {
            for idx in 0..fl.off[a + 1] - fl.off[a] {
                let fi = fl.off[a] + idx;
                if !fine_mask[fi] {
                    let f = fl.face_coords(a, idx);
                    let half = f.map(|v| v / 2);
                    let sign = f.map(|v| if v % 2 == 1 { 1.0 } else { -1.0 });
                    if f[a] % 2 == 0 {
                        // on a coarse face: average over the adjacent coarse cells
                        let cells: Vec<[usize; 3]> =
                            cl.face_cells(a, half).into_iter().flatten().collect();
                        let w = 1.0 / cells.len() as f64;
                        entries.push((cl.face(a, half) as u32, 1.0));
                        for c in cells {
                            for b in others(a) {
                                let q = (w * sign[b] / 4.0) as f32;
                                entries.push((cl.face(b, cl.upper(b, c)) as u32, q));
                                entries.push((cl.face(b, c) as u32, -q));
                            }
                        }
                    } else {
                        // inside the coarse cell `half`
                        for b in others(a) {
                            let face = if sign[b] > 0.0 {
                                cl.upper(b, half)
                            } else {
                                half
                            };
                            entries.push((cl.face(b, face) as u32, 0.5));
                        }
                    }
                }
                start.push(entries.len());
            }
        }
        // transpose, rows in increasing fine index
        let nc = cl.num_faces();
        let mut count = vec![0usize; nc + 1];
        for &(q, _) in &entries {
            count[q as usize + 1] += 1;
        }
        for q in 0..nc {
            count[q + 1] += count[q];
        }
        let t_start = count.clone();
        let mut t_entries = vec![(0u32, 0.0f32); entries.len()];
        let mut fill = count;
        for fi in 0..start.len() - 1 {
            for &(q, w) in &entries[start[fi]..start[fi + 1]] {
                t_entries[fill[q as usize]] = (fi as u32, w);
                fill[q as usize] += 1;
            }
        }
        FaceTransfer {
            start,
            entries,
            t_start,
            t_entries,
        }
    }

    /// `x = P xc` (each of the `M` vectors), zero on the faces flagged in `mask`: one pass
    /// for what were three (zeroing `x`, adding `P xc`, zeroing the masked faces). The
    /// free faces get `0 + (P xc)_i`, the sum added to a zeroed vector (so that a sum of
    /// `-0` gives `+0` as it did).
    fn prolong<const M: usize>(&self, xc: &[[f64; M]], x: &mut [[f64; M]], mask: &[bool]) {
        x.par_iter_mut()
            .with_min_len(min_rows(1))
            .enumerate()
            .for_each(|(fi, o)| {
                *o = [0.0; M];
                if mask[fi] {
                    return;
                }
                let row = &self.entries[self.start[fi]..self.start[fi + 1]];
                let mut s = [0.0; M];
                for &(q, w) in row {
                    let (v, w) = (&xc[q as usize], f64::from(w));
                    for m in 0..M {
                        s[m] += w * v[m];
                    }
                }
                for m in 0..M {
                    o[m] += s[m];
                }
            });
    }

    /// `rc = P^T r`, zero on the coarse faces masked in `coarse_mask`.
    fn restrict<const M: usize>(&self, r: &[[f64; M]], rc: &mut [[f64; M]], coarse_mask: &[bool]) {
        rc.par_iter_mut()
            .with_min_len(min_rows(1))
            .enumerate()
            .for_each(|(q, o)| {
                *o = [0.0; M];
                if !coarse_mask[q] {
                    let col = &self.t_entries[self.t_start[q]..self.t_start[q + 1]];
                    for &(fi, w) in col {
                        let (v, w) = (&r[fi as usize], f64::from(w));
                        for m in 0..M {
                            o[m] += w * v[m];
                        }
                    }
                }
            });
    }
}

struct FaceLevel<const M: usize> {
    grid: Grid,
    op: FaceOperator,
    mask: Vec<bool>,
    transfer: Option<FaceTransfer>,
    x: Vec<[f64; M]>,
    b: Vec<[f64; M]>,
    r: Vec<[f64; M]>,
    tmp: Vec<[f64; M]>,
    av: Vec<[f64; M]>,
}

/// Per-vector `sum_i a_i b_i` of `M` interleaved vectors, summed in the fixed chunks of
/// [`crate::ops::dot`] (independent of the thread count).
fn dot_lanes<const M: usize>(a: &[[f64; M]], b: &[[f64; M]]) -> [f64; M] {
    let partial: Vec<[f64; M]> = a
        .par_chunks(CHUNK)
        .zip(b.par_chunks(CHUNK))
        .map(|(x, y)| {
            let mut s = [0.0; M];
            for (p, q) in x.iter().zip(y) {
                for m in 0..M {
                    s[m] += p[m] * q[m];
                }
            }
            s
        })
        .collect();
    let mut s = [0.0; M];
    for p in &partial {
        for m in 0..M {
            s[m] += p[m];
        }
    }
    s
}

/// Multigrid for `(alpha M + nu K) u = f` on levels 1 to `grid.level`, for `M` vectors at
/// once (see the module docs).
pub struct FaceMg<const M: usize = 1> {
    levels: Vec<FaceLevel<M>>,
    /// Pre- and post-smoothing sweeps (each sweep: all six colours).
    pub smoothing: (usize, usize),
    /// Cycle type.
    pub cycle: Cycle,
}

impl FaceMg<1> {
    /// Hierarchy for `alpha M + nu K` on `grid` for one vector (see [`FaceMg::with_mask`]).
    pub fn new(grid: &Grid, alpha: f64, nu: f64, mask: Vec<bool>) -> Self {
        Self::with_mask(grid, alpha, nu, mask)
    }

    /// Solves from the initial `x` (whose masked entries are the prescribed values) until
    /// the residual of the free faces drops by `rtol` or `max_cycles` cycles were done.
    pub fn solve(&mut self, x: &mut [f64], b: &[f64], rtol: f64, max_cycles: usize) -> MgReport {
        let [rep] = self.solve_all([x], [b], rtol, max_cycles);
        rep
    }
}

impl<const M: usize> FaceMg<M> {
    /// Hierarchy for `alpha M + nu K` on `grid`; `mask` flags the finest-level faces whose
    /// values are prescribed (at least [`Grid::dirichlet_mask`]). Coarse levels use the box
    /// boundary conditions only.
    pub fn with_mask(grid: &Grid, alpha: f64, nu: f64, mask: Vec<bool>) -> Self {
        assert_eq!(mask.len(), grid.num_faces(), "mask: one flag per face");
        let mut grids = vec![grid.clone()];
        while let Some(c) = grids.last().unwrap().coarser() {
            grids.push(c);
        }
        grids.reverse();
        let nl = grids.len();
        let levels = grids
            .iter()
            .enumerate()
            .map(|(l, g)| {
                let n = g.num_faces();
                let mask = if l + 1 == nl {
                    mask.clone()
                } else {
                    g.dirichlet_mask()
                };
                // the prolongation leaves out the box's prescribed faces only; the other
                // masked faces of the finest level are zeroed after it, so that
                // [`FaceMg::set_mask`] needs no new transfer
                let transfer = g
                    .coarser()
                    .map(|c| FaceTransfer::new(&c, g, &g.dirichlet_mask()));
                FaceLevel {
                    grid: g.clone(),
                    op: FaceOperator::helmholtz(g, alpha, nu),
                    mask,
                    transfer,
                    x: vec![[0.0; M]; n],
                    b: vec![[0.0; M]; n],
                    r: vec![[0.0; M]; n],
                    tmp: vec![[0.0; M]; n],
                    av: vec![[0.0; M]; n],
                }
            })
            .collect();
        FaceMg {
            levels,
            smoothing: (2, 2),
            cycle: Cycle::V,
        }
    }

    /// Sets entries `(face, prescribed)` of the finest level's mask (which must keep at
    /// least [`Grid::dirichlet_mask`]), e.g. after particles moved; the hierarchy is kept.
    pub fn update_mask(&mut self, entries: impl Iterator<Item = (usize, bool)>) {
        let fine = self.levels.last_mut().expect("one level at least");
        for (f, m) in entries {
            fine.mask[f] = m;
        }
    }

    /// Replaces the operators of all levels by `alpha M + nu K` (consistent mass) or
    /// `alpha M_l + nu K` (`lumped`, see [`FaceOperator::lumped`]), without convection.
    pub fn set_operator(&mut self, alpha: f64, nu: f64, lumped: bool) {
        for l in &mut self.levels {
            l.op = if lumped {
                FaceOperator::lumped(&l.grid, alpha, nu)
            } else {
                FaceOperator::helmholtz(&l.grid, alpha, nu)
            };
        }
    }

    /// As [`FaceMg::set_operator`] with the lumped mass, `alpha M_l + nu_stiff K`, with the
    /// Samarskij weights of a later [`FaceMg::set_convection`] computed with `nu_upwind`.
    pub fn set_operator_split(&mut self, alpha: f64, nu_stiff: f64, nu_upwind: f64) {
        for l in &mut self.levels {
            let op =
                FaceOperator::lumped(&l.grid, alpha, nu_stiff).with_upwind_viscosity(nu_upwind);
            let old = std::mem::replace(&mut l.op, op);
            l.op.recycle(old);
        }
    }

    /// Adds the linearised convection `N(w)` of the finest-level velocity `w` to the
    /// operators of all levels (keeping `alpha` and `nu` of [`FaceMg::set_operator`]); `w`
    /// reaches the coarser levels as the mean of the four fine faces of each coarse face.
    pub fn set_convection(&mut self, w: [&[f64]; 3]) {
        let mut cur: Option<[Vec<f64>; 3]> = None;
        for k in (0..self.levels.len()).rev() {
            let l = &mut self.levels[k];
            let wk = cur.as_ref().map_or(w, |c| [&c[0][..], &c[1], &c[2]]);
            let op = std::mem::replace(&mut l.op, FaceOperator::helmholtz(&l.grid, 0.0, 0.0));
            l.op = op.with_convection(&l.grid, wk);
            if let Some(coarse) = l.grid.coarser() {
                let fine = l.grid.layout();
                cur = Some(wk.map(|c| restrict_face_means(&coarse, &fine, c)));
            }
        }
    }

    /// Adds `v` to the finest level's diagonal entry of every listed face `(face, v)`
    /// (after [`FaceMg::set_convection`], which drops earlier additions). The coarse
    /// levels do not see them, as they do not see the finest level's extra mask: the
    /// smoother resolves these strongly diagonal rows.
    pub fn add_fine_diagonal(&mut self, entries: impl Iterator<Item = (usize, f64)>) {
        let fine = self.levels.last_mut().expect("at least one level");
        fine.op.add_to_diagonal(entries);
    }

    /// The finest-level operator.
    pub fn operator(&self) -> &FaceOperator {
        &self.levels.last().unwrap().op
    }

    /// The finest-level Dirichlet mask.
    pub fn mask(&self) -> &[bool] {
        &self.levels.last().unwrap().mask
    }

    /// Solves the `M` problems `A x_m = b_m` from the initial `x_m` (whose masked entries
    /// are the prescribed values) with common cycles, until the residual of the free faces
    /// of every one has dropped by `rtol` or `max_cycles` cycles were done. One report per
    /// vector (its residuals; the cycles and seconds are those of the common solve).
    pub fn solve_all(
        &mut self,
        x: [&mut [f64]; M],
        b: [&[f64]; M],
        rtol: f64,
        max_cycles: usize,
    ) -> [MgReport; M] {
        let fine = self.levels.len() - 1;
        let start = Instant::now();
        let l = &mut self.levels[fine];
        l.x.par_iter_mut()
            .with_min_len(min_rows(1))
            .enumerate()
            .for_each(|(i, o)| *o = std::array::from_fn(|m| x[m][i]));
        l.b.par_iter_mut()
            .with_min_len(min_rows(1))
            .enumerate()
            .for_each(|(i, o)| *o = std::array::from_fn(|m| b[m][i]));
        l.op.residual(&l.x, &l.b, &l.mask, &mut l.r);
        let r0 = dot_lanes(&l.r, &l.r).map(f64::sqrt);
        let mut rep: [MgReport; M] = std::array::from_fn(|m| MgReport {
            initial_residual: r0[m],
            final_residual: r0[m],
            ..Default::default()
        });
        let mut cycles = 0;
        while cycles < max_cycles
            && rep
                .iter()
                .any(|r| r.final_residual > rtol * r.initial_residual)
        {
            self.cycle(fine);
            let l = &mut self.levels[fine];
            l.op.residual(&l.x, &l.b, &l.mask, &mut l.r);
            let rr = dot_lanes(&l.r, &l.r);
            for (r, v) in rep.iter_mut().zip(rr) {
                r.final_residual = v.sqrt();
            }
            cycles += 1;
        }
        let l = &self.levels[fine];
        for (m, xm) in x.into_iter().enumerate() {
            xm.par_iter_mut()
                .with_min_len(min_rows(1))
                .enumerate()
                .for_each(|(i, o)| *o = l.x[i][m]);
        }
        let seconds = start.elapsed().as_secs_f64();
        for r in &mut rep {
            r.cycles = cycles;
            r.seconds = seconds;
            r.finish();
        }
        rep
    }

    fn smooth(l: &mut FaceLevel<M>, sweeps: usize, forward: bool) {
        // colours x0 x1 y0 y1 z0 z1, backwards z1 z0 y1 y0 x1 x0
        let (order, first) = if forward {
            ([0, 1, 2], 0)
        } else {
            ([2, 1, 0], 1)
        };
        for _ in 0..sweeps {
            for a in order {
                l.op.gauss_seidel_family(a, first, &mut l.x, &l.b, &l.mask);
            }
        }
    }

    /// One cycle on level `k` for `levels[k].x` with right-hand side `levels[k].b`.
    fn cycle(&mut self, k: usize) {
        if k == 0 {
            let l = &mut self.levels[0];
            let n = l.x.len();
            let (mut x, mut b) = (vec![0.0; n], vec![0.0; n]);
            for m in 0..M {
                for ((xi, bi), (lx, lb)) in x.iter_mut().zip(&mut b).zip(l.x.iter().zip(&l.b)) {
                    (*xi, *bi) = (lx[m], lb[m]);
                }
                if l.op.has_convection() {
                    coarse_bicgstab(&l.op, &l.mask, &mut x, &b);
                } else {
                    coarse_cg(&l.op, &l.mask, &mut x, &b);
                }
                for (lx, xi) in l.x.iter_mut().zip(&x) {
                    lx[m] = *xi;
                }
            }
            return;
        }
        let (nu1, nu2) = self.smoothing;
        let visits = match self.cycle {
            Cycle::V => 1,
            Cycle::W => 2,
        };
        {
            let (lower, upper) = self.levels.split_at_mut(k);
            let fine = &mut upper[0];
            let coarse = &mut lower[k - 1];
            Self::smooth(fine, nu1, true);
            fine.op.residual(&fine.x, &fine.b, &fine.mask, &mut fine.r);
            let tr = fine.transfer.as_ref().expect("level > 1");
            tr.restrict(&fine.r, &mut coarse.b, &coarse.mask);
            coarse.x.iter_mut().for_each(|v| *v = [0.0; M]);
        }
        for _ in 0..visits {
            self.cycle(k - 1);
        }
        let (lower, upper) = self.levels.split_at_mut(k);
        let fine = &mut upper[0];
        let coarse = &lower[k - 1];
        let tr = fine.transfer.as_ref().expect("level > 1");
        // adaptive step length: x += alpha v, v = P e_c, alpha = (r, v) / (A v, v)
        tr.prolong(&coarse.x, &mut fine.tmp, &fine.mask);
        fine.op
            .apply_masked(&fine.tmp, Some(&fine.mask), &mut fine.av);
        // symmetric: energy-minimising step; with convection: residual-minimising step
        let (num, den) = if fine.op.has_convection() {
            (dot_lanes(&fine.r, &fine.av), dot_lanes(&fine.av, &fine.av))
        } else {
            (
                dot_lanes(&fine.r, &fine.tmp),
                dot_lanes(&fine.av, &fine.tmp),
            )
        };
        let alpha: [f64; M] =
            std::array::from_fn(|m| if den[m] > 0.0 { num[m] / den[m] } else { 1.0 });
        fine.x
            .par_iter_mut()
            .zip(fine.tmp.par_iter())
            .for_each(|(y, v)| {
                for m in 0..M {
                    y[m] += alpha[m] * v[m];
                }
            });
        Self::smooth(fine, nu2, false);
    }
}

/// Coarse face values as the mean of the four fine faces covering each coarse face
/// (`fine` one level finer than `coarse`; the face-mean of a field over a coarse face is
/// exactly the mean of its four sub-face means).
fn restrict_face_means(coarse: &Grid, fine: &crate::grid::Layout, x: &[f64]) -> Vec<f64> {
    let cl = coarse.layout();
    let mut out = vec![0.0; cl.num_faces()];
    for a in 0..3 {
        let range = cl.off[a]..cl.off[a + 1];
        out[range].par_iter_mut().enumerate().for_each(|(idx, o)| {
            let fc = cl.face_coords(a, idx);
            let [b, c] = others(a);
            let mut s = 0.0;
            for db in 0..2 {
                for dc in 0..2 {
                    let mut f = fc.map(|v| 2 * v);
                    f[b] += db;
                    f[c] += dc;
                    s += x[fine.face(a, f)];
                }
            }
            *o = 0.25 * s;
        });
    }
    out
}

/// Most BiCGStab steps of a coarsest-level solve. The drag case's coarsest level (16,560
/// faces) needs at most 65 at Re = 50 and 150; a coarse problem that BiCGStab cannot
/// bring to 1e-10 (a momentum operator too central for its grid: upwind scale 0.05 at
/// Re = 150) took 2 n = 33,120 steps at every visit, minutes per fluid step, before this
/// bound. The multigrid cycle only needs an approximate coarse correction.
const COARSE_BICGSTAB_STEPS: usize = 1000;

/// BiCGStab on the free faces of the coarsest level (1e-10 relative, at most
/// [`COARSE_BICGSTAB_STEPS`] steps; serial: the coarsest level is small).
fn coarse_bicgstab(op: &FaceOperator, mask: &[bool], x: &mut [f64], b: &[f64]) {
    let n = x.len();
    let mut r = vec![0.0; n];
    op.residual(x, b, mask, &mut r);
    let r0 = r.clone();
    let mut p = r.clone();
    let mut v = vec![0.0; n];
    let mut s = vec![0.0; n];
    let mut t = vec![0.0; n];
    let mut rho = serial_dot(&r0, &r);
    let stop = 1e-20 * serial_dot(&r, &r);
    for _ in 0..(2 * n).min(COARSE_BICGSTAB_STEPS) {
        if serial_dot(&r, &r) <= stop || rho == 0.0 {
            break;
        }
        op.apply_masked(&p, Some(mask), &mut v);
        let alpha = rho / serial_dot(&r0, &v);
        for i in 0..n {
            s[i] = r[i] - alpha * v[i];
        }
        op.apply_masked(&s, Some(mask), &mut t);
        let tt = serial_dot(&t, &t);
        let omega = if tt > 0.0 {
            serial_dot(&t, &s) / tt
        } else {
            0.0
        };
        for i in 0..n {
            x[i] += alpha * p[i] + omega * s[i];
            r[i] = s[i] - omega * t[i];
        }
        let rho_new = serial_dot(&r0, &r);
        if omega == 0.0 {
            break;
        }
        let beta = rho_new / rho * alpha / omega;
        rho = rho_new;
        for i in 0..n {
            p[i] = r[i] + beta * (p[i] - omega * v[i]);
        }
    }
}

/// Conjugate gradients on the free faces of the coarsest level (1e-12 relative).
fn coarse_cg(op: &FaceOperator, mask: &[bool], x: &mut [f64], b: &[f64]) {
    let n = x.len();
    let mut r = vec![0.0; n];
    op.residual(x, b, mask, &mut r);
    let mut d = r.clone();
    let mut q = vec![0.0; n];
    let mut rr = serial_dot(&r, &r);
    let stop = 1e-24 * rr;
    for _ in 0..10 * n {
        if rr <= stop || rr == 0.0 {
            break;
        }
        op.apply_masked(&d, Some(mask), &mut q);
        let alpha = rr / serial_dot(&d, &q);
        for i in 0..n {
            x[i] += alpha * d[i];
            r[i] -= alpha * q[i];
        }
        let rr_new = serial_dot(&r, &r);
        let beta = rr_new / rr;
        rr = rr_new;
        d.iter_mut().zip(&r).for_each(|(d, r)| *d = r + beta * *d);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::BoundaryKind::*;

    /// The prolongation reproduces the Q1~ interpolants of linear functions exactly (the
    /// coarse Q1~ function of a linear field is the field itself, so its fine face means
    /// are the fine interpolant), on all faces including box sides and periodic wraps.
    #[test]
    fn prolongation_is_exact_for_linear_functions() {
        let bc = [[Dirichlet; 2], [DoNothing; 2], [DoNothing, Dirichlet]];
        let fine = Grid::new([0.0, 1.0, -1.0], [1.0, 1.5, 0.0], [2, 3, 2], 2, bc).unwrap();
        let coarse = fine.coarser().unwrap();
        let lin = |x: [f64; 3]| 1.0 + 2.0 * x[0] - 3.0 * x[1] + 0.5 * x[2];
        let interp = |g: &Grid| {
            let lay = g.layout();
            (0..3)
                .flat_map(|a| {
                    (0..lay.off[a + 1] - lay.off[a])
                        .map(move |idx| lin(g.face_centre(a, lay.face_coords(a, idx))))
                })
                .collect::<Vec<f64>>()
        };
        let uc = interp(&coarse);
        let uf = interp(&fine);
        let tr = FaceTransfer::new(&coarse, &fine, &vec![false; fine.num_faces()]);
        let uc: Vec<[f64; 1]> = uc.into_iter().map(|v| [v]).collect();
        let mut x = vec![[0.0]; fine.num_faces()];
        tr.prolong(&uc, &mut x, &vec![false; fine.num_faces()]);
        for i in 0..x.len() {
            assert!(
                (x[i][0] - uf[i]).abs() < 1e-13,
                "face {i}: {} vs {}",
                x[i][0],
                uf[i]
            );
        }
    }

    fn rate(alpha: f64, nu: f64, level: u32, cycle: Cycle) -> MgReport {
        let bc = [[Dirichlet; 2], [Dirichlet; 2], [Periodic; 2]];
        let g = Grid::new([0.0; 3], [1.0; 3], [2, 2, 2], level, bc).unwrap();
        let mut mg = FaceMg::new(&g, alpha, nu, g.dirichlet_mask());
        mg.cycle = cycle;
        let n = g.num_faces();
        let b: Vec<f64> = (0..n)
            .map(|c| ((c as f64 * 12.9898).sin() * 43_758.545).fract())
            .collect();
        let mut x = vec![0.0; n];
        mg.solve(&mut x, &b, 1e-10, 60)
    }

    /// Multigrid convergence (level-independent rate, Hackbusch 1985) for the Q1~ Poisson
    /// problem (alpha = 0) and for the Helmholtz problem of an implicit time step
    /// (alpha = 1/dt = 1000, nu = 1 on the unit box: mass and stiffness of the same size on
    /// the finest levels), walls in x and y, periodic in z, levels 2 to 4: the mean
    /// reduction per V(2,2) cycle stays below 0.2.
    #[test]
    fn helmholtz_multigrid_rates() {
        for (name, alpha, nu) in [("Poisson", 0.0, 1.0), ("Helmholtz", 1000.0, 1.0)] {
            for level in 2..=4 {
                let rep = rate(alpha, nu, level, Cycle::V);
                println!(
                    "Q1~ MG {name:9} level {level}: {} V(2,2) cycles, rho = {:.4}, {:.3} s",
                    rep.cycles, rep.reduction, rep.seconds
                );
                assert!(rep.final_residual <= 1e-10 * rep.initial_residual);
                assert!(rep.reduction <= 0.2, "{name} {level}: {}", rep.reduction);
            }
        }
    }
}
