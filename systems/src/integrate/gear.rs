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
//! With [`PredictAhead`] granted, the corrector also runs the next step's predictor on
//! each row it has corrected, in the same pass: one pass over the state per step instead
//! of two, the same arithmetic in the same order.
//!
//! Under a constant force (free fall) b and c decay geometrically towards zero and would
//! become subnormal numbers, whose arithmetic is about a hundred times slower: the
//! corrector sets |b|, |c| < 1e-150 (in SI units: physically nil) to zero.
use bevy_ecs::prelude::*;
use grainflow_components::{
    BodyAcceleration, GearState, Particles, PredictAhead, RunHealth, SimClock, StepMotion,
};
use rayon::prelude::*;

use crate::monitor::state_is_finite;
use crate::team::StaticSplit;
use crate::{body_acceleration_column, chunks_of_three_coordinates, BodyColumn, CHUNK};

pub fn gear_predict(
    mut particles: ResMut<Particles>,
    mut gear: ResMut<GearState>,
    clock: Res<SimClock>,
    mut motion: ResMut<StepMotion>,
) {
    let _span = tracing::info_span!("gear_predict").entered();
    // Rows the last corrector predicted already (PredictAhead); their move is in `motion`.
    let start = std::mem::take(&mut gear.predicted_rows).min(particles.len());
    if start == particles.len() {
        return;
    }
    let steps = predictor_steps(clock.dt);
    let GearState {
        acc, jerk, snap, ..
    } = &*gear;
    let Particles {
        position, velocity, ..
    } = &mut *particles;
    let mut largest = 0.0f64;
    for d in 0..3 {
        let column_largest = (
            position[d][start..].par_chunks_mut(CHUNK),
            velocity[d][start..].par_chunks_mut(CHUNK),
            acc[d][start..].par_chunks(CHUNK),
            jerk[d][start..].par_chunks(CHUNK),
            snap[d][start..].par_chunks(CHUNK),
        )
            .into_par_iter()
            .static_map_reduce(
                |(x, v, a, b, c)| {
                    let n = x.len();
                    let (v, a, b, c) = (&mut v[..n], &a[..n], &b[..n], &c[..n]);
                    let mut largest = 0u64;
                    for k in 0..n {
                        let dx = predict_row([&mut x[k], &mut v[k]], a[k], b[k], c[k], steps);
                        largest = largest.max(dx.abs().to_bits());
                    }
                    f64::from_bits(largest)
                },
                || 0.0,
                f64::max,
            );
        largest = largest.max(column_largest);
    }
    // The corrector of the last step moved x too (by alpha_0 dt^2/2 Delta): its share is
    // in `motion` already.
    motion.add(largest * (1.0 + 1e-12));
}

/// The corrector; with [`PredictAhead`] granted, also the next step's predictor on each
/// corrected row, in the same pass (the same arithmetic as [`gear_predict`], so the
/// results do not change). The pass also bounds the positions and velocities it leaves,
/// which spares the monitor its own pass over them when they are finite
/// ([`RunHealth::state_found_finite`]).
pub fn gear_correct(
    mut particles: ResMut<Particles>,
    mut gear: ResMut<GearState>,
    clock: Res<SimClock>,
    body: Res<BodyAcceleration>,
    mut motion: ResMut<StepMotion>,
    mut health: ResMut<RunHealth>,
    predict_ahead: Option<Res<PredictAhead>>,
) {
    let ahead = predict_ahead.is_some_and(|p| p.allowed);
    let _span = tracing::info_span!("gear_correct", ahead).entered();
    let dt = clock.dt;
    let coefficients = CorrectorCoefficients::new(dt, gear.alpha0);
    let cx = coefficients.x;
    let steps = predictor_steps(dt);
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
    let g = [0, 1, 2].map(|d| body_acceleration_column(&body, d));
    // One work item per chunk of rows, with its rows of all three coordinates: one pass
    // (inverse mass and material read once per row), as one part per thread.
    let items = chunks_of_three_coordinates(
        [position, velocity, acc, jerk, snap],
        force,
        inv_mass,
        material,
    );
    let all = items.into_par_iter().static_map_reduce(
        |([x, v, a, b, c], f, im, m)| {
            let k = (&coefficients, steps);
            let rows = x.into_iter().zip(v).zip(a).zip(b).zip(c);
            let mut chunk = Largest::default();
            for (d, ((((x, v), a), b), c)) in rows.enumerate() {
                let (rows, f) = ([x, v, a, b, c], f[d]);
                // One monomorphised loop per kind of body force and per pass, each with
                // the rows inlined (a closure called from two loops was not, and lost
                // the vector code).
                chunk = chunk.max(match (&g[d], ahead) {
                    (BodyColumn::Uniform(g), false) => {
                        correct_chunk::<false>(rows, f, im, |_| *g, k)
                    }
                    (BodyColumn::Uniform(g), true) => correct_chunk::<true>(rows, f, im, |_| *g, k),
                    (BodyColumn::PerMaterial(g), false) => {
                        correct_chunk::<false>(rows, f, im, |i| g[m[i] as usize], k)
                    }
                    (BodyColumn::PerMaterial(g), true) => {
                        correct_chunk::<true>(rows, f, im, |i| g[m[i] as usize], k)
                    }
                });
            }
            chunk
        },
        Largest::default,
        Largest::max,
    );
    // |x move| = alpha_0 dt^2/2 |Delta| (cx > 0: the largest product is that of the
    // largest |Delta|).
    let largest = cx * f64::from_bits(all.delta);
    // This move and the next predictor's add (triangle inequality), in the order of the
    // two passes.
    motion.add(largest * (1.0 + 1e-12));
    if ahead {
        motion.add(f64::from_bits(all.ahead) * (1.0 + 1e-12));
        gear.predicted_rows = particles.len();
    }
    health.state_found_finite = state_is_finite(all.position, all.velocity);
}

