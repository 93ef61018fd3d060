//! Matrix-free stencil operators of the Q1~/Q0 pair on one uniform level.
//!
//! * [`FaceOperator`]: the scalar Q1~ operator `alpha M + nu K` (mass plus viscous
//!   stiffness) acting on one velocity component, assembled on the fly from the constant
//!   element matrices of [`crate::element`]. The rows are evaluated along the contiguous
//!   `i` rows of each face family: faces away from the box sides and periodic wraps share
//!   their neighbour offsets (one specialised loop per row, `FaceOperator::for_row`),
//!   and with convection a per-face table holds the diagonal and the signed fluxes and
//!   weights, computed once with the same operations as the generic row. A face with one adjacent cell (a box side that
//!   is not periodic) gets only that cell's contribution: the natural (do-nothing)
//!   condition. Dirichlet faces are handled by the callers through a mask (their rows are
//!   never solved for; their values enter the other rows as known data).
//! * [`add_gradient`] (`B`) and [`divergence`] (`D = -B^T`): from the weak form
//!   `-(p, div v)` and `int_T d phi_F / dx_a = |F| n_a(F)`,
//!   `(B p)_F = |F| (p_plus - p_minus)` on the normal component of face `F` and
//!   `(D u)_T = sum_a |F_a| (u_a(F_a+) - u_a(F_a-))` (the flux out of `T`). A missing cell
//!   outside a do-nothing side counts as pressure 0; a given boundary pressure enters
//!   through [`add_boundary_pressure`].
//! * [`CellOperator`]: the pressure Schur complement `P = B^T M_l^{-1} B` with the lumped
//!   mass `M_l` (`V/6` per adjacent cell of a face): a 7-point operator with coefficient
//!   `|F_a|^2 / (V/3) = 3 |F_a|^2 / V` between neighbouring cells across an `a`-face, `0`
//!   across a Dirichlet (wall) side where `B` has no row, and `|F_a|^2 / (V/6)` on the
//!   diagonal only across a do-nothing side.
//!
//! All loops run over rows of contiguous unknowns with rayon; each output entry is
//! written by exactly one task and reductions use a fixed chunking ([`dot`]), so results
//! do not depend on the number of threads.

use crate::element::{mass_entries, stiffness_entries, transpose_stiffness_entries};
use crate::grid::{BoundaryKind, Grid, Layout};
use rayon::prelude::*;

/// Chunk length of the deterministic reductions.
pub(crate) const CHUNK: usize = 4096;

/// `sum_i a_i b_i`, summed in fixed chunks (independent of the thread count).
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    let partial: Vec<f64> = a
        .par_chunks(CHUNK)
        .zip(b.par_chunks(CHUNK))
        .map(|(x, y)| x.iter().zip(y).map(|(p, q)| p * q).sum::<f64>())
        .collect();
    partial.iter().sum()
}

/// `sum_i a_i b_i` in one serial loop (small vectors).
pub fn serial_dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(p, q)| p * q).sum()
}

/// Minimum unknowns per parallel task: smaller levels run in one task.
const MIN_TASK: usize = 8192;

/// Minimum number of rows of length `row_len` per parallel task.
pub(crate) fn min_rows(row_len: usize) -> usize {
    (MIN_TASK / row_len.max(1)).max(1)
}

/// `sum_i a_i`, summed in fixed chunks.
pub fn sum(a: &[f64]) -> f64 {
    let partial: Vec<f64> = a.par_chunks(CHUNK).map(|x| x.iter().sum::<f64>()).collect();
    partial.iter().sum()
}

/// `y += s x`.
pub fn axpy(s: f64, x: &[f64], y: &mut [f64]) {
    y.par_iter_mut()
        .zip(x.par_iter())
        .for_each(|(y, x)| *y += s * x);
}

/// Subtracts the mean of `x` (the pressure constant of an enclosed flow).
pub fn remove_mean(x: &mut [f64]) {
    let m = sum(x) / x.len() as f64;
    x.par_iter_mut().for_each(|v| *v -= m);
}

/// The other two directions of `a`.
#[inline]
pub(crate) fn others(a: usize) -> [usize; 2] {
    [(a + 1) % 3, (a + 2) % 3]
}

/// The value at one face of `M` vectors that share an operator (the velocity components of
/// a momentum solve): `f64` for one vector, `[f64; M]` for `M` vectors stored interleaved,
/// so that one pass over the operator's tables serves all of them.
pub trait Lanes<const M: usize>: Copy + Send + Sync {
    /// The `M` values.
    fn lanes(self) -> [f64; M];
    /// From `M` values.
    fn from_lanes(v: [f64; M]) -> Self;
}

impl Lanes<1> for f64 {
    #[inline(always)]
    fn lanes(self) -> [f64; 1] {
        [self]
    }
    #[inline(always)]
    fn from_lanes(v: [f64; 1]) -> Self {
        v[0]
    }
}

impl<const M: usize> Lanes<M> for [f64; M] {
    #[inline(always)]
    fn lanes(self) -> [f64; M] {
        self
    }
    #[inline(always)]
    fn from_lanes(v: [f64; M]) -> Self {
        v
    }
}

/// The scalar Q1~ operator `alpha M + nu K (+ N(w))` on one level (matrix-free), with the
/// consistent or the lumped mass matrix and an optional linearised convection `N(w)` (see
/// [`Convection`]).
#[derive(Debug, Clone)]
pub struct FaceOperator {
    pub layout: Layout,
    /// Element entry of a face with itself, per family.
    same: [f64; 3],
    /// Element entry of a face with the opposite face of the cell, per family.
    opp: [f64; 3],
    /// Element entry of a face of family `a` with a face of family `b` of the same cell.
    adj: [[f64; 3]; 3],
    /// Viscosity of the stiffness part (the Samarskij weights of the convection use it).
    nu: f64,
    /// Linearised convection, if any.
    conv: Option<Convection>,
    /// With convection, per face: the diagonal entry, then per adjacent cell (in the order
    /// minus, plus of the existing cells) the five coefficients of [`side_coefficients`]
    /// (see [`FaceOperator::fill_face_table`]).
    faces: Vec<[f64; FACE_RECORD]>,
    /// Storage of a convection dropped by [`FaceOperator::recycle`], for the next
    /// [`FaceOperator::with_convection`]; never read as data.
    spare_cells: Vec<[f64; 24]>,
}

/// Length of a face's record in the convection table: the diagonal and five coefficients
/// per adjacent cell.
const FACE_RECORD: usize = 11;

/// The off-diagonal coefficients that one adjacent cell gives the row of a face with
/// convection, `(c_opp, c_0, c_1, c_2, c_3)` of the opposite face and the four faces of the
/// other families (`b0` lower/upper, `b1` lower/upper): with the element entries `opp`,
/// `adj = (A_ab0, A_ab1)` and the pairs' fluxes `d_j` and upwind weights `e_j` (see
/// [`Convection`]), the row's part
/// `opp x_opp + sum_j adj x_j + sum_j d_j (2/3 x_j - rest/18) - e_j x_j` with
/// `rest = x_opp + sum_j x_j`, collected per unknown: `c_opp = opp - D/18` and
/// `c_j = adj + 2/3 d_j - e_j - D/18`, `D = sum_j d_j`.
#[inline]
fn side_coefficients(opp: f64, adj: [f64; 2], d: [f64; 4], e: [f64; 4]) -> [f64; 5] {
    let r = (d[0] + d[1] + d[2] + d[3]) / 18.0;
    let c = |j: usize| adj[j / 2] + 2.0 / 3.0 * d[j] - e[j] - r;
    [opp - r, c(0), c(1), c(2), c(3)]
}

/// `sum c_i x_i` of a face row's part from one cell ([`side_coefficients`]), in the one
/// order both the table and the generic row use.
#[inline(always)]
fn side_sum(c: &[f64], x_opp: f64, xb: [[f64; 2]; 2]) -> f64 {
    c[0] * x_opp + c[1] * xb[0][0] + c[2] * xb[0][1] + c[3] * xb[1][0] + c[4] * xb[1][1]
}

/// Index of the unordered family pair `{a, b}` (`a != b`): `{x,y}` 0, `{x,z}` 1, `{y,z}` 2.
#[inline]
fn pair_index(a: usize, b: usize) -> usize {
    a + b - 1
}

