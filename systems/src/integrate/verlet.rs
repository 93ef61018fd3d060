//! Velocity Verlet (Swope, Andersen, Berens & Wilson 1982) with a = F/m + g (1 - rho_f/rho):
//!
//!   predictor:  v(t + dt/2) = v(t) + a(t) dt/2,  x(t + dt) = x(t) + v(t + dt/2) dt,
//!   corrector:  v(t + dt) = v(t + dt/2) + a(t + dt) dt/2.
//!
//! Forces that depend on the velocity (damping) are evaluated with the estimate
//! v*(t + dt) = v(t + dt/2) + a(t) dt/2, second-order accurate, so the scheme stays second
//! order with damping (with v(t + dt/2) alone it would be first order). The half-step
//! velocity waits in [`VerletState`] meanwhile.
//!
//! With [`PredictAhead`] granted, the corrector also runs the next step's predictor on
//! each row in the same pass: both kick with the same forces a(t + dt), so the pass reads
//! the state once per step instead of twice, with the same arithmetic in the same order.
use bevy_ecs::prelude::*;
use grainflow_components::{
    BodyAcceleration, Particles, PredictAhead, RunHealth, SimClock, StepMotion, VerletState,
};
use rayon::prelude::*;

use crate::monitor::state_is_finite;
use crate::team::StaticSplit;
use crate::{body_acceleration_column, chunks_of_three_coordinates, BodyColumn, CHUNK};

pub fn verlet_predict(
    mut particles: ResMut<Particles>,
    mut state: ResMut<VerletState>,
    mut motion: ResMut<StepMotion>,
    clock: Res<SimClock>,
    body: Res<BodyAcceleration>,
) {
    let _span = tracing::info_span!("verlet_predict").entered();
    // Rows the last corrector predicted already (PredictAhead); their move is in `motion`.
    let start = std::mem::take(&mut state.predicted_rows).min(particles.len());
    if start == particles.len() {
        return;
    }
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
            position[d][start..].par_chunks_mut(CHUNK),
            velocity[d][start..].par_chunks_mut(CHUNK),
            state.half_velocity[d][start..].par_chunks_mut(CHUNK),
            force[d][start..].par_chunks(CHUNK),
            inv_mass[start..].par_chunks(CHUNK),
            material[start..].par_chunks(CHUNK),
        )
            .into_par_iter()
            .static_map_reduce(
                |(x, v, vh, f, im, m)| {
                    let n = x.len();
                    let (v, vh, f, im, m) = (&mut v[..n], &mut vh[..n], &f[..n], &im[..n], &m[..n]);
                    let mut fastest = 0u64;
                    let mut predict = |k: usize, g: f64| {
                        let kick = h * (f[k] * im[k] + g);
                        predict_row([&mut x[k], &mut v[k], &mut vh[k]], kick, dt);
                        fastest = fastest.max(vh[k].abs().to_bits());
                    };
                    match &g {
                        BodyColumn::Uniform(g) => (0..n).for_each(|k| predict(k, *g)),
                        BodyColumn::PerMaterial(g) => {
                            (0..n).for_each(|k| predict(k, g[m[k] as usize]))
                        }
                    }
                    f64::from_bits(fastest)
                },
                || 0.0,
                f64::max,
            );
        fastest = fastest.max(column_fastest);
    }
    // |dx_d| = dt |v_d(t + dt/2)|, rounded up by a relative 1e-12 for the products.
    motion.add(dt * fastest * (1.0 + 1e-12));
}

