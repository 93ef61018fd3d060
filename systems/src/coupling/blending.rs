//! The smooth velocity transition around the particles (Luo et al. 2007, the seed's
//! "nonlinear weighted velocity update"), before each fluid step, only when the scene
//! sets `alpha`.
//!
//! The faces of the cells a particle's surface cuts that lie outside every particle
//! ([`CellMarkers::blend_faces`], from [`super::markers`]) are set to
//! `u = (1 - phi) u + phi U(x)` with `phi = exp(-alpha Re_p)`, `Re_p = 2 r |U(x) - u| / nu`
//! and the particle's rigid-body velocity `U(x) = U + w x (x - x_p)` (the arm by minimum
//! image across periodic sides, [`super::Wrap`]), before the step (so the update enters
//! the step as its old velocity). The momentum this moves, `rho_f m_f (u_old - u_new) /
//! dt_F` per face with the lumped mass `m_f`, is the particle's
//! (`HydroForces::exchange_force`, which [`super::markers`] zeroes before, added to the
//! sampled force), so the exchange conserves
//! momentum. Measured on the drag case (Re = 50, level 2) the update makes the steady drag
//! depend on dt_F, being a relaxation applied once per step: alpha = 0.1 gives C_D 1.96 at
//! dt_F = 0.02 and 1.64 at 0.05 (1.24 and 1.39 without its momentum booked), against 1.49
//! at both dt_F without blending (Schiller-Naumann 1.54): the default is no blending.
use bevy_ecs::prelude::*;
use grainflow_components::{CellMarkers, Coupling, HydroForces, Particles};

use super::{add_force, rigid_velocity, Wrap};
use crate::fluid::FluidFlow;

/// `velocity_blending`: the smooth transition on the faces to blend, its momentum booked
/// to the particles (see the module docs).
pub fn velocity_blending(
    coupling: Res<Coupling>,
    particles: Res<Particles>,
    markers: Res<CellMarkers>,
    mut flow: ResMut<FluidFlow>,
    mut hydro: ResMut<HydroForces>,
) {
    let _span = tracing::info_span!("velocity_blending").entered();
    let alpha = coupling.alpha.expect("a scene that blends");
    let grid = flow.solver.grid().clone();
    let lay = grid.layout();
    let wrap = Wrap::new(&grid);
    let momentum_rate = coupling.fluid_density * grid.cell_volume() / 6.0 / flow.dt;
    let u = &mut flow.solver.u;
    let HydroForces {
        exchange_force,
        exchange_torque,
        ..
    } = &mut *hydro;
    for &(idx, i) in &markers.blend_faces {
        let idx = idx as usize;
        let (a, f) = lay.face_of(idx);
        let i = i as usize;
        let xp = [0, 1, 2].map(|d| particles.position[d][i]);
        let arm = wrap.arm(grid.face_centre(a, f), xp);
        let v = rigid_velocity(&particles, i, arm);
        let slip = (0..3)
            .map(|d| (v[d] - u[d][idx]).powi(2))
            .sum::<f64>()
            .sqrt();
        let re_p = 2.0 * particles.radius[i] * slip / coupling.viscosity;
        let phi = (-alpha * re_p).exp();
        let share = momentum_rate * lay.face_cells(a, f).iter().flatten().count() as f64;
        let df = [0, 1, 2].map(|d| share * phi * (u[d][idx] - v[d]));
        let (mut force, mut torque) = ([0.0; 3], [0.0; 3]);
        add_force(&mut force, &mut torque, arm, df);
        for d in 0..3 {
            u[d][idx] = (1.0 - phi) * u[d][idx] + phi * v[d];
            exchange_force[d][i] += force[d];
            exchange_torque[d][i] += torque[d];
        }
    }
}