/// Linearised convection `N(w) v ~ int (w . grad) v phi_i` of the Q1~ element by fluxes
/// between the dual cells of the faces (a finite-volume form in the spirit of the upwind
/// schemes for nonconforming elements, Turek 1999, "Efficient solvers for incompressible
/// flow problems", sec. 3.2, and Schieweck & Tobiska 1989; written out here for 3D boxes).
///
/// * Dual cell of a face: the pyramids (cell centre, face) in its adjacent cells (volume
///   `V/6` each: the lumped mass). Inside a cell the pyramids of two faces `i` (family `a`,
///   outward side `s_a = +-1`) and `j` (family `b != a`, side `s_b`) meet in the triangle
///   (cell centre, common edge) with area vector from `i` to `j`
///   `A_ij = (|F_b|/4) s_b e_b - (|F_a|/4) s_a e_a` (cross product of the two edge-end
///   vectors from the centre); opposite faces' pyramids meet only in a point.
/// * Interface value: the Q1~ function at the triangle centroid
///   (`xi_a = 2/3 s_a, xi_b = 2/3 s_b, xi_c = 0`), where the basis of [`crate::element`]
///   gives `v_ij = 11/18 (v_i + v_j) - 1/18 (the other four faces)
///   = 2/3 (v_i + v_j) - S_T/18` with `S_T` the sum of the six face values (exact for
///   linear `v`). Flux `d_ij = A_ij . w_ij` with `w_ij` the same centroid value of `w`
///   (`d_ji = -d_ij`).
/// * Convective form on the dual cell of `i`: `int (w.grad) v = int_dD (w.n)(v - v_i)`
///   `~ sum_{T, j} d_ij (v_ij - v_i)` (the boundary face itself contributes
///   `(w.n)(v_i - v_i) = 0`), plus Samarskij's upwind weighting (Samarskij 1984, "Theorie
///   der Differenzenverfahren"; Turek 1999, sec. 3.2.3): the interface value is shifted
///   towards the upwind side by `sigma(r) = r / (2 (2 + r))` of `(v_i - v_j)`, i.e. the
///   term `e_ij (v_i - v_j)` with `e_ij = |d_ij| sigma(r_ij) >= 0`, local Peclet number
///   `r_ij = |d_ij| / (nu |A_ij| / l_ij)` (`l_ij = sqrt(h_a^2 + h_b^2)/2` the distance of
///   the two face centres). `sigma -> 0` (central, second order) for `r -> 0` and
///   `sigma -> 1/2` (full upwind, first order) for `r -> infinity`; the added diffusion
///   `|d| sigma ~ |w|^2 h^2 / nu` is of second order in `h` at a fixed viscosity.
///
/// Per cell it stores the 12 fluxes `d` (from the face of the lower family to the face of
/// the higher one) and the 12 weights `e`.
#[derive(Debug, Clone)]
pub struct Convection {
    /// `[d_0 .. d_11, e_0 .. e_11]` per cell, pair `4 pair_index + 2 s_low + s_high`
    /// (`s` = 0 lower, 1 upper face of the cell).
    cells: Vec<[f64; 24]>,
}

impl Convection {
    /// The convection of the velocity `w` (face values of its three components) on `grid`
    /// with viscosity `nu` (for the Samarskij weights; `nu = 0` gives full upwind), built
    /// in `cells`: the storage of an earlier convection (no fresh allocation, hence no page
    /// faults, on the same grid: one convection per substep), or an empty vector.
    pub fn new_in(mut cells: Vec<[f64; 24]>, grid: &Grid, nu: f64, w: [&[f64]; 3]) -> Self {
        let geometry = ConvectionGeometry::of(grid);
        // Every entry is written below.
        cells.resize(grid.num_cells(), [0.0; 24]);
        cells
            .par_iter_mut()
            .with_min_len(MIN_TASK / 24)
            .enumerate()
            .for_each(|(c, out)| *out = geometry.cell_record(nu, w, c));
        Convection { cells }
    }
}

/// What the convection records of a grid's cells share: the layout, the face areas and
/// `|A_ij| / l_ij` per family pair (see [`Convection`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct ConvectionGeometry {
    layout: Layout,
    area: [f64; 3],
    coupling: [f64; 3],
}

impl ConvectionGeometry {
    pub(crate) fn of(grid: &Grid) -> Self {
        let h = grid.h();
        let area = [0, 1, 2].map(|a| grid.face_area(a));
        let mut coupling = [0.0; 3];
        for (a, b) in [(0, 1), (0, 2), (1, 2)] {
            let amag = (area[a] * area[a] + area[b] * area[b]).sqrt() / 4.0;
            let dist = (h[a] * h[a] + h[b] * h[b]).sqrt() / 2.0;
            coupling[pair_index(a, b)] = amag / dist;
        }
        ConvectionGeometry {
            layout: grid.layout(),
            area,
            coupling,
        }
    }

    /// The record of cell `c` (fluxes `d` and weights `e`, see [`Convection`]) for the
    /// convecting velocity `w` and the viscosity `nu` of the Samarskij weights.
    #[inline]
    pub(crate) fn cell_record(&self, nu: f64, w: [&[f64]; 3], c: usize) -> [f64; 24] {
        let (lay, area, coupling) = (&self.layout, &self.area, &self.coupling);
        let mut out = [0.0; 24];
        let cc = lay.cell_coords(c);
        let faces = [0, 1, 2].map(|a| [lay.face(a, cc), lay.face(a, lay.upper(a, cc))]);
        let sum = [0, 1, 2].map(|q| faces.iter().flatten().map(|&f| w[q][f]).sum::<f64>());
        for (a, b) in [(0, 1), (0, 2), (1, 2)] {
            let k = pair_index(a, b);
            for sa in 0..2 {
                for sb in 0..2 {
                    let (fi, fj) = (faces[a][sa], faces[b][sb]);
                    let centroid = |q: usize| 2.0 / 3.0 * (w[q][fi] + w[q][fj]) - sum[q] / 18.0;
                    let sign = |s: usize| if s == 1 { 1.0 } else { -1.0 };
                    let d = area[b] / 4.0 * sign(sb) * centroid(b)
                        - area[a] / 4.0 * sign(sa) * centroid(a);
                    let e = if nu > 0.0 {
                        let r = d.abs() / (nu * coupling[k]);
                        d.abs() * r / (2.0 * (2.0 + r))
                    } else {
                        0.5 * d.abs()
                    };
                    let idx = 4 * k + 2 * sa + sb;
                    out[idx] = d;
                    out[12 + idx] = e;
                }
            }
        }
        out
    }
}

impl FaceOperator {
    /// `alpha M + nu K` with the element entries of [`mass_entries`] and
    /// [`stiffness_entries`].
    pub fn helmholtz(grid: &Grid, alpha: f64, nu: f64) -> Self {
        let (ms, mo, ma) = mass_entries(grid.cell_volume());
        let (ks, ko, ka) = stiffness_entries(grid.h());
        let mut adj = [[0.0; 3]; 3];
        for (a, row) in adj.iter_mut().enumerate() {
            for b in others(a) {
                row[b] = alpha * ma + nu * ka[a][b];
            }
        }
        FaceOperator {
            layout: grid.layout(),
            same: ks.map(|k| alpha * ms + nu * k),
            opp: ko.map(|k| alpha * mo + nu * k),
            adj,
            nu,
            conv: None,
            faces: Vec::new(),
            spare_cells: Vec::new(),
        }
    }

    /// `alpha M_l + nu K` with the lumped mass `M_l` (`V/6` per adjacent cell on the
    /// diagonal, the row sums of `M`): the momentum operator of the discrete projection
    /// schemes (Turek 1999, sec. 3.3), whose Schur complement `B^T M_l^{-1} B` is
    /// [`CellOperator`].
    pub fn lumped(grid: &Grid, alpha: f64, nu: f64) -> Self {
        let mut op = FaceOperator::helmholtz(grid, 0.0, nu);
        let v6 = grid.cell_volume() / 6.0;
        op.same.iter_mut().for_each(|s| *s += alpha * v6);
        op
    }

    /// Sets the viscosity used by the Samarskij weights of a convection added afterwards
    /// (by default the viscosity of the stiffness part), for operators whose stiffness is
    /// scaled for another reason (the stabilised lag of the deformation form).
    pub fn with_upwind_viscosity(mut self, nu: f64) -> Self {
        self.nu = nu;
        self
    }

    /// Adds the linearised convection `N(w)` of the velocity `w` (replacing any earlier).
    /// The tables of an earlier convection are refilled in place.
    pub fn with_convection(mut self, grid: &Grid, w: [&[f64]; 3]) -> Self {
        let cells = self
            .conv
            .take()
            .map_or_else(|| std::mem::take(&mut self.spare_cells), |c| c.cells);
        let conv = Convection::new_in(cells, grid, self.nu, w);
        let mut faces = std::mem::take(&mut self.faces);
        self.fill_face_table(&conv, &mut faces);
        self.faces = faces;
        self.conv = Some(conv);
        self
    }

    /// Takes over the table storage of `old` (an operator this one replaces on the same
    /// grid), so that a convection added later refills it instead of allocating: the
    /// operator itself, with or without convection, is unchanged.
    pub fn recycle(&mut self, old: FaceOperator) {
        self.faces = old.faces;
        self.spare_cells = old.conv.map_or(old.spare_cells, |c| c.cells);
    }

