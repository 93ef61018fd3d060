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
//! * Transient Navier-Stokes ([`navier`]): [`NavierStokes::new`] (grid, [`NsConfig`],
//!   mask of prescribed faces), fields `u`, `p`, `time`; [`NavierStokes::set_side_velocity`]
//!   for walls, lids and inflow profiles; [`NavierStokes::step_with`] for time-dependent
//!   Dirichlet data (called at each substep's time); [`NavierStokes::move_mask`] when
//!   markers move; [`NsConfig::viscous`] selects the [`ViscousForm`];
//!   [`NavierStokes::step`] does one step of the selected [`TimeScheme`] (backward Euler,
//!   Crank-Nicolson, fractional-step theta; backward Euler for `startup_steps`) by the
//!   discrete projection with [`FaceMg`] (momentum, `alpha M_l + nu K + N(u*)`) and
//!   [`PressureMg`], and returns a [`StepReport`] (cycles and mean reduction per cycle of
//!   the momentum and pressure solves, their wall seconds, the divergence after the step).
//!   Convection: [`Convection`], dual-cell fluxes with Samarskij upwinding, implicit
//!   (linearised about an extrapolated velocity), second order in `h` at fixed viscosity.
//! * [`ghia`]: the lid-driven cavity of Ghia et al. (1982), its reference centreline
//!   profiles (Re = 100, 400) and the deviation of a computed flow from them (tests,
//!   `benches/cavity_error.rs`, docs/fluid-benchmarks.md).
//!
//! # Known limits
//! * The viscous term is the Laplacian form `nu K` by default; the deformation-tensor form
//!   of the seed's stress tensor ([`ViscousForm::Deformation`], `nu (K + K_T)`) treats its
//!   component coupling `K_T` by a stabilised lag (the momentum solve uses `2 nu K`), see
//!   [`navier`]. Both agree for divergence-free fields with Dirichlet walls and differ in
//!   the meaning of the do-nothing condition.
//! * Steady states by large steps: the convection is linearised about an extrapolated
//!   velocity (one Picard step per substep), so large CFL numbers flip-flop (cavity,
//!   measured: Crank-Nicolson beyond U dt/h = 2, fractional-step theta beyond 8, backward
//!   Euler beyond 32); fractional-step theta at U dt/h = 8 reaches the Re = 400 cavity's
//!   steady state in ~170 steps. The projection's pressure iteration converges at about
//!   0.9 per step with large steps (Stokes flow with a do-nothing side, measured).
//! * Convection at cell Peclet numbers >> 1: the full Samarskij upwinding adds numerical
//!   diffusion of several times `nu` (Re = 400 cavity on 32^2: u off Ghia by 0.11);
//!   [`NsConfig::upwind`] = 0.1 (FEATFLOW's UPSAM) brings it to 0.044; 0.03 diverged.
//! * On strongly anisotropic cells the Q1~ stencil is not exact for quadratics and the
//!   point smoothers lose efficiency; the tests use cubic cells.
//! * The Q1~ prolongation is stored as a sparse matrix (about 5 entries of 16 bytes per
//!   fine face): fine for the test levels, heavy at level 5 of the seed grids.
//! * The momentum multigrid ([`FaceMg`]) evaluates a generic per-face stencil (about
//!   1 us per face and cycle with convection); the mean reduction per cycle of the
//!   Oseen problems is 0.13-0.2 (cavity, 24^2-32^2).
//! * The projection is not told about marker faces: near marked cells the divergence is
//!   not driven to zero. The viscous pressure term of the projection is damped by 1/2
//!   (see [`navier`]); steady states from large backward-Euler steps converge at about
//!   0.9 per step (cavity Re = 100).

pub mod element;
pub mod ghia;
pub mod grid;
pub mod mg_cell;
pub mod mg_face;
pub mod navier;
pub mod ops;
pub mod sample;
pub mod stokes;

pub use grid::{dofs_of_level, Boundaries, BoundaryKind, Grid, GridError, Layout};
pub use mg_cell::{MgReport, PressureMg};
pub use mg_face::{Cycle, FaceMg};
pub use navier::{
    FaceLoad, FlowLevels, NavierStokes, NsConfig, PenaltyFace, StepReport, TimeScheme, ViscousForm,
};
pub use ops::{CellOperator, Convection, FaceOperator, PressureForce, TransposeStiffness};
pub use stokes::{body_force_load, StokesReport, StokesSolver};