/// The corrector; with [`PredictAhead`] granted, also the next step's predictor on each
/// corrected row, in the same pass, which then bounds the positions and velocities it
/// leaves ([`RunHealth::state_found_finite`]).
pub fn verlet_correct(
    mut particles: ResMut<Particles>,
    mut state: ResMut<VerletState>,
    clock: Res<SimClock>,
    body: Res<BodyAcceleration>,
    mut motion: ResMut<StepMotion>,
    mut health: ResMut<RunHealth>,
    predict_ahead: Option<Res<PredictAhead>>,
) {
    let ahead = predict_ahead.is_some_and(|p| p.allowed);
    let _span = tracing::info_span!("verlet_correct", ahead).entered();
    let dt = clock.dt;
    let Particles {
        position,
        velocity,
        force,
        inv_mass,
        material,
        ..
    } = &mut *particles;
    let g = [0, 1, 2].map(|d| body_acceleration_column(&body, d));
    // One work item per chunk of rows, with its rows of all three coordinates (as the
    // Gear corrector).
    let items = chunks_of_three_coordinates(
        [position, velocity, &mut state.half_velocity],
        force,
        inv_mass,
        material,
    );
    let all = items.into_par_iter().static_map_reduce(
        |([x, v, vh], f, im, m)| {
            let mut chunk = Largest::default();
            for (d, ((x, v), vh)) in x.into_iter().zip(v).zip(vh).enumerate() {
                let (rows, f) = ([x, v, vh], f[d]);
                // One monomorphised loop per kind of body force and per pass.
                chunk = chunk.max(match (&g[d], ahead) {
                    (BodyColumn::Uniform(g), false) => {
                        correct_chunk::<false>(rows, f, im, |_| *g, dt)
                    }
                    (BodyColumn::Uniform(g), true) => {
                        correct_chunk::<true>(rows, f, im, |_| *g, dt)
                    }
                    (BodyColumn::PerMaterial(g), false) => {
                        correct_chunk::<false>(rows, f, im, |i| g[m[i] as usize], dt)
                    }
                    (BodyColumn::PerMaterial(g), true) => {
                        correct_chunk::<true>(rows, f, im, |i| g[m[i] as usize], dt)
                    }
                });
            }
            chunk
        },
        Largest::default,
        Largest::max,
    );
    if ahead {
        // As the predictor reports it.
        motion.add(dt * f64::from_bits(all.half_velocity) * (1.0 + 1e-12));
        state.predicted_rows = particles.len();
        health.state_found_finite = state_is_finite(all.position, all.velocity);
    }
}

/// The predictor's half kick and drift on one row with the kick a(t) dt/2:
/// v(t + dt/2) = v + kick, x += v(t + dt/2) dt, and the estimate v*(t + dt) =
/// v(t + dt/2) + kick (module doc).
#[inline(always)]
fn predict_row([x, v, vh]: [&mut f64; 3], kick: f64, dt: f64) {
    *vh = *v + kick;
    *x += dt * *vh;
    *v = *vh + kick;
}

/// Bits of the largest absolute values of a predicting-ahead corrector pass (as in
/// `gear.rs`): v(t + dt/2) of the next step, and x and v as the pass leaves them.
#[derive(Debug, Clone, Copy, Default)]
struct Largest {
    half_velocity: u64,
    position: u64,
    velocity: u64,
}

impl Largest {
    fn max(self, o: Self) -> Self {
        Self {
            half_velocity: self.half_velocity.max(o.half_velocity),
            position: self.position.max(o.position),
            velocity: self.velocity.max(o.velocity),
        }
    }
}

/// The corrector v = v(t + dt/2) + a dt/2 on the rows of one chunk, a = F/m + `body(i)`;
/// with `AHEAD` also the next predictor on every corrected row, with the same kick.
#[inline(always)]
fn correct_chunk<const AHEAD: bool>(
    [x, v, vh]: [&mut [f64]; 3],
    force: &[f64],
    inv_mass: &[f64],
    body: impl Fn(usize) -> f64,
    dt: f64,
) -> Largest {
    let h = 0.5 * dt;
    let n = v.len();
    let (x, vh, f, im) = (&mut x[..n], &mut vh[..n], &force[..n], &inv_mass[..n]);
    let mut largest = Largest::default();
    for i in 0..n {
        let kick = h * (f[i] * im[i] + body(i));
        let mut vi = vh[i] + kick;
        if AHEAD {
            // The row in locals, written back once (as in the Gear corrector: through
            // references into the slices, v was stored twice).
            let (mut xi, mut vhi) = (x[i], vh[i]);
            predict_row([&mut xi, &mut vi, &mut vhi], kick, dt);
            largest.half_velocity = largest.half_velocity.max(vhi.abs().to_bits());
            largest.position = largest.position.max(xi.abs().to_bits());
            largest.velocity = largest.velocity.max(vi.abs().to_bits());
            (x[i], vh[i]) = (xi, vhi);
        }
        v[i] = vi;
    }
    largest
}
