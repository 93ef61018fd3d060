//! Velocity Verlet (Swope, Andersen, Berens & Wilson 1982):
//!   v(t + dt/2) = v(t) + a(t) dt/2,  x(t + dt) = x(t) + v(t + dt/2) dt,
//!   v(t + dt) = v(t + dt/2) + a(t + dt) dt/2,  a = F/m + g (1 - rho_f/rho).
//! Velocity-dependent (damping) forces use the half-step velocity.
use bevy_ecs::prelude::*;
use grainflow_components::{BodyAcceleration, Particles, SimClock};
use rayon::prelude::*;

use crate::CHUNK;

/// Half kick with the current forces, then drift (`drift = true`), or the closing half kick.
fn half_kick(particles: &mut Particles, body: &BodyAcceleration, dt: f64, drift: bool) {
    let Particles {
        position,
        velocity,
        force,
        inv_mass,
        material,
        ..
    } = particles;
    let h = 0.5 * dt;
    for d in 0..3 {
        let g: Vec<f64> = body.per_material.iter().map(|g| g[d]).collect();
        (
            position[d].par_chunks_mut(CHUNK),
            velocity[d].par_chunks_mut(CHUNK),
            force[d].par_chunks(CHUNK),
            inv_mass.par_chunks(CHUNK),
            material.par_chunks(CHUNK),
        )
            .into_par_iter()
            .for_each(|(x, v, f, im, m)| {
                for k in 0..x.len() {
                    v[k] += h * (f[k] * im[k] + g[m[k] as usize]);
                    if drift {
                        x[k] += dt * v[k];
                    }
                }
            });
    }
}

pub fn verlet_predict(
    mut particles: ResMut<Particles>,
    clock: Res<SimClock>,
    body: Res<BodyAcceleration>,
) {
    let _span = tracing::info_span!("verlet_predict").entered();
    half_kick(&mut particles, &body, clock.dt, true);
}

pub fn verlet_correct(
    mut particles: ResMut<Particles>,
    clock: Res<SimClock>,
    body: Res<BodyAcceleration>,
) {
    let _span = tracing::info_span!("verlet_correct").entered();
    half_kick(&mut particles, &body, clock.dt, false);
}
