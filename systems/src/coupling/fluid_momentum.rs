//! Hydrodynamic force on a free particle from the momentum of the fluid inside it
//! (Sharma & Patankar 2005, J. Comput. Phys. 205:439), under
//! [`ParticleUpdate::FluidMomentum`]: the faces inside the particle start the fluid step
//! at its rigid-body velocity ([`super::markers`]) and move with the fluid through the
//! step; the momentum they gain is the particle's impulse.
//!
//! [`ParticleUpdate::FluidMomentum`]: grainflow_components::ParticleUpdate
use grainflow_components::{ParticleFace, Particles};
use grainflow_fluid::NavierStokes;

use super::add_force;

/// Force and torque on every particle from the momentum that the fluid faces inside it
/// gained over the fluid step of length `dt_f` ([`ParticleUpdate::FluidMomentum`]):
/// `F = rho_f sum_f M_f (u_f - u_f^0) / dt_F`, `T = rho_f sum_f (x_f - x_p) x M_f (u_f -
/// u_f^0) / dt_F` over the faces `f` of the particle, with the lumped mass `M_f` and the
/// rigid-body velocity `u_f^0` the face started the step with (Sharma & Patankar 2005,
/// J. Comput. Phys. 205:439, the particle's momentum from the fluid's inside it). The
/// faces are summed in face order: the result does not depend on the thread count.
/// Rows without faces get zero.
///
/// [`ParticleUpdate::FluidMomentum`]: grainflow_components::ParticleUpdate
pub fn fluid_momentum_force(
    ns: &NavierStokes,
    faces: &[ParticleFace],
    particles: &Particles,
    fluid_density: f64,
    dt_f: f64,
) -> Vec<([f64; 3], [f64; 3])> {
    let grid = ns.grid();
    let lay = grid.layout();
    let ml = ns.lumped_mass();
    let mut ft = vec![([0.0; 3], [0.0; 3]); particles.len()];
    for pf in faces {
        let (idx, i) = (pf.face as usize, pf.row as usize);
        let (a, f) = lay.face_of(idx);
        let x = grid.face_centre(a, f);
        let arm = [0, 1, 2].map(|d| x[d] - particles.position[d][i]);
        let rate = fluid_density * ml[idx] / dt_f;
        let df = [0, 1, 2].map(|d| rate * (ns.u[d][idx] - pf.start[d]));
        let (force, torque) = &mut ft[i];
        add_force(force, torque, arm, df);
    }
    ft
}
