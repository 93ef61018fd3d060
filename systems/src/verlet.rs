//! Velocity Verlet (Swope, Andersen, Berens & Wilson 1982) with a = F/m + g (1 - rho_f/rho):
//!
//!   predictor:  v(t + dt/2) = v(t) + a(t) dt/2,  x(t + dt) = x(t) + v(t + dt/2) dt,
//!   corrector:  v(t + dt) = v(t + dt/2) + a(t + dt) dt/2.
//!
//! Forces that depend on the velocity (damping) are evaluated with the estimate
//! v*(t + dt) = v(t + dt/2) + a(t) dt/2, second-order accurate, so the scheme stays second
//! order with damping (with v(t + dt/2) alone it would be first order). The half-step
//! velocity waits in [`VerletState`] meanwhile.
use bevy_ecs::prelude::*;
use grainflow_components::{BodyAcceleration, Particles, SimClock, StepMotion, VerletState};
use rayon::prelude::*;

use crate::{body_acceleration_column, BodyColumn, CHUNK};

pub fn verlet_predict(
    mut particles: ResMut<Particles>,
    mut state: ResMut<VerletState>,
    mut motion: ResMut<StepMotion>,
    clock: Res<SimClock>,
    body: Res<BodyAcceleration>,
) {
    let _span = tracing::info_span!("verlet_predict").entered();
    let dt = clock.dt;
    let h = 0.5 * dt;
    let Particles {
        position,
        velocity,
        force,
        inv_mass,
        material,
        ..
    } = &mut *particles;
    let mut fastest = 0.0f64;
    for d in 0..3 {
        let g = body_acceleration_column(&body, d);
        let column_fastest = (
            position[d].par_chunks_mut(CHUNK),
            velocity[d].par_chunks_mut(CHUNK),
            state.half_velocity[d].par_chunks_mut(CHUNK),
            force[d].par_chunks(CHUNK),
            inv_mass.par_chunks(CHUNK),
            material.par_chunks(CHUNK),
        )
            .into_par_iter()
            .map(|(x, v, vh, f, im, m)| {
                let n = x.len();
                let (v, vh, f, im, m) = (&mut v[..n], &mut vh[..n], &f[..n], &im[..n], &m[..n]);
                let mut fastest = 0u64;
                let mut predict = |k: usize, g: f64| {
                    let kick = h * (f[k] * im[k] + g);
                    vh[k] = v[k] + kick;
                    x[k] += dt * vh[k];
                    v[k] = vh[k] + kick;
                    fastest = fastest.max(vh[k].abs().to_bits());
                };
                match &g {
                    BodyColumn::Uniform(g) => (0..n).for_each(|k| predict(k, *g)),
                    BodyColumn::PerMaterial(g) => (0..n).for_each(|k| predict(k, g[m[k] as usize])),
                }
                f64::from_bits(fastest)
            })
            .reduce(|| 0.0, f64::max);
        fastest = fastest.max(column_fastest);
    }
    // |dx_d| = dt |v_d(t + dt/2)|, rounded up by a relative 1e-12 for the products.
    motion.add(dt * fastest * (1.0 + 1e-12));
}

pub fn verlet_correct(
    mut particles: ResMut<Particles>,
    state: Res<VerletState>,
    clock: Res<SimClock>,
    body: Res<BodyAcceleration>,
) {
    let _span = tracing::info_span!("verlet_correct").entered();
    let h = 0.5 * clock.dt;
    let Particles {
        velocity,
        force,
        inv_mass,
        material,
        ..
    } = &mut *particles;
    for d in 0..3 {
        let g = body_acceleration_column(&body, d);
        (
            velocity[d].par_chunks_mut(CHUNK),
            state.half_velocity[d].par_chunks(CHUNK),
            force[d].par_chunks(CHUNK),
            inv_mass.par_chunks(CHUNK),
            material.par_chunks(CHUNK),
        )
            .into_par_iter()
            .for_each(|(v, vh, f, im, m)| {
                let n = v.len();
                let (vh, f, im, m) = (&vh[..n], &f[..n], &im[..n], &m[..n]);
                let mut correct = |k: usize, g: f64| v[k] = vh[k] + h * (f[k] * im[k] + g);
                match &g {
                    BodyColumn::Uniform(g) => (0..n).for_each(|k| correct(k, *g)),
                    BodyColumn::PerMaterial(g) => (0..n).for_each(|k| correct(k, g[m[k] as usize])),
                }
            });
    }
}
