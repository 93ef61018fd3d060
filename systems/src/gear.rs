//! Gear predictor-corrector with five values for the second-order equations of motion
//! (Gear 1971; Allen & Tildesley 1987, Appendix E): position x, velocity v, acceleration
//! a, and its derivatives b = da/dt, c = d2a/dt2.
//!
//! Predictor (Taylor series):  x += v dt + a dt^2/2 + b dt^3/6 + c dt^4/24,
//!   v += a dt + b dt^2/2 + c dt^3/6,  a += b dt + c dt^2/2,  b += c dt.
//! Corrector with Delta = a(F(x_p, v_p)) - a_p and the scaled coefficients
//! (alpha_0, 3/4, 1, 1/2, 1/12):  x += alpha_0 dt^2/2 Delta,  v += 3/8 dt Delta,
//!   a += Delta,  b += 3/2 Delta/dt,  c += Delta/dt^2.
//! alpha_0 = 19/120, or 19/90 when the forces depend on the velocity (damping).
//!
//! The predictor writes only x and v, which the forces need: the corrector forms the
//! predicted a_p = a + b dt + c dt^2/2 and b_p = b + c dt itself, with the same
//! arithmetic, from the a, b, c of the last step (two columns per coordinate fewer
//! written per step).
//!
//! Under a constant force (free fall) b and c decay geometrically towards zero and would
//! become subnormal numbers, whose arithmetic is about a hundred times slower: the
//! corrector sets |b|, |c| < 1e-150 (in SI units: physically nil) to zero.
use bevy_ecs::prelude::*;
use grainflow_components::{BodyAcceleration, GearState, Particles, SimClock, StepMotion};
use rayon::prelude::*;

use crate::{body_acceleration_column, BodyColumn, CHUNK};

pub fn gear_predict(
    mut particles: ResMut<Particles>,
    gear: Res<GearState>,
    clock: Res<SimClock>,
    mut motion: ResMut<StepMotion>,
) {
    let _span = tracing::info_span!("gear_predict").entered();
    let dt = clock.dt;
    let (h2, h3, h4) = (dt * dt / 2.0, dt * dt * dt / 6.0, dt * dt * dt * dt / 24.0);
    let GearState {
        acc, jerk, snap, ..
    } = &*gear;
    let Particles {
        position, velocity, ..
    } = &mut *particles;
    let mut largest = 0.0f64;
    for d in 0..3 {
        let column_largest = (
            position[d].par_chunks_mut(CHUNK),
            velocity[d].par_chunks_mut(CHUNK),
            acc[d].par_chunks(CHUNK),
            jerk[d].par_chunks(CHUNK),
            snap[d].par_chunks(CHUNK),
        )
            .into_par_iter()
            .map(|(x, v, a, b, c)| {
                let n = x.len();
                let (v, a, b, c) = (&mut v[..n], &a[..n], &b[..n], &c[..n]);
                let mut largest = 0u64;
                for k in 0..n {
                    let dx = v[k] * dt + a[k] * h2 + b[k] * h3 + c[k] * h4;
                    x[k] += dx;
                    largest = largest.max(dx.abs().to_bits());
                    v[k] += a[k] * dt + b[k] * h2 + c[k] * h3;
                }
                f64::from_bits(largest)
            })
            .reduce(|| 0.0, f64::max);
        largest = largest.max(column_largest);
    }
    // The corrector moves x again (by alpha_0 dt^2/2 Delta) and adds its share.
    motion.max_component = Some(largest * (1.0 + 1e-12));
}