    /// The per-face convection table (see the field `faces`): the diagonal entry and the
    /// coefficients of [`side_coefficients`], computed with exactly the operations of
    /// [`FaceOperator::row_with`], so that the row loops read one contiguous record per face.
    fn fill_face_table(&self, conv: &Convection, out: &mut Vec<[f64; FACE_RECORD]>) {
        let lay = &self.layout;
        out.resize(lay.num_faces(), [0.0; FACE_RECORD]);
        for a in 0..3 {
            out[lay.off[a]..lay.off[a + 1]]
                .par_iter_mut()
                .with_min_len(MIN_TASK / FACE_RECORD)
                .enumerate()
                .for_each(|(idx, o)| {
                    *o = [0.0; FACE_RECORD];
                    let f = lay.face_coords(a, idx);
                    let mut diag = 0.0;
                    let mut slot = 0;
                    for (side, cell) in lay.face_cells(a, f).into_iter().enumerate() {
                        let Some(c) = cell else { continue };
                        diag += self.same[a];
                        let (coef, dg) = self.side_convection(a, side, &conv.cells[lay.cell(c)]);
                        diag += dg;
                        o[1 + 5 * slot..6 + 5 * slot].copy_from_slice(&coef);
                        slot += 1;
                    }
                    o[0] = diag;
                });
        }
    }

    /// The coefficients of [`side_coefficients`] of a face of family `a` from its cell on
    /// `side` (0: the face is the cell's upper face) with convection record `data`, and
    /// that cell's convection share `sum_j (e_j - 7/18 d_j)` of the diagonal.
    #[inline]
    fn side_convection(&self, a: usize, side: usize, data: &[f64; 24]) -> ([f64; 5], f64) {
        let sa = 1 - side;
        let [b0, b1] = others(a);
        let (mut d, mut e) = ([0.0; 4], [0.0; 4]);
        let mut diag = 0.0;
        for (q, b) in [b0, b1].into_iter().enumerate() {
            let k = pair_index(a, b);
            for sb in 0..2 {
                let (dj, ej) = convection_entry(data, a, b, k, sa, sb);
                diag += ej - 7.0 / 18.0 * dj;
                (d[2 * q + sb], e[2 * q + sb]) = (dj, ej);
            }
        }
        let coef = side_coefficients(self.opp[a], [self.adj[a][b0], self.adj[a][b1]], d, e);
        (coef, diag)
    }

    /// Adds `v` to the diagonal entry of every listed face `(face, v)` (an implicit
    /// reaction term such as the penalty of a fictitious boundary,
    /// [`crate::navier::PenaltyFace`]): the row loops of [`FaceOperator::apply`],
    /// [`FaceOperator::residual`] and the Gauss-Seidel sweeps read the diagonal from the
    /// convection table, so the hot loops are unchanged. The next
    /// [`FaceOperator::with_convection`] refills the table and drops the additions.
    /// Panics without a convection table.
    pub(crate) fn add_to_diagonal(&mut self, entries: impl Iterator<Item = (usize, f64)>) {
        assert!(
            self.conv.is_some(),
            "diagonal additions need the convection table"
        );
        for (f, v) in entries {
            self.faces[f][0] += v;
        }
    }

    /// Whether the operator carries a (non-symmetric) convection part.
    pub fn has_convection(&self) -> bool {
        self.conv.is_some()
    }

    /// Row `f` of family `a` of `A x` for the three vectors `x`, with the convection of
    /// the velocity `w` (the row of `self.with_convection(grid, w).apply(x[c], ..)`,
    /// operation for operation), from the records of the face's two cells alone, each
    /// built once: no table over the grid. `self` carries no convection of its own.
    pub(crate) fn apply_at(
        &self,
        geometry: &ConvectionGeometry,
        w: [&[f64]; 3],
        a: usize,
        f: [usize; 3],
        x: [&[f64]; 3],
    ) -> [f64; 3] {
        debug_assert!(self.conv.is_none(), "apply_at brings its own convection");
        let lay = &self.layout;
        let cells = lay.face_cells(a, f).map(|c| c.map(|c| lay.cell(c)));
        let records = cells.map(|c| c.map(|c| geometry.cell_record(self.nu, w, c)));
        let record = |c: usize| {
            let at = cells.iter().position(|&k| k == Some(c))?;
            records[at].as_ref()
        };
        let fi = lay.face(a, f);
        x.map(|xc| {
            let (diag, off) = self.row_with(a, f, |i| xc[i], record);
            diag * xc[fi] + off
        })
    }

    /// The deferred upwind correction `y = (N_s(w) - N(w)) x` at every face (three
    /// components), `N_s` and `N` the convections of `w` with the Samarskij weights of the
    /// upwind viscosities `nu_solve` and `nu_target` (see [`Convection`]): the two differ
    /// only in the added diffusion `e_ij (x_i - x_j)`. A step whose implicit operator
    /// carries `N_s` and whose right-hand side carries `y` of the old velocity has the
    /// steady states of `N` (deferred correction, Khosla & Rubin 1974, Comput. Fluids
    /// 2:207; Ferziger & Peric 2002, "Computational methods for fluid dynamics",
    /// sec. 4.4.6). Each face from its two cells alone ([`FaceOperator::apply_at`]):
    /// no table over the grid. `self` is the lumped operator without convection; `y` is
    /// written in place (storage reused from step to step).
    pub(crate) fn upwind_correction(
        &self,
        geometry: &ConvectionGeometry,
        nu_solve: f64,
        nu_target: f64,
        w: [&[f64]; 3],
        x: [&[f64]; 3],
        y: &mut Vec<[f64; 3]>,
    ) {
        let lay = &self.layout;
        let (solve, target) = (
            self.clone().with_upwind_viscosity(nu_solve),
            self.clone().with_upwind_viscosity(nu_target),
        );
        y.resize(lay.num_faces(), [0.0; 3]);
        y.par_iter_mut()
            .with_min_len(MIN_TASK / 24)
            .enumerate()
            .for_each(|(i, out)| {
                let (a, f) = lay.face_of(i);
                let (s, t) = (
                    solve.apply_at(geometry, w, a, f, x),
                    target.apply_at(geometry, w, a, f, x),
                );
                *out = [s[0] - t[0], s[1] - t[1], s[2] - t[2]];
            });
    }

    /// Diagonal entry and `sum_{j != i} A_ij x_j` of the row of face `f` of family `a`
    /// (the generic row, the reference of the row loops), with the values `x(i)` and the
    /// convection record of cell `c` from `conv(c)` (`None`: no convection).
    #[inline]
    fn row_with<R: std::borrow::Borrow<[f64; 24]>>(
        &self,
        a: usize,
        f: [usize; 3],
        x: impl Fn(usize) -> f64,
        conv: impl Fn(usize) -> Option<R>,
    ) -> (f64, f64) {
        let lay = &self.layout;
        let mut diag = 0.0;
        let mut off = 0.0;
        for (side, cell) in lay.face_cells(a, f).into_iter().enumerate() {
            let Some(c) = cell else { continue };
            diag += self.same[a];
            // the face is the upper face of the minus cell (side 0), the lower face of the
            // plus cell (side 1); the opposite face is the other one
            let opp = if side == 0 { c } else { lay.upper(a, c) };
            let x_opp = x(lay.face(a, opp));
            let [b0, b1] = others(a);
            let xb = [
                [x(lay.face(b0, c)), x(lay.face(b0, lay.upper(b0, c)))],
                [x(lay.face(b1, c)), x(lay.face(b1, lay.upper(b1, c)))],
            ];
            if let Some(data) = conv(lay.cell(c)) {
                // see [`Convection`] and [`side_coefficients`]
                let (coef, dg) = self.side_convection(a, side, data.borrow());
                diag += dg;
                off += side_sum(&coef, x_opp, xb);
            } else {
                off += self.opp[a] * x_opp;
                off += self.adj[a][b0] * (xb[0][0] + xb[0][1])
                    + self.adj[a][b1] * (xb[1][0] + xb[1][1]);
            }
        }
        (diag, off)
    }

    /// For the faces of row `(j, k)` of family `a` (face coordinates `[i, j, k]`) with
    /// `i % 2 == p` (all `i` if `parity` is `None`): `g(i, diag, off)` with the diagonal
    /// entry and `sum_{j != i} A_ij x_j` of the row for each of the `M` vectors of `x`,
    /// exactly as [`FaceOperator::row_with`] computes them (same operations in the same order,
    /// per vector as for one), with the values of `x` read from `x` (see [`Sources`]).
    /// The faces whose neighbours are shift-invariant along `i` (no box side, no periodic
    /// wrap) run through one specialised loop with precomputed index offsets, the others
    /// one by one.
    #[inline]
    pub(crate) fn for_row<const M: usize, T: Lanes<M>>(
        &self,
        a: usize,
        j: usize,
        k: usize,
        x: Sources<'_, T>,
        parity: Option<usize>,
        mut g: impl FnMut(usize, f64, [f64; M]),
    ) {
        let lay = &self.layout;
        let len = lay.fdim[a][0];
        let n0 = lay.n[0];
        // shift-invariant range [i0, i1): both cells of an x-face exist, and no upper
        // x-face wraps around a periodic x side
        let i0 = usize::from(a == 0);
        let i1 = if lay.periodic[0] { n0 - 1 } else { n0 };
        let (step, first) = match parity {
            Some(p) => (2, p),
            None => (1, 0),
        };
        // first face at or after `lo` of the selected parity
        let first_from = |lo: usize| if step == 1 { lo } else { lo + (lo + first) % 2 };
        if i1 <= i0 {
            for i in (first..len).step_by(step) {
                self.segment_at(a, j, k, x, i, i, i + 1, 1, &mut g);
            }
            return;
        }
        for i in (first..i0).step_by(step) {
            self.segment_at(a, j, k, x, i, i, i + 1, 1, &mut g);
        }
        self.segment_at(a, j, k, x, i0, first_from(i0), i1, step, &mut g);
        for i in (first_from(i1)..len).step_by(step) {
            self.segment_at(a, j, k, x, i, i, i + 1, 1, &mut g);
        }
    }

