//! The fluid-particle coupling (seed, "Coupling of the phases"): a fictitious domain on
//! the fixed fluid grid, with the hydrodynamic force held over the DEM subcycles.
//!
//! # The coupled step
//!
//! Time levels (seed, "Coupling of FEM-DEM on the time level", after Feng & Owen 2007):
//! one fluid step of dt_F spans n_s = int(dt_F / dt_D) + 1 DEM substeps of
//! dt_D' = dt_F / n_s ([`subcycles`]). `schedule.rs` runs the fluid step inside the first
//! of them, between its contact forces and its corrector:
//!
//! 1. before the flow step ([`markers`], [`face_exchange`], [`blending`]): the level-set
//!    cell markers of every particle, the rigid-body velocity `U + w x (x - x_p)` on
//!    every face whose centre lies inside a particle (held through the step, the
//!    fictitious boundary of Wan & Turek 2006, or only its start under the fluid-momentum
//!    update, with the momentum of the faces that entered and left a free particle since
//!    the last step booked to it), when the scene sets `alpha`, the smooth transition
//!    of Luo et al. (2007) on the other faces of the cells the surfaces cut, and under
//!    `boundary = "distance_penalty"` the implicit penalty of the faces within a cell
//!    outside the surfaces ([`distance_penalty`]);
//! 2. the flow step (`crate::fluid`): one Navier-Stokes step of dt_F;
//! 3. after the flow step ([`sampling`]): the hydrodynamic force and torque of every
//!    particle from the new flow, by [`surface_points`] (the seed's Lebedev-Laikov force
//!    points, [`lebedev`]), [`volume_integral`] (Wan & Turek 2006) or, for free particles
//!    under the fluid-momentum update, [`fluid_momentum`] (Sharma & Patankar 2005).
//!
//! In every substep the force and torque of the last fluid step are added, held
//! constant, to the contact forces (`m dU/dt = (rho - rho_f) V g + F_p + F_f`,
//! `I dw/dt = T_p + T_f`): the coupling is explicit in the particle velocity.
//!
//! # Periodic sides
//!
//! Along a periodic direction of the fluid (both sides `periodic`, box length `L`) the
//! coupling wraps, while the DEM particles do not (a particle that moves through the side
//! keeps its position outside `[x_0, x_1)`): every job takes the particle's centre modulo
//! `L` (it sees the flow at its image in the box), lets the cell index ranges of a sphere
//! run past 0 or `n` and maps them modulo `n`, so a sphere straddling the side is marked
//! and sampled on both sides, and takes the arms `x - x_p` of cells, faces and force
//! points by minimum image ([`Wrap`], the one helper they share). A run stops only for a
//! centre that leaves the box through a non-periodic side, or for a sphere that would
//! meet its own image ([`markers::outside_the_fluid`]).
//!
//! # Bodies of other shapes
//!
//! A clump is one rigid body for the fluid ([`bodies`]): its cells and faces are those of
//! its shape's fluid indicator (the union of its members), with the body's rigid velocity,
//! and its force and torque are computed once for that solid and held on one of its rows.
//! Free spheres keep the sphere path of every job.
//!
//! This module holds the helpers its files share; each job has its own file.
use bevy_ecs::prelude::*;
use grainflow_components::{Clamped, Coupling, ParticleUpdate, Particles};
use grainflow_fluid::Grid;

pub mod blending;
pub mod bodies;
pub mod distance_penalty;
pub mod face_exchange;
pub mod fluid_momentum;
pub mod lebedev;
pub mod lubrication;
pub mod markers;
pub mod sampling;
pub mod surface_points;
pub mod volume_integral;

/// Whether the world couples particles and fluid.
pub fn has_coupling(w: &World) -> bool {
    w.contains_resource::<Coupling>()
}

/// Whether the world couples particles and fluid with the smooth velocity transition.
pub fn has_blending(w: &World) -> bool {
    w.get_resource::<Coupling>()
        .is_some_and(|c| c.alpha.is_some())
}

/// DEM subcycles per fluid step (seed, "Coupling of FEM-DEM on the time level", after
/// Feng & Owen 2007): `n_s = int(dt_F / dt_D) + 1`, run with `dt_D' = dt_F / n_s`. A ratio
/// within 1e-9 of a whole number counts as that number (1e-4 / 1e-5 gives 11 subcycles,
/// not 10 or 11 by rounding luck).
pub fn subcycles(dt_fluid: f64, dt_dem: f64) -> u32 {
    let ratio = dt_fluid / dt_dem;
    let whole = if (ratio - ratio.round()).abs() <= 1e-9 * ratio {
        ratio.round()
    } else {
        ratio.floor()
    };
    whole as u32 + 1
}

/// Whether the faces inside particle row `i` are held at its rigid-body velocity through
/// the fluid step (a fixed particle, or the scene's [`ParticleUpdate::Prescribed`]), or
/// start the step at it and move with the fluid ([`ParticleUpdate::FluidMomentum`]).
pub fn holds_faces(coupling: &Coupling, clamped: Option<&Clamped>, i: usize) -> bool {
    coupling.update == ParticleUpdate::Prescribed || clamped.is_some_and(|c| c.held[i])
}