/// Bits of the largest absolute values of a corrector pass (non-negative floats order
/// like their bits; NaN above all): |Delta|, the predicted |dx| (0 without predicting
/// ahead), and |x| and |v| as the pass leaves them.
#[derive(Debug, Clone, Copy, Default)]
struct Largest {
    delta: u64,
    ahead: u64,
    position: u64,
    velocity: u64,
}

impl Largest {
    fn max(self, o: Self) -> Self {
        Self {
            delta: self.delta.max(o.delta),
            ahead: self.ahead.max(o.ahead),
            position: self.position.max(o.position),
            velocity: self.velocity.max(o.velocity),
        }
    }
}

/// The Taylor steps of the predictor: dt, dt^2/2, dt^3/6, dt^4/24.
pub(crate) fn predictor_steps(dt: f64) -> [f64; 4] {
    [
        dt,
        dt * dt / 2.0,
        dt * dt * dt / 6.0,
        dt * dt * dt * dt / 24.0,
    ]
}

/// The predictor on one row: x += v dt + a dt^2/2 + b dt^3/6 + c dt^4/24 and
/// v += a dt + b dt^2/2 + c dt^3/6 (`steps` from [`predictor_steps`]); returns the move
/// of x.
#[inline(always)]
pub(crate) fn predict_row(
    [x, v]: [&mut f64; 2],
    a: f64,
    b: f64,
    c: f64,
    [dt, h2, h3, h4]: [f64; 4],
) -> f64 {
    let dx = *v * dt + a * h2 + b * h3 + c * h4;
    *x += dx;
    *v += a * dt + b * h2 + c * h3;
    dx
}

/// The corrector's factors of Delta (module doc) and the steps of the predicted
/// derivatives.
pub(crate) struct CorrectorCoefficients {
    dt: f64,
    h2: f64,
    x: f64,
    v: f64,
    b: f64,
    c: f64,
}

impl CorrectorCoefficients {
    pub(crate) fn new(dt: f64, alpha0: f64) -> Self {
        Self {
            dt,
            h2: dt * dt / 2.0,
            x: alpha0 * dt * dt / 2.0,
            v: 3.0 / 8.0 * dt,
            b: 1.5 / dt,
            c: 1.0 / (dt * dt),
        }
    }
}

/// The corrector on the rows (x, v, a, b, c) of one chunk towards the accelerations
/// F/m + `body(i)`; with `AHEAD` also the next predictor on every corrected row.
#[inline(always)]
fn correct_chunk<const AHEAD: bool>(
    [x, v, a, b, c]: [&mut [f64]; 5],
    force: &[f64],
    inv_mass: &[f64],
    body: impl Fn(usize) -> f64,
    (k, steps): (&CorrectorCoefficients, [f64; 4]),
) -> Largest {
    let n = x.len();
    let (v, a, b, c, f, im) = (
        &mut v[..n],
        &mut a[..n],
        &mut b[..n],
        &mut c[..n],
        &force[..n],
        &inv_mass[..n],
    );
    let mut largest = Largest::default();
    for i in 0..n {
        // The row is read into locals and written back once. Through references into
        // the five slices, the compiler stored x and v twice and read back what it had
        // just stored (it cannot tell the slices apart after inlining): the pass took
        // 1.5 times as long as the same loop written in C (docs/performance.md).
        let (mut xi, mut vi, mut ai, mut bi, mut ci) = (x[i], v[i], a[i], b[i], c[i]);
        let row = [&mut xi, &mut vi, &mut ai, &mut bi, &mut ci];
        let delta = correct_row(row, f[i] * im[i] + body(i), k);
        largest.delta = largest.delta.max(delta.abs().to_bits());
        if AHEAD {
            let dx = predict_row([&mut xi, &mut vi], ai, bi, ci, steps);
            largest.ahead = largest.ahead.max(dx.abs().to_bits());
        }
        largest.position = largest.position.max(xi.abs().to_bits());
        largest.velocity = largest.velocity.max(vi.abs().to_bits());
        (x[i], v[i], a[i], b[i], c[i]) = (xi, vi, ai, bi, ci);
    }
    largest
}

/// The corrector on one row (x, v, a, b, c) towards the acceleration `target` = F/m + g,
/// from the predicted a_p = a + b dt + c dt^2/2 and b_p = b + c dt (see the module doc);
/// returns Delta = target - a_p.
#[inline(always)]
pub(crate) fn correct_row(
    [x, v, a, b, c]: [&mut f64; 5],
    target: f64,
    k: &CorrectorCoefficients,
) -> f64 {
    let (a_p, b_p) = predicted_derivatives(*a, *b, *c, k.dt, k.h2);
    let delta = target - a_p;
    *x += k.x * delta;
    *v += k.v * delta;
    *a = a_p + delta;
    *b = flush_tiny(b_p + k.b * delta);
    *c = flush_tiny(*c + k.c * delta);
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
