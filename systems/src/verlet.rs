//! Velocity Verlet (Swope, Andersen, Berens & Wilson 1982):
//!   v(t + dt/2) = v(t) + a(t) dt/2,  x(t + dt) = x(t) + v(t + dt/2) dt,
//!   v(t + dt) = v(t + dt/2) + a(t + dt) dt/2,  a = F/m + g (1 - rho_f/rho).
//! Velocity-dependent (damping) forces use the half-step velocity.
use bevy_ecs::prelude::*;
use grainflow_components::{BodyAcceleration, Particles, SimClock};
use rayon::prelude::*;

use crate::{body_acceleration_column, BodyColumn, CHUNK};

/// Half kick with the current forces, then a drift when `drift` (the predictor), or the
/// closing half kick alone (the corrector).
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
    let step = if drift { dt } else { 0.0 };
    for d in 0..3 {
        let g = body_acceleration_column(body, d);
        (
            position[d].par_chunks_mut(CHUNK),
            velocity[d].par_chunks_mut(CHUNK),
            force[d].par_chunks(CHUNK),
            inv_mass.par_chunks(CHUNK),
            material.par_chunks(CHUNK),
        )
            .into_par_iter()
            .for_each(|(x, v, f, im, m)| {
                let n = x.len();
                let (v, f, im, m) = (&mut v[..n], &f[..n], &im[..n], &m[..n]);
                let mut kick = |k: usize, g: f64| {
                    v[k] += h * (f[k] * im[k] + g);
                    x[k] += step * v[k];
                };
                match &g {
                    BodyColumn::Uniform(g) => (0..n).for_each(|k| kick(k, *g)),
                    BodyColumn::PerMaterial(g) => (0..n).for_each(|k| kick(k, g[m[k] as usize])),
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