pub fn gear_correct(
    mut particles: ResMut<Particles>,
    mut gear: ResMut<GearState>,
    clock: Res<SimClock>,
    body: Res<BodyAcceleration>,
    mut motion: ResMut<StepMotion>,
) {
    let _span = tracing::info_span!("gear_correct").entered();
    let dt = clock.dt;
    let h2 = dt * dt / 2.0;
    let cx = gear.alpha0 * dt * dt / 2.0;
    let (cv, cb, cc) = (3.0 / 8.0 * dt, 1.5 / dt, 1.0 / (dt * dt));
    let GearState {
        acc, jerk, snap, ..
    } = &mut *gear;
    let Particles {
        position,
        velocity,
        force,
        inv_mass,
        material,
        ..
    } = &mut *particles;
    let mut largest = 0.0f64;
    for d in 0..3 {
        let g = body_acceleration_column(&body, d);
        let column_largest = (
            position[d].par_chunks_mut(CHUNK),
            velocity[d].par_chunks_mut(CHUNK),
            acc[d].par_chunks_mut(CHUNK),
            jerk[d].par_chunks_mut(CHUNK),
            snap[d].par_chunks_mut(CHUNK),
            force[d].par_chunks(CHUNK),
            inv_mass.par_chunks(CHUNK),
            material.par_chunks(CHUNK),
        )
            .into_par_iter()
            .map(|(x, v, a, b, c, f, im, m)| {
                let n = x.len();
                let (v, a, b, c, f, im, m) = (
                    &mut v[..n],
                    &mut a[..n],
                    &mut b[..n],
                    &mut c[..n],
                    &f[..n],
                    &im[..n],
                    &m[..n],
                );
                let coefficients = [dt, h2, cx, cv, cb, cc];
                let mut largest = 0u64;
                // One loop per kind of body force, each with the row inlined (a closure
                // called from both was not, and lost the vector code).
                match &g {
                    BodyColumn::Uniform(g) => {
                        for k in 0..n {
                            let row = [&mut x[k], &mut v[k], &mut a[k], &mut b[k], &mut c[k]];
                            let delta = correct_row(row, f[k] * im[k] + g, coefficients);
                            largest = largest.max(delta.abs().to_bits());
                        }
                    }
                    BodyColumn::PerMaterial(g) => {
                        for k in 0..n {
                            let row = [&mut x[k], &mut v[k], &mut a[k], &mut b[k], &mut c[k]];
                            let target = f[k] * im[k] + g[m[k] as usize];
                            let delta = correct_row(row, target, coefficients);
                            largest = largest.max(delta.abs().to_bits());
                        }
                    }
                }
                cx * f64::from_bits(largest)
            })
            .reduce(|| 0.0, f64::max);
        largest = largest.max(column_largest);
    }
    // Predictor and corrector moves add (triangle inequality).
    motion.max_component = motion.max_component.map(|m| m + largest * (1.0 + 1e-12));
}

/// The corrector on one row (x, v, a, b, c) towards the acceleration `target` = F/m + g,
/// from the predicted a_p = a + b dt + c dt^2/2 and b_p = b + c dt (see the module doc);
/// returns Delta = target - a_p.
#[inline(always)]
fn correct_row(
    [x, v, a, b, c]: [&mut f64; 5],
    target: f64,
    [dt, h2, cx, cv, cb, cc]: [f64; 6],
) -> f64 {
    let (a_p, b_p) = predicted_derivatives(*a, *b, *c, dt, h2);
    let delta = target - a_p;
    *x += cx * delta;
    *v += cv * delta;
    *a = a_p + delta;
    *b = flush_tiny(b_p + cb * delta);
    *c = flush_tiny(*c + cc * delta);
    delta
}

/// The predictor's a_p = a + b dt + c dt^2/2 and b_p = b + c dt (`h2` = dt^2/2), formed
/// by the correctors (translation and rotation) instead of stored by the predictors.
#[inline(always)]
pub(crate) fn predicted_derivatives(a: f64, b: f64, c: f64, dt: f64, h2: f64) -> (f64, f64) {
    (a + (b * dt + c * h2), b + c * dt)
}

/// Zero for |x| < 1e-150, else x.
#[inline(always)]
pub(crate) fn flush_tiny(x: f64) -> f64 {
    if x.abs() < 1e-150 {
        0.0
    } else {
        x
    }
}

/// Start-up: the acceleration from the forces at t = 0, higher derivatives zero.
pub fn gear_start(
    particles: Res<Particles>,
    mut gear: ResMut<GearState>,
    body: Res<BodyAcceleration>,
) {
    for d in 0..3 {
        for i in 0..particles.len() {
            gear.acc[d][i] = particles.force[d][i] * particles.inv_mass[i]
                + body.per_material[particles.material[i] as usize][d];
            gear.jerk[d][i] = 0.0;
            gear.snap[d][i] = 0.0;
        }
    }
}
