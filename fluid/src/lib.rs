//! grainflow-fluid: the numerical core of the incompressible flow solver (issue 4).
//!
//! Discretisation as in the seed (Wriggers & Avci 2010, after FEATFLOW, Turek 1998/1999):
//! the nonconforming rotated trilinear element Q1~ of Rannacher & Turek (1992) with face
//! mean values as degrees of freedom for each velocity component, piecewise constant
//! pressure, on the uniform hexahedral grids of a box refined level by level
//! (`coarse x 2^(L-1)` cells per direction). Operators are matrix-free stencils built from
//! the constant element matrices of a box cell ([`element`]); everything is `f64`.
//!
//! # Interface
//! * [`Grid`]: box `lower..upper`, coarse cells, level, [`BoundaryKind`] of the six sides
//!   (Dirichlet velocity, do-nothing, periodic). [`Grid::dofs`] = `3 x faces + cells`
//!   (reproduces the seed's "MG-Level" tables), [`Grid::num_faces`], [`Grid::num_cells`],
//!   [`Grid::h`], [`Grid::layout`] for index arithmetic.
//! * Fields are plain `Vec<f64>` (structure of arrays): a velocity is `[Vec<f64>; 3]`, one
//!   vector per component, each holding the face mean values of all faces (x-faces, then
//!   y-faces, then z-faces, each family lexicographic with `i` fastest); a pressure is one
//!   `Vec<f64>` over the cells (lexicographic). The cell-centre value of a velocity
//!   component is the mean of its six face values (every basis function is 1/6 at the
//!   centre).
//! * Fictitious boundary hook: a marker array of one `i32` per cell (0 outer, `p`
//!   boundary, `-p` inner cell of particle `p`); [`Grid::mark_faces`] adds the faces of
//!   marked cells to a Dirichlet mask, and the velocities stored on those faces are kept as
//!   prescribed by the solvers. The pressure operator ignores the markers.
//! * Solvers report cycles and mean reduction factors: [`PressureMg`] (cell-centred
//!   multigrid for `P = B^T M_l^{-1} B`, the discrete projection's pressure Poisson
//!   problem) and [`FaceMg`] (multigrid for `alpha M + nu K`, the momentum building
//!   block) return an [`MgReport`]; [`StokesSolver`] returns a [`StokesReport`].
//!
//! # Known limits
//! * The viscous term is the Laplacian form `nu K` (not the deformation-tensor form of the
//!   seed's stress tensor); both agree for divergence-free fields with Dirichlet walls,
//!   and differ in the meaning of the do-nothing condition.
//! * On strongly anisotropic cells the Q1~ stencil is not exact for quadratics and the
//!   point smoothers lose efficiency; the tests use cubic cells.
//! * The Q1~ prolongation is stored as a sparse matrix (about 5 entries of 16 bytes per
//!   fine face): fine for the test levels, heavy at level 5 of the seed grids.
//! * No time stepping yet (the transient Navier-Stokes step of issue 4 is future work).

pub mod element;
pub mod grid;
pub mod mg_cell;
pub mod mg_face;
pub mod ops;
pub mod stokes;

pub use grid::{dofs_of_level, Boundaries, BoundaryKind, Grid, GridError, Layout};
pub use mg_cell::{MgReport, PressureMg};
pub use mg_face::{Cycle, FaceMg};
pub use ops::{CellOperator, FaceOperator};
pub use stokes::{body_force_load, StokesReport, StokesSolver};