/// The periodic wrap of the fluid grid, shared by every coupling job. The fluid is
/// periodic along a direction whose two sides are `periodic` (box length `L`); the DEM
/// particles do not wrap, so a particle may sit anywhere along it and sees the flow at its
/// image in the box. Along the other directions positions and indices pass unchanged.
///
/// * [`Wrap::image`]: the position in the box, `x_0 + (x - x_0) mod L` (unchanged when it
///   already lies in `[x_0, x_1)`);
/// * [`Wrap::arm`]: the minimum image of `x - x_p`, `d - L round(d / L)`, the arm of a
///   point within `L / 2` of the particle across the periodic sides;
/// * [`Wrap::cells`]: the cell index ranges a box about a point meets, running past 0 or
///   `n` along a periodic direction, and [`Wrap::index`] maps such an index into the
///   grid (modulo `n`), so a sphere straddling a periodic side covers the cells on both.
///
/// The arms are exact while every marked cell lies within `L / 2` of the sphere's centre,
/// which [`markers::outside_the_fluid`] requires.
#[derive(Debug, Clone, Copy)]
pub struct Wrap {
    lower: [f64; 3],
    upper: [f64; 3],
    h: [f64; 3],
    n: [usize; 3],
    periodic: [bool; 3],
}

impl Wrap {
    /// The wrap of `grid`'s periodic directions.
    pub fn new(grid: &Grid) -> Self {
        Wrap {
            lower: grid.lower,
            upper: grid.upper,
            h: grid.h(),
            n: grid.n(),
            periodic: [0, 1, 2].map(|d| grid.periodic(d)),
        }
    }

    /// The image of `x` in the box: `x_0 + (x - x_0) mod L` along the periodic directions
    /// outside `[x_0, x_1)`, `x` otherwise.
    pub fn image(&self, x: [f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|d| {
            if self.periodic[d] && !(self.lower[d] <= x[d] && x[d] < self.upper[d]) {
                self.lower[d] + (x[d] - self.lower[d]).rem_euclid(self.upper[d] - self.lower[d])
            } else {
                x[d]
            }
        })
    }

    /// The arm `x - x_p`, along the periodic directions by minimum image:
    /// `d - L round(d / L)` (unchanged for `|d| < L / 2`).
    pub fn arm(&self, x: [f64; 3], xp: [f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|d| {
            let r = x[d] - xp[d];
            if self.periodic[d] {
                let length = self.upper[d] - self.lower[d];
                r - length * (r / length).round()
            } else {
                r
            }
        })
    }

    /// Index ranges `[lo, hi)` per direction of the cells that the box `x +- reach` meets:
    /// clamped to `[0, n]` along a non-periodic direction, running past them along a
    /// periodic one (map the indices with [`Wrap::index`]).
    pub fn cells(&self, x: [f64; 3], reach: f64) -> [(isize, isize); 3] {
        [0, 1, 2].map(|d| {
            let lo = ((x[d] - reach - self.lower[d]) / self.h[d]).floor();
            let hi = ((x[d] + reach - self.lower[d]) / self.h[d]).floor() + 1.0;
            if self.periodic[d] {
                (lo as isize, hi as isize)
            } else {
                let n = self.n[d] as isize;
                ((lo.max(0.0) as isize).min(n), (hi.max(0.0) as isize).min(n))
            }
        })
    }

    /// Cell (or face) coordinates of the index `c` from [`Wrap::cells`]: `c mod n` along
    /// the periodic directions.
    pub fn index(&self, c: [isize; 3]) -> [usize; 3] {
        [0, 1, 2].map(|d| {
            if self.periodic[d] {
                c[d].rem_euclid(self.n[d] as isize) as usize
            } else {
                c[d] as usize
            }
        })
    }
}

/// Rigid-body velocity `U + w x r` of particle `i` at arm `r = x - x_p` (by minimum
/// image, [`Wrap::arm`]).
pub fn rigid_velocity(particles: &Particles, i: usize, r: [f64; 3]) -> [f64; 3] {
    let w = [0, 1, 2].map(|d| particles.angular_velocity[d][i]);
    let cross = [
        w[1] * r[2] - w[2] * r[1],
        w[2] * r[0] - w[0] * r[2],
        w[0] * r[1] - w[1] * r[0],
    ];
    [0, 1, 2].map(|d| particles.velocity[d][i] + cross[d])
}

/// Calls `g(a, f, arm)` once for every face of family `a` with coordinates `f` of the
/// cells that the box `x_p +- reach` meets (the lower faces of the cells, plus the upper
/// layer along a non-periodic `a`), with its arm `x_f - x_p` by minimum image: every face
/// whose centre lies within `reach` of `x_p` is among them. `x_p` is the image in the box
/// ([`Wrap::image`]).
pub(crate) fn faces_about(
    grid: &Grid,
    wrap: &Wrap,
    xp: [f64; 3],
    reach: f64,
    mut g: impl FnMut(usize, [usize; 3], [f64; 3]),
) {
    let lay = grid.layout();
    let range = wrap.cells(xp, reach);
    for a in 0..3 {
        let mut hi = [range[0].1, range[1].1, range[2].1];
        if !lay.periodic[a] {
            hi[a] = (hi[a] + 1).min(lay.n[a] as isize + 1);
        }
        for k in range[2].0..hi[2] {
            for j in range[1].0..hi[1] {
                for i in range[0].0..hi[0] {
                    let fc = wrap.index([i, j, k]);
                    g(a, fc, wrap.arm(grid.face_centre(a, fc), xp));
                }
            }
        }
    }
}

/// Adds the force `df` acting at lever arm `arm` to the force `f` and torque `t`.
pub(crate) fn add_force(f: &mut [f64; 3], t: &mut [f64; 3], arm: [f64; 3], df: [f64; 3]) {
    for d in 0..3 {
        f[d] += df[d];
    }
    t[0] += arm[1] * df[2] - arm[2] * df[1];
    t[1] += arm[2] * df[0] - arm[0] * df[2];
    t[2] += arm[0] * df[1] - arm[1] * df[0];
}