    /// [`FaceOperator::segment`] for the faces `start, start + step, .. < end` of row
    /// `(j, k)` of family `a`, with the neighbour offsets taken at face `i0` (a single face
    /// `i0 = start`, `end = start + 1` is always valid).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn segment_at<const M: usize, T: Lanes<M>>(
        &self,
        a: usize,
        j: usize,
        k: usize,
        x: Sources<'_, T>,
        i0: usize,
        start: usize,
        end: usize,
        step: usize,
        g: &mut impl FnMut(usize, f64, [f64; M]),
    ) {
        let (sides, count) = self.row_sides(a, [i0, j, k], &x);
        let fb = self.row_start(a, j, k) + i0;
        let conv = self.conv.is_some();
        match (count, conv) {
            (1, false) => {
                self.segment::<1, false, M, T>([sides[0]], a, x, fb, i0, start, end, step, g)
            }
            (2, false) => self.segment::<2, false, M, T>(sides, a, x, fb, i0, start, end, step, g),
            (1, true) => {
                self.segment::<1, true, M, T>([sides[0]], a, x, fb, i0, start, end, step, g)
            }
            (2, true) => self.segment::<2, true, M, T>(sides, a, x, fb, i0, start, end, step, g),
            _ => unreachable!("a face has one or two cells"),
        }
    }

    /// Index offsets of the adjacent cells of face `f` of family `a` (see [`RowSide`]),
    /// relative to the slices of `x` they are read from.
    #[inline]
    fn row_sides<T>(&self, a: usize, f: [usize; 3], x: &Sources<'_, T>) -> ([RowSide; 2], usize) {
        let lay = &self.layout;
        let [b0, b1] = others(a);
        let mut out = [RowSide::default(); 2];
        let mut count = 0;
        for (side, cell) in lay.face_cells(a, f).into_iter().enumerate() {
            let Some(c) = cell else { continue };
            let opp = if side == 0 { c } else { lay.upper(a, c) };
            let (o0, o1) = (x.xb[0].1, x.xb[1].1);
            out[count] = RowSide {
                side,
                opp: lay.face(a, opp) - x.opp[side].1,
                xb: [
                    lay.face(b0, c) - o0,
                    lay.face(b0, lay.upper(b0, c)) - o0,
                    lay.face(b1, c) - o1,
                    lay.face(b1, lay.upper(b1, c)) - o1,
                ],
            };
            count += 1;
        }
        (out, count)
    }

    /// The shift-invariant part of [`FaceOperator::for_row`] on family `a`: faces
    /// `i = start, start + step, ... < end`, whose neighbour indices are those of `sides`
    /// (taken at face `i0`, global index `fbase`) plus `i - i0`; the arithmetic is that of
    /// [`FaceOperator::row_with`] (with convection the diagonal comes from the face table).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn segment<const N: usize, const CONV: bool, const M: usize, T: Lanes<M>>(
        &self,
        sides: [RowSide; N],
        a: usize,
        x: Sources<'_, T>,
        fbase: usize,
        i0: usize,
        start: usize,
        end: usize,
        step: usize,
        g: &mut impl FnMut(usize, f64, [f64; M]),
    ) {
        let same = self.same[a];
        let opp_c = self.opp[a];
        let [b0, b1] = others(a);
        let (adj0, adj1) = (self.adj[a][b0], self.adj[a][b1]);
        let xo = sides.map(|s| x.opp[s.side].0);
        let [xb0, xb1] = x.xb.map(|(v, _)| v);
        for i in (start..end).step_by(step) {
            let t = i - i0;
            let mut diag = 0.0;
            let mut off = [0.0; M];
            let fc: &[f64; FACE_RECORD] = if CONV {
                &self.faces[fbase + t]
            } else {
                &[0.0; FACE_RECORD]
            };
            for (slot, s) in sides.iter().enumerate() {
                if !CONV {
                    diag += same;
                }
                let x_opp = xo[slot][s.opp + t].lanes();
                let xb = [
                    [xb0[s.xb[0] + t].lanes(), xb0[s.xb[1] + t].lanes()],
                    [xb1[s.xb[2] + t].lanes(), xb1[s.xb[3] + t].lanes()],
                ];
                for m in 0..M {
                    let xbm = [[xb[0][0][m], xb[0][1][m]], [xb[1][0][m], xb[1][1][m]]];
                    if CONV {
                        off[m] += side_sum(&fc[1 + 5 * slot..6 + 5 * slot], x_opp[m], xbm);
                    } else {
                        off[m] += opp_c * x_opp[m];
                        off[m] += adj0 * (xbm[0][0] + xbm[0][1]) + adj1 * (xbm[1][0] + xbm[1][1]);
                    }
                }
            }
            if CONV {
                diag = fc[0];
            }
            g(i, diag, off);
        }
    }

    /// Calls `g(j, k, row)` for every row (faces `[0.., j, k]`) of family `a` of `out`,
    /// rows in parallel (each output row written by one task).
    pub(crate) fn par_rows<T: Send, F>(&self, a: usize, out: &mut [T], g: F)
    where
        F: Fn(usize, usize, &mut [T]) + Sync,
    {
        let lay = &self.layout;
        let d = lay.fdim[a];
        out[lay.off[a]..lay.off[a + 1]]
            .par_chunks_mut(d[0])
            .with_min_len(min_rows(d[0]))
            .enumerate()
            .for_each(|(r, row)| g(r % d[1], r / d[1], row));
    }

    /// Index of the first face of row `(j, k)` of family `a`.
    #[inline]
    pub(crate) fn row_start(&self, a: usize, j: usize, k: usize) -> usize {
        self.layout.face(a, [0, j, k])
    }

    /// `y = A x` (for each of the `M` vectors of `x`, see [`Lanes`]).
    pub fn apply<const M: usize, T: Lanes<M>>(&self, x: &[T], y: &mut [T]) {
        self.apply_masked(x, None, y);
    }

    /// `y = A x` with the rows flagged in `mask` (if any) set to zero, in the same pass.
    pub(crate) fn apply_masked<const M: usize, T: Lanes<M>>(
        &self,
        x: &[T],
        mask: Option<&[bool]>,
        y: &mut [T],
    ) {
        for a in 0..3 {
            self.par_rows(a, y, |j, k, row| {
                let base = self.row_start(a, j, k);
                self.for_row(a, j, k, Sources::whole(x), None, |i, d, off| {
                    let fi = base + i;
                    row[i] = if mask.is_some_and(|m| m[fi]) {
                        T::from_lanes([0.0; M])
                    } else {
                        let xi = x[fi].lanes();
                        T::from_lanes(std::array::from_fn(|m| d * xi[m] + off[m]))
                    };
                });
            });
        }
    }

    /// `r = b - A x` on the free faces, `0` on the faces with `mask` set.
    pub fn residual<const M: usize, T: Lanes<M>>(
        &self,
        x: &[T],
        b: &[T],
        mask: &[bool],
        r: &mut [T],
    ) {
        for a in 0..3 {
            self.par_rows(a, r, |j, k, row| {
                let base = self.row_start(a, j, k);
                self.for_row(a, j, k, Sources::whole(x), None, |i, d, off| {
                    let fi = base + i;
                    row[i] = if mask[fi] {
                        T::from_lanes([0.0; M])
                    } else {
                        let (bi, xi) = (b[fi].lanes(), x[fi].lanes());
                        T::from_lanes(std::array::from_fn(|m| bi[m] - d * xi[m] - off[m]))
                    };
                });
            });
        }
    }

    /// The two Gauss-Seidel colours of family `a` (faces whose coordinate along `a` has
    /// parity `first`, then the others): each free face of a colour gets
    /// `(b_i - off_i) / d_i`, written into `x` in place. Faces of one colour share no cell
    /// (their rows do not couple), so the order inside a colour does not matter, and the
    /// result is that of the two colours swept one after the other over the whole family,
    /// bit for bit. Read together, the two colours fetch the family's neighbours from
    /// memory once instead of twice:
    ///
    /// * `a = 0`: the colours alternate along each row (opposite faces `i -+ 1`); a row
    ///   task sweeps the first colour, then the second, each reading the row's other
    ///   parity from a copy of the row taken before it (the row and its neighbours of the
    ///   other families are in cache for the second colour).
    /// * `a = 1, 2`: the colours alternate by row (opposite faces in the rows `-+ 1` along
    ///   `a`). A task takes a line of rows along `a` (`a = 1`: the rows `j = 0..` of one
    ///   `k`; `a = 2`: the rows `k = 0..` of one `j`) as a wavefront: row `c` of the first
    ///   colour (its neighbours `c -+ 1` not yet updated), then row `c - 1` of the second
    ///   (its neighbours `c - 2` and `c` updated); the second-colour rows at the two ends
    ///   (row 0, and the last row, whose neighbours can wrap around a periodic side) last.
    ///
    /// A row is written only by the task that owns it and read, while it is written, only
    /// by that task (the rows are borrowed mutably, the other families shared). The colours
    /// need an even number of cells along `a` if it is periodic (else the wrap couples two
    /// faces of one colour): true on every level that smooths (level 2 and finer).
    pub(crate) fn gauss_seidel_family<const M: usize, T: Lanes<M>>(
        &self,
        a: usize,
        first: usize,
        x: &mut [T],
        b: &[T],
        mask: &[bool],
    ) {
        let lay = &self.layout;
        assert!(
            !lay.periodic[a] || lay.n[a] % 2 == 0,
            "Gauss-Seidel colours: periodic direction {a} with an odd number of cells"
        );
        let d = lay.fdim[a];
        let off = lay.off;
        let (front, x2) = x.split_at_mut(off[2]);
        let (x0, x1) = front.split_at_mut(off[1]);
        let (xa, xb): (&mut [T], [(&[T], usize); 2]) = match a {
            0 => (x0, [(x1, off[1]), (x2, off[2])]),
            1 => (x1, [(x2, off[2]), (x0, off[0])]),
            _ => (x2, [(x0, off[0]), (x1, off[1])]),
        };
        // the free faces of row (j, k) of the selected parity (`None`: all), opposite
        // faces from `opp`
        let update =
            |j: usize, k: usize, row: &mut [T], opp: [(&[T], usize); 2], parity: Option<usize>| {
                let base = self.row_start(a, j, k);
                self.for_row(a, j, k, Sources { opp, xb }, parity, |i, dg, o| {
                    let fi = base + i;
                    if !mask[fi] {
                        let bi = b[fi].lanes();
                        row[i] = T::from_lanes(std::array::from_fn(|m| (bi[m] - o[m]) / dg));
                    }
                });
            };
        if a == 0 {
            xa.par_chunks_mut(d[0])
                .with_min_len(min_rows(d[0]))
                .enumerate()
                .for_each_init(Vec::new, |copy, (r, row)| {
                    let (j, k) = (r % d[1], r / d[1]);
                    let base = self.row_start(a, j, k);
                    for parity in [first, 1 - first] {
                        copy.clear();
                        copy.extend_from_slice(row);
                        update(j, k, row, [(&copy[..], base); 2], Some(parity));
                    }
                });
            return;
        }
        // row (j, k) is row c of line `line`: a = 1: (c, line) = (j, k), a = 2: (k, j)
        let coords = |line: usize, c: usize| if a == 1 { (c, line) } else { (line, c) };
        let lines = if a == 1 { d[2] } else { d[1] };
        let mut rows: Vec<Vec<&mut [T]>> = (0..lines).map(|_| Vec::new()).collect();
        for (r, row) in xa.chunks_mut(d[0]).enumerate() {
            let line = if a == 1 { r / d[1] } else { r % d[1] };
            rows[line].push(row);
        }
        let periodic = lay.periodic[a];
        rows.into_par_iter()
            .enumerate()
            .for_each(|(line, mut rows)| {
                let len = rows.len();
                let mut step = |c: usize| {
                    let (before, rest) = rows.split_at_mut(c);
                    let (row, after) = rest.split_first_mut().expect("row c exists");
                    // the rows of the opposite faces of the minus and the plus cell
                    let (mut minus, mut plus) = (before.last(), after.first());
                    if periodic {
                        minus = minus.or(after.last());
                        plus = plus.or(before.first());
                    }
                    let opp = [(minus, c + len - 1), (plus, c + 1)].map(|(r, c)| match r {
                        Some(r) => {
                            let (j, k) = coords(line, c % len);
                            (&r[..], self.row_start(a, j, k))
                        }
                        // no cell on this side: never read
                        None => (&[][..], 0),
                    });
                    let (j, k) = coords(line, c);
                    update(j, k, row, opp, None);
                };
                for c in (first..len).step_by(2) {
                    step(c);
                    if c >= 2 {
                        step(c - 1);
                    }
                }
                if first == 1 {
                    step(0);
                }
                if (len - 1) % 2 != first && len > 1 {
                    step(len - 1);
                }
            });
    }
}

