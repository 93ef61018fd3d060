//! Hydrodynamic force on a free particle from the momentum of the fluid inside it
//! (Sharma & Patankar 2005, J. Comput. Phys. 205:439), under
//! [`ParticleUpdate::FluidMomentum`]: the faces inside the particle start the fluid step
//! at its rigid-body velocity ([`super::markers`]) and move with the fluid through the
//! step; the momentum they gain is the particle's impulse.
//!
//! [`ParticleUpdate::FluidMomentum`]: grainflow_components::ParticleUpdate
use grainflow_components::{ParticleFace, Particles};
use grainflow_fluid::NavierStokes;

use super::{add_force, Wrap};

/// Force and torque on every particle from the momentum that the fluid faces inside it
/// gained over the fluid step of length `dt_f` ([`ParticleUpdate::FluidMomentum`]).
///
/// The surface force on the fluid inside the particle is the momentum rate of that
/// material volume, `F = rho_f int_V Du/Dt = rho_f int_V (du/dt + (u . grad) u)` (Reynolds
/// transport, `div u = 0`). The fluid step gives `du/dt` at the fixed faces; for the
/// rigid motion the faces start with, `(u . grad) u = w x u`. So, over the faces `f` of
/// the particle with lumped mass `M_f` and start velocity `u_f^0 = U + w x (x_f - x_p)`:
/// `F = rho_f sum_f M_f (u_f - u_f^0 + (R(w dt_F) - I) u_f^0) / dt_F`, the convective term
/// integrated over the step as the rigid rotation it is ([`rigid_rotation_change`]), and
/// the torque of the same terms about `x_p`, with the arms `x_f - x_p` by minimum image
/// across periodic sides ([`super::Wrap`]) (Sharma & Patankar 2005, J. Comput. Phys. 205:439, the particle's
/// momentum from the fluid's inside it). Without the convective term a sphere carried
/// by a rigidly rotating flow feels no centripetal force and spirals out
/// (tests/neutral_buoyancy.rs). The faces are summed in face order: the result does not
/// depend on the thread count. Rows without faces get zero.
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
    let wrap = Wrap::new(grid);
    let mut ft = vec![([0.0; 3], [0.0; 3]); particles.len()];
    for pf in faces {
        let (idx, i) = (pf.face as usize, pf.row as usize);
        let (a, f) = lay.face_of(idx);
        let xp = [0, 1, 2].map(|d| particles.position[d][i]);
        let arm = wrap.arm(grid.face_centre(a, f), xp);
        let m = fluid_density * ml[idx];
        let w = [0, 1, 2].map(|d| particles.angular_velocity[d][i]);
        let turned = rigid_rotation_change(w, pf.start, dt_f);
        let df =
            [0, 1, 2].map(|d| m * ((ns.u[d][idx] - pf.start[d] + turned[d]) / dt_f - pf.load[d]));
        let (force, torque) = &mut ft[i];
        add_force(force, torque, arm, df);
    }
    ft
}

/// The change `(R(w dt) - I) u` of a velocity `u` carried for a time `dt` by a rigid
/// rotation `w` (Rodrigues' formula: with `n = w / |w|`, `theta = |w| dt`,
/// `(R - I) u = sin(theta) n x u + (1 - cos(theta)) n x (n x u)`): the convective term
/// `(u . grad) u = w x u` of a rigidly moving fluid integrated exactly over the step, so
/// that a velocity carried round a circle keeps its length (the held `dt w x u` would
/// lengthen it by `(w dt)^2 / 2` per step and the orbit would spiral out).
fn rigid_rotation_change(w: [f64; 3], u: [f64; 3], dt: f64) -> [f64; 3] {
    let speed = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
    if speed == 0.0 {
        return [0.0; 3];
    }
    let n = w.map(|c| c / speed);
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let nu = cross(n, u);
    let nnu = cross(n, nu);
    let theta = speed * dt;
    let (s, c) = theta.sin_cos();
    [0, 1, 2].map(|d| s * nu[d] + (1.0 - c) * nnu[d])
}