/// Precomputed neighbourhood of one adjacent cell of the faces of a row segment (indices
/// at the segment's first face): the opposite face and the four faces of the other
/// families (`b0` lower/upper, `b1` lower/upper).
#[derive(Debug, Clone, Copy, Default)]
struct RowSide {
    /// Side of the face the cell lies on (0: minus, 1: plus): which of
    /// [`Sources::opp`] holds the opposite face.
    side: usize,
    opp: usize,
    xb: [usize; 4],
}

/// Where the row loops ([`FaceOperator::for_row`]) read the values of the unknowns: each
/// slice with the global face index of its first entry. The opposite faces of the minus
/// and of the plus cell of a face of family `a` come from `opp[0]` and `opp[1]`, the faces
/// of the families `others(a)` from `xb[0]` and `xb[1]`. Whole-vector passes give the
/// whole vector for all four ([`Sources::whole`]); the in-place Gauss-Seidel sweep gives
/// the rows and families it does not write ([`FaceOperator::gauss_seidel_family`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Sources<'a, T> {
    opp: [(&'a [T], usize); 2],
    xb: [(&'a [T], usize); 2],
}

impl<'a, T> Sources<'a, T> {
    /// Every value from the whole vector `x`.
    pub(crate) fn whole(x: &'a [T]) -> Self {
        Sources {
            opp: [(x, 0); 2],
            xb: [(x, 0); 2],
        }
    }
}

/// The transposed-gradient part `K_T` of the deformation-tensor viscous term:
/// `2 nu int D(u) : D(v) = nu (K u, v) + nu (K_T u, v)` with `(K_T u)_i(F) = sum_T sum_j
/// int_T du_j/dx_i dphi_F/dx_j` (element matrices of
/// [`crate::element::transpose_stiffness_entries`]). It couples the three components.
/// For a smooth divergence-free field with Dirichlet walls it is `-grad div u = 0` in the
/// continuous weak form; for the nonconforming Q1~ it is not zero (the elementwise
/// integration by parts leaves face jumps), and at a do-nothing side it changes the natural
/// condition from `nu du/dn - p n = 0` to `nu (grad u + grad u^T) n - p n = 0`.
#[derive(Debug, Clone)]
pub struct TransposeStiffness {
    layout: Layout,
    e: [[[[f64; 6]; 6]; 3]; 3],
}

impl TransposeStiffness {
    /// `K_T` of `grid`.
    pub fn new(grid: &Grid) -> Self {
        TransposeStiffness {
            layout: grid.layout(),
            e: transpose_stiffness_entries(grid.h()),
        }
    }

    /// `y += s K_T u` (all faces, masked or not). Serial loop over the cells.
    pub fn apply_add(&self, s: f64, u: [&[f64]; 3], y: [&mut [f64]; 3]) {
        let lay = &self.layout;
        let mut y = y;
        for c in 0..lay.num_cells() {
            let faces = self.cell_faces(lay.cell_coords(c));
            let local = u.map(|uj| faces.map(|f| uj[f]));
            for (i, yi) in y.iter_mut().enumerate() {
                for (f, &fi) in faces.iter().enumerate() {
                    let mut acc = 0.0;
                    for (j, lj) in local.iter().enumerate() {
                        let row = &self.e[i][j][f];
                        acc += row.iter().zip(lj).map(|(e, v)| e * v).sum::<f64>();
                    }
                    yi[fi] += s * acc;
                }
            }
        }
    }
}

impl TransposeStiffness {
    /// The six faces of cell `cc` in the order of the element entries (lower, upper per
    /// family).
    #[inline]
    fn cell_faces(&self, cc: [usize; 3]) -> [usize; 6] {
        let lay = &self.layout;
        let mut faces = [0usize; 6];
        for a in 0..3 {
            faces[2 * a] = lay.face(a, cc);
            faces[2 * a + 1] = lay.face(a, lay.upper(a, cc));
        }
        faces
    }

    /// `y += s (K_T u)_F` for the one face `F` (index `fi`, family `a`, coordinates `f`),
    /// all three components: the contributions of its cells in the order of
    /// [`TransposeStiffness::apply_add`] (cells by index, element slots in order), so the
    /// sums equal that row of it.
    pub(crate) fn add_at(
        &self,
        s: f64,
        u: [&[f64]; 3],
        (fi, a, f): (usize, usize, [usize; 3]),
        y: &mut [f64; 3],
    ) {
        let lay = &self.layout;
        // the face's cells by index, a cell on both sides (a one-cell periodic direction)
        // once
        let [m, p] = lay.face_cells(a, f).map(|c| c.map(|c| lay.cell(c)));
        let (lo, hi) = match (m, p) {
            (Some(m), Some(p)) if m != p => (Some(m.min(p)), Some(m.max(p))),
            (m, p) => (m.or(p), None),
        };
        for c in [lo, hi].into_iter().flatten() {
            let faces = self.cell_faces(lay.cell_coords(c));
            let local = u.map(|uj| faces.map(|g| uj[g]));
            for (i, yi) in y.iter_mut().enumerate() {
                for (slot, _) in faces.iter().enumerate().filter(|(_, &g)| g == fi) {
                    let mut acc = 0.0;
                    for (j, lj) in local.iter().enumerate() {
                        let row = &self.e[i][j][slot];
                        acc += row.iter().zip(lj).map(|(e, v)| e * v).sum::<f64>();
                    }
                    *yi += s * acc;
                }
            }
        }
    }
}

/// Lumped Q1~ mass of every face: `V/6` per adjacent cell (row sums of the mass matrix).
pub fn lumped_mass(grid: &Grid) -> Vec<f64> {
    let lay = grid.layout();
    let v6 = grid.cell_volume() / 6.0;
    let mut m = vec![0.0; lay.num_faces()];
    for (a, fam) in [0, 1, 2]
        .into_iter()
        .map(|a| (a, lay.off[a]..lay.off[a + 1]))
    {
        for (idx, out) in m[fam].iter_mut().enumerate() {
            let f = lay.face_coords(a, idx);
            let cells = lay.face_cells(a, f);
            *out = v6 * cells.iter().flatten().count() as f64;
        }
    }
    m
}

/// Discrete divergence `D u = -B^T u` (integrated over each cell): `out_T = sum_a |F_a| (u_a on
/// the upper a-face - u_a on the lower a-face)`.
pub fn divergence(grid: &Grid, u: [&[f64]; 3], out: &mut [f64]) {
    let lay = grid.layout();
    let area = [0, 1, 2].map(|a| grid.face_area(a));
    out.par_iter_mut().enumerate().for_each(|(c, o)| {
        let cc = lay.cell_coords(c);
        let mut s = 0.0;
        for a in 0..3 {
            s += area[a] * (u[a][lay.face(a, lay.upper(a, cc))] - u[a][lay.face(a, cc)]);
        }
        *o = s;
    });
}

/// `u_a += s (B p)_a` on the a-faces of component `a`: `(B p)_F = |F| (p_plus - p_minus)`,
/// a cell outside the box counting as `p = 0`.
pub fn add_gradient(grid: &Grid, p: &[f64], s: f64, u: [&mut [f64]; 3]) {
    let lay = grid.layout();
    for (a, ua) in u.into_iter().enumerate() {
        let area = grid.face_area(a);
        let d = lay.fdim[a];
        ua[lay.off[a]..lay.off[a + 1]]
            .par_chunks_mut(d[0])
            .enumerate()
            .for_each(|(r, row)| {
                let (j, k) = (r % d[1], r / d[1]);
                for (i, o) in row.iter_mut().enumerate() {
                    *o += s * area * pressure_jump(&lay, p, a, [i, j, k]);
                }
            });
    }
}

/// How the pressure acts on the face velocities.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PressureForce {
    /// The Galerkin form `B p` of the Q1~/P0 pair: on the normal component of each face.
    Normal,
    /// `S B p` ([`PressureShare::component`]): each interior face's force shared among
    /// its normal component and the tangential components of its neighbours.
    Shared,
}

/// `u_b += s (S B p)_b` for all three components `b` on every face: the pressure force
/// `B p` of the Q1~/P0 pair shared among the components ([`PressureShare::component`]).
pub fn add_shared_gradient(grid: &Grid, p: &[f64], s: f64, u: [&mut [f64]; 3]) {
    let share = PressureShare::of(grid);
    for (b, ub) in u.into_iter().enumerate() {
        for a in 0..3 {
            ub[share.layout.off[a]..share.layout.off[a + 1]]
                .par_iter_mut()
                .with_min_len(MIN_TASK)
                .enumerate()
                .for_each(|(idx, o)| {
                    let f = share.layout.face_coords(a, idx);
                    *o += s * share.component(p, a, f, b);
                });
        }
    }
}

/// What [`PressureShare::component`] needs of a grid: the layout and the face areas.
#[derive(Debug, Clone, Copy)]
pub struct PressureShare {
    layout: Layout,
    area: [f64; 3],
}

impl PressureShare {
    pub fn of(grid: &Grid) -> Self {
        PressureShare {
            layout: grid.layout(),
            area: [0, 1, 2].map(|a| grid.face_area(a)),
        }
    }

    /// Component `b` of the shared pressure force `(S B p)` at face `f` of family `a`.
    ///
    /// The Galerkin gradient of the P0 pressure, `(B p)_g = |F_b| (p_plus - p_minus)` on
    /// face `g` of family `b`, acts on the normal component of `g` only: the tangential
    /// components never feel the pressure, so a pressure impulse moves only the normal
    /// components, which carry a third of the fluid's lumped mass, and the pressure of an
    /// accelerating flow comes out a third of its value. A sphere released in fluid at
    /// rest then carries about a fifth of its added mass `rho_f V / 2`
    /// (tests/added_mass.rs). `S` shares each interior face's force: the face keeps a
    /// third on its normal component and gives a twelfth to component `b` of each of the
    /// eight faces of the other families in its two cells. For a smooth pressure every
    /// face away from the box sides then gets `M_l grad p` at its centre to `O(h^2)` (the
    /// four `b`-faces round a face of family `a` average the central differences of its
    /// two cells), and the pressure force on the fluid keeps its total. A face on a box
    /// side (one cell) keeps its whole force: on a do-nothing side it balances the
    /// viscous traction of the natural condition, on a Dirichlet side it is not used.
    /// The divergence constraint sees the normal part, `B p / 3` inside and `B p` on the
    /// sides: the Schur complement of [`CellOperator::shared_schur`].
    #[inline]
    pub fn component(&self, p: &[f64], a: usize, f: [usize; 3], b: usize) -> f64 {
        let lay = &self.layout;
        let interior = |b: usize, g: [usize; 3]| matches!(lay.face_cells(b, g), [Some(_), Some(_)]);
        if a == b {
            let keep = if interior(a, f) { 1.0 / 3.0 } else { 1.0 };
            return keep * self.area[a] * pressure_jump(lay, p, a, f);
        }
        // per adjacent cell: the mean force of its interior b-faces
        let cell = |c: [usize; 3]| -> f64 {
            let (mut sum, mut n) = (0.0, 0.0);
            for g in [c, lay.upper(b, c)] {
                if interior(b, g) {
                    sum += self.area[b] * pressure_jump(lay, p, b, g);
                    n += 1.0;
                }
            }
            if n > 0.0 {
                sum / (6.0 * n)
            } else {
                0.0
            }
        };
        lay.face_cells(a, f).into_iter().flatten().map(cell).sum()
    }
}

/// `p_plus - p_minus` across face `f` of family `a` (a cell outside the box counting as
/// `p = 0`): `(B p)_F = |F|` times it.
#[inline]
pub(crate) fn pressure_jump(lay: &Layout, p: &[f64], a: usize, f: [usize; 3]) -> f64 {
    let [m, pl] = lay.face_cells(a, f);
    let pm = m.map_or(0.0, |c| p[lay.cell(c)]);
    let pp = pl.map_or(0.0, |c| p[lay.cell(c)]);
    pp - pm
}

/// Adds the do-nothing boundary load `-int_G p_b n . v dA` of the constant pressures
/// `pressure[a][side]` given on the do-nothing sides to the right-hand side `rhs` of the
/// momentum equation (`+|F| p_b` at a lower side, `-|F| p_b` at an upper side).
pub fn add_boundary_pressure(grid: &Grid, pressure: [[f64; 2]; 3], rhs: [&mut [f64]; 3]) {
    let lay = grid.layout();
    for (a, ra) in rhs.into_iter().enumerate() {
        for (side, pb) in pressure[a].into_iter().enumerate() {
            if grid.bc[a][side] != BoundaryKind::DoNothing {
                continue;
            }
            let m = if side == 0 { 0 } else { lay.n[a] };
            let val = if side == 0 { 1.0 } else { -1.0 } * grid.face_area(a) * pb;
            lay.for_each_face_at(a, m, |i| ra[i] += val);
        }
    }
}

/// The cell-centred 7-point operator `P = B^T M_l^{-1} B` on one level.
#[derive(Debug, Clone)]
pub struct CellOperator {
    pub layout: Layout,
    /// Coupling across an a-face between two cells: `3 |F_a|^2 / V`.
    coef: [f64; 3],
    /// Diagonal factor of the coupling across a box side: 0 wall, 2 do-nothing (lumped
    /// mass `V/6` instead of `V/3`); unused on periodic sides.
    bfac: [[f64; 2]; 3],
    /// The couplings removed by faces held at a prescribed velocity (none: empty).
    held: HeldRows,
}

/// The part of `P` that faces held at a prescribed velocity remove
/// ([`CellOperator::hold_face_shares`]): the projection does not correct them, so they carry no
/// coupling between their cells. For each cell next to one, the diagonal to subtract and
/// the neighbours whose coupling goes.
#[derive(Debug, Clone, Default)]
struct HeldRows {
    /// Per cell the index into `rows`, `u32::MAX` for none (empty when nothing is held).
    index: Vec<u32>,
    rows: Vec<(f64, Vec<(u32, f64)>)>,
}

impl HeldRows {
    /// The row of cell `c`, made empty first if it has none.
    fn row_of(&mut self, c: usize) -> &mut (f64, Vec<(u32, f64)>) {
        if self.index[c] == u32::MAX {
            self.index[c] = self.rows.len() as u32;
            self.rows.push((0.0, Vec::new()));
        }
        &mut self.rows[self.index[c] as usize]
    }

    /// `(diag, s)` of cell `c` with the held couplings removed.
    #[inline]
    fn correct(&self, c: usize, diag: f64, s: f64, x: &[f64]) -> (f64, f64) {
        match self.index.get(c) {
            Some(&k) if k != u32::MAX => {
                let (dd, ref nb) = self.rows[k as usize];
                let ds: f64 = nb.iter().map(|&(j, cj)| cj * x[j as usize]).sum();
                (diag - dd, s - ds)
            }
            _ => (diag, s),
        }
    }
}

impl CellOperator {
    /// `P = B^T M_l^{-1} B` of `grid`.
    pub fn schur(grid: &Grid) -> Self {
        let v = grid.cell_volume();
        let coef = [0, 1, 2].map(|a| 3.0 * grid.face_area(a).powi(2) / v);
        let bfac = grid.bc.map(|s| {
            s.map(|k| match k {
                BoundaryKind::DoNothing => 2.0,
                _ => 0.0,
            })
        });
        CellOperator {
            layout: grid.layout(),
            coef,
            bfac,
            held: HeldRows::default(),
        }
    }

    /// Removes from `P` the share `w` (0 to 1) of the couplings of each face of `faces`
    /// (`(index of a face field, w)`), held at a prescribed velocity by the flow solver
    /// and not corrected by its projection: across an interior face the coupling of its
    /// two cells, across a do-nothing side its share of the cell's diagonal (wall and
    /// inflow sides have none). On the finest level every share is 1; a coarse face whose
    /// children are partly held has less ([`crate::PressureMg::hold_faces`]). A cell all
    /// of whose faces are wholly held then has a zero row, which the smoother leaves alone.
    pub fn hold_face_shares(&mut self, faces: &[(u32, f64)]) {
        if faces.is_empty() {
            return;
        }
        let lay = self.layout;
        if self.held.index.is_empty() {
            self.held.index = vec![u32::MAX; lay.num_cells()];
        }
        for &(f, w) in faces {
            let (a, fc) = lay.face_of(f as usize);
            let coef = w * self.coef[a];
            match lay.face_cells(a, fc) {
                [Some(m), Some(p)] => {
                    let (m, p) = (lay.cell(m), lay.cell(p));
                    for (c, other) in [(m, p), (p, m)] {
                        let row = self.held.row_of(c);
                        row.0 += coef;
                        row.1.push((other as u32, coef));
                    }
                }
                [Some(c), None] | [None, Some(c)] => {
                    let dd = self.bfac[a][usize::from(fc[a] > 0)] * coef;
                    if dd != 0.0 {
                        self.held.row_of(lay.cell(c)).0 += dd;
                    }
                }
                [None, None] => {}
            }
        }
    }

    /// The Schur complement `B^T M_l^{-1} S_n B` of the shared pressure force
    /// ([`PressureShare::component`]), `S_n` its normal part: a third of
    /// [`CellOperator::schur`] across interior faces, all of it across do-nothing sides.
    pub fn shared_schur(grid: &Grid) -> Self {
        let mut op = CellOperator::schur(grid);
        op.coef.iter_mut().for_each(|c| *c /= 3.0);
        op.bfac.iter_mut().flatten().for_each(|f| *f *= 3.0);
        op
    }

    /// Neighbour coordinate of `m` along `d` on `side` (0 lower, 1 upper), `None` across
    /// a non-periodic box side.
    #[inline]
    fn nb(&self, d: usize, side: usize, m: usize) -> Option<usize> {
        let n = self.layout.n[d];
        if side == 0 {
            if m > 0 {
                Some(m - 1)
            } else if self.layout.periodic[d] {
                Some(n - 1)
            } else {
                None
            }
        } else if m + 1 < n {
            Some(m + 1)
        } else if self.layout.periodic[d] {
            Some(0)
        } else {
            None
        }
    }

    /// For every cell `i` of row `(j, k)`: `g(i, diag, s)` with `(P x)_i = diag x_i - s`.
    #[inline]
    pub(crate) fn for_row(
        &self,
        j: usize,
        k: usize,
        x: &[f64],
        mut g: impl FnMut(usize, f64, f64),
    ) {
        let [nx, ny, _] = self.layout.n;
        let mut rows = [(0usize, 0.0f64); 4];
        let mut cnt = 0;
        let mut diag_base = 0.0;
        for (d, m) in [(1, j), (2, k)] {
            for side in 0..2 {
                match self.nb(d, side, m) {
                    Some(mm) => {
                        let (jj, kk) = if d == 1 { (mm, k) } else { (j, mm) };
                        rows[cnt] = (nx * (jj + ny * kk), self.coef[d]);
                        cnt += 1;
                        diag_base += self.coef[d];
                    }
                    None => diag_base += self.bfac[d][side] * self.coef[d],
                }
            }
        }
        let rows = &rows[..cnt];
        let base = nx * (j + ny * k);
        let cx = self.coef[0];
        let held = (!self.held.index.is_empty()).then_some(&self.held);
        for i in 0..nx {
            let mut diag = diag_base;
            let mut s = 0.0;
            for &(st, c) in rows {
                s += c * x[st + i];
            }
            for side in 0..2 {
                match self.nb(0, side, i) {
                    Some(ii) => {
                        diag += cx;
                        s += cx * x[base + ii];
                    }
                    None => diag += self.bfac[0][side] * cx,
                }
            }
            let (diag, s) = match held {
                Some(h) => h.correct(base + i, diag, s, x),
                None => (diag, s),
            };
            g(i, diag, s);
        }
    }

    /// `y = P x`.
    pub fn apply(&self, x: &[f64], y: &mut [f64]) {
        let [nx, ny, _] = self.layout.n;
        y.par_chunks_mut(nx)
            .with_min_len(min_rows(nx))
            .enumerate()
            .for_each(|(r, row)| {
                let (j, k) = (r % ny, r / ny);
                let base = r * nx;
                self.for_row(j, k, x, |i, d, s| row[i] = d * x[base + i] - s);
            });
    }

    /// `r = b - P x`.
    pub fn residual(&self, x: &[f64], b: &[f64], r: &mut [f64]) {
        let [nx, ny, _] = self.layout.n;
        r.par_chunks_mut(nx)
            .with_min_len(min_rows(nx))
            .enumerate()
            .for_each(|(row_idx, row)| {
                let (j, k) = (row_idx % ny, row_idx / ny);
                let base = row_idx * nx;
                self.for_row(j, k, x, |i, d, s| {
                    row[i] = b[base + i] - d * x[base + i] + s
                });
            });
    }

    /// One half-sweep of red-black Gauss-Seidel (over-relaxed by `omega`) on the cells of
    /// colour `colour` (`(i + j + k) % 2`), written to `y` (the other colour copied from
    /// `x`): the cells of one colour only couple to the other colour, so this is exactly
    /// the in-place sweep, `y_i = x_i + omega ((b_i + s_i)/d_i - x_i)`.
    pub fn gauss_seidel_colour(
        &self,
        colour: usize,
        omega: f64,
        x: &[f64],
        b: &[f64],
        y: &mut [f64],
    ) {
        let [nx, ny, _] = self.layout.n;
        y.par_chunks_mut(nx)
            .with_min_len(min_rows(nx))
            .enumerate()
            .for_each(|(r, row)| {
                let (j, k) = (r % ny, r / ny);
                let base = r * nx;
                let par = (j + k + colour) % 2;
                self.for_row(j, k, x, |i, d, s| {
                    row[i] = if i % 2 == par && d > 0.0 {
                        let xi = x[base + i];
                        xi + omega * ((b[base + i] + s) / d - xi)
                    } else {
                        x[base + i]
                    };
                });
            });
    }
}

/// The convection coefficients `(d_ij, e_ij)` between face `sa` of family `a` and face
/// `sb` of family `b` of a cell, from the cell's record `data` of [`Convection`] (`k` =
/// `pair_index(a, b)`): the flux is stored once per unordered pair of families, so it
/// changes sign when read from the other side; the upwind weight does not.
#[inline]
fn convection_entry(
    data: &[f64],
    a: usize,
    b: usize,
    k: usize,
    sa: usize,
    sb: usize,
) -> (f64, f64) {
    let (idx, d) = if a < b {
        let idx = 4 * k + 2 * sa + sb;
        (idx, data[idx])
    } else {
        let idx = 4 * k + 2 * sb + sa;
        (idx, -data[idx])
    };
    (d, data[12 + idx])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::BoundaryKind::*;

    fn grid(bc: crate::grid::Boundaries) -> Grid {
        Grid::new([0.0, -1.0, 0.5], [1.2, 1.0, 1.5], [3, 4, 2], 2, bc).unwrap()
    }

    /// Consistency with the continuous operators on cubic cells: the mass matrix applied
    /// to the constant 1 gives the lumped mass `V/6` per adjacent cell; for the face means
    /// of u = x^2/2 + 2y - z the stiffness rows of interior faces give
    /// `int -Laplace(u) phi = -(lumped mass)` to 1e-12 (by hand for an x-face:
    /// `2 [h * h^2/2 - h * 4 * h^2/6] = -h^3/3 = -2 h^3/6`). On non-cubic boxes the Q1~
    /// stencil is not exact for quadratics (see the crate docs).
    #[test]
    fn operators_reproduce_polynomials() {
        let g = Grid::new([0.0; 3], [0.6, 0.8, 0.4], [3, 4, 2], 2, [[DoNothing; 2]; 3]).unwrap();
        let lay = g.layout();
        let nf = lay.num_faces();
        let mass = FaceOperator::helmholtz(&g, 1.0, 0.0);
        let ones = vec![1.0; nf];
        let mut y = vec![0.0; nf];
        mass.apply(&ones, &mut y);
        let ml = lumped_mass(&g);
        for i in 0..nf {
            assert!((y[i] - ml[i]).abs() < 1e-14);
        }
        // linear function: K u = 0 in interior rows (the element reproduces P1 exactly)
        let stiff = FaceOperator::helmholtz(&g, 0.0, 1.0);
        let h = g.h();
        let mut u = vec![0.0; nf];
        for a in 0..3 {
            for (idx, v) in u[lay.off[a]..lay.off[a + 1]].iter_mut().enumerate() {
                let x = g.face_centre(a, lay.face_coords(a, idx));
                // face mean of x^2/2 is x_c^2/2 + h^2/24 along the tangential directions
                let mut m = 0.5 * x[0] * x[0];
                if a != 0 {
                    m += h[0] * h[0] / 24.0;
                }
                *v = m + 2.0 * x[1] - x[2];
            }
        }
        stiff.apply(&u, &mut y);
        for a in 0..3 {
            for idx in 0..lay.fdim[a].iter().product() {
                let f = lay.face_coords(a, idx);
                if lay.face_cells(a, f).iter().all(|c| c.is_some()) {
                    // -Laplace(x^2/2) = -1, tested against the lumped mass
                    let want = -ml[lay.off[a] + idx];
                    let got = y[lay.off[a] + idx];
                    assert!(
                        (got - want).abs() < 1e-12,
                        "face {a} {f:?}: {got} vs {want}"
                    );
                }
            }
        }
    }

    /// Consistency of the convection [`Convection`] (see its derivation): for a constant
    /// convecting velocity `w` and a linear `v`, every interior row of the central part
    /// (`nu = 1e12`, Samarskij weights ~ 1e-12) of `N(w) v` equals the dual-cell volume
    /// (lumped mass) times `w . grad v`, to 1e-12 relative, on a non-cubic grid. With
    /// `nu = 1e-3` (cell Peclet ~ 100) the upwind part is dissipative: `v . N(w) v` grows
    /// by a positive amount for a rough `v` on a periodic grid (where the central part is
    /// the only other contribution).
    #[test]
    fn convection_is_consistent_for_linear_fields() {
        let g = Grid::new([0.0; 3], [0.6, 0.8, 0.4], [3, 4, 2], 2, [[DoNothing; 2]; 3]).unwrap();
        let lay = g.layout();
        let nf = lay.num_faces();
        let w = [0.7, -1.3, 0.4];
        let grad = [2.0, -0.5, 1.5];
        let wf = w.map(|c| vec![c; nf]);
        let mut v = vec![0.0; nf];
        for a in 0..3 {
            for (idx, val) in v[lay.off[a]..lay.off[a + 1]].iter_mut().enumerate() {
                let x = g.face_centre(a, lay.face_coords(a, idx));
                *val = 0.3 + (0..3).map(|d| grad[d] * x[d]).sum::<f64>();
            }
        }
        let ml = lumped_mass(&g);
        let wgv: f64 = (0..3).map(|d| w[d] * grad[d]).sum();
        let conv_only = |g: &Grid, nu: f64, wf: &[Vec<f64>; 3]| {
            let op = FaceOperator {
                nu,
                ..FaceOperator::helmholtz(g, 0.0, 0.0)
            };
            op.with_convection(g, [&wf[0], &wf[1], &wf[2]])
        };
        let op = conv_only(&g, 1e12, &wf);
        let mut y = vec![0.0; nf];
        op.apply(&v, &mut y);
        for a in 0..3 {
            for idx in 0..lay.fdim[a].iter().product() {
                let f = lay.face_coords(a, idx);
                if lay.face_cells(a, f).iter().all(|c| c.is_some()) {
                    let i = lay.off[a] + idx;
                    let want = ml[i] * wgv;
                    assert!(
                        (y[i] - want).abs() <= 1e-12 * want.abs(),
                        "face {a} {f:?}: {} vs {want}",
                        y[i]
                    );
                }
            }
        }
        // dissipativity of the upwind part on a periodic grid
        let gp = Grid::new([0.0; 3], [1.0; 3], [4, 4, 4], 1, [[Periodic; 2]; 3]).unwrap();
        let np = gp.num_faces();
        let wp = w.map(|c| vec![c; np]);
        let rough: Vec<f64> = (0..np).map(|i| ((i * 7919 % 13) as f64).sin()).collect();
        let energy = |nu: f64| {
            let mut y = vec![0.0; np];
            conv_only(&gp, nu, &wp).apply(&rough, &mut y);
            serial_dot(&rough, &y)
        };
        let (central, upwind) = (energy(1e12), energy(1e-3));
        assert!(upwind > central + 1e-3, "{upwind} vs {central}");
    }

    /// `P = B^T M_l^{-1} B` with the Dirichlet rows of B removed equals the 7-point
    /// [`CellOperator`], for walls, do-nothing and periodic sides.
    #[test]
    fn schur_complement_equals_seven_point_stencil() {
        let g = grid([
            [Dirichlet, DoNothing],
            [Periodic, Periodic],
            [DoNothing, Dirichlet],
        ]);
        let lay = g.layout();
        let nc = lay.num_cells();
        let p: Vec<f64> = (0..nc).map(|c| ((c * 37 % 11) as f64).sin()).collect();
        let mask = g.dirichlet_mask();
        let ml = lumped_mass(&g);
        let mut u = [0, 1, 2].map(|_| vec![0.0; lay.num_faces()]);
        let [u0, u1, u2] = &mut u;
        add_gradient(&g, &p, 1.0, [u0, u1, u2]);
        for ua in &mut u {
            for i in 0..ua.len() {
                ua[i] = if mask[i] { 0.0 } else { ua[i] / ml[i] };
            }
        }
        let mut want = vec![0.0; nc];
        divergence(&g, [&u[0], &u[1], &u[2]], &mut want);
        want.iter_mut().for_each(|w| *w = -*w);
        let mut got = vec![0.0; nc];
        CellOperator::schur(&g).apply(&p, &mut got);
        for c in 0..nc {
            assert!(
                (got[c] - want[c]).abs() < 1e-12,
                "cell {c}: {} vs {}",
                got[c],
                want[c]
            );
        }
    }

    /// Discrete divergence of the face means of a linear field u = (x, 2y, -3z) is the cell
    /// volume times div u = 0; of (x, 0, 0) it is the volume.
    #[test]
    fn divergence_of_linear_fields() {
        let g = grid([[Dirichlet; 2]; 3]);
        let lay = g.layout();
        let nf = lay.num_faces();
        let field = |s: [f64; 3]| {
            let mut u = [0, 1, 2].map(|_| vec![0.0; nf]);
            for (d, ud) in u.iter_mut().enumerate() {
                for a in 0..3 {
                    for idx in 0..lay.fdim[a].iter().product() {
                        let x = g.face_centre(a, lay.face_coords(a, idx));
                        ud[lay.off[a] + idx] = s[d] * x[d];
                    }
                }
            }
            u
        };
        let mut div = vec![0.0; lay.num_cells()];
        let u = field([1.0, 2.0, -3.0]);
        divergence(&g, [&u[0], &u[1], &u[2]], &mut div);
        assert!(div.iter().all(|d| d.abs() < 1e-14));
        let u = field([1.0, 0.0, 0.0]);
        divergence(&g, [&u[0], &u[1], &u[2]], &mut div);
        assert!(div.iter().all(|d| (d - g.cell_volume()).abs() < 1e-14));
    }

    /// Reductions give the same bits on 1 and 2 threads.
    #[test]
    fn dot_is_thread_independent() {
        let a: Vec<f64> = (0..100_000).map(|i| (i as f64 * 0.37).sin()).collect();
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let two = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let d1 = one.install(|| dot(&a, &a));
        let d2 = two.install(|| dot(&a, &a));
        assert_eq!(d1.to_bits(), d2.to_bits());
    }
}
