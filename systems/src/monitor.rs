//! Stability monitor: stops a run whose state is no longer physical (non-finite values or
//! an overlap beyond the limit), naming the step and the particle; and the clock.
use bevy_ecs::prelude::*;
use grainflow_components::{Particles, RunHealth, SimClock};
use rayon::prelude::*;
use wide::f64x4;

use crate::real::lane_sum;
use crate::CHUNK;

/// Advance the simulated time by one step (last system of the corrector set).
pub fn advance_clock(mut clock: ResMut<SimClock>) {
    clock.step += 1;
    clock.time = clock.step as f64 * clock.dt;
}

/// The first non-finite particle and the failure verdict. Every step reads positions and
/// velocities once, unless the integrator found them finite in its own pass
/// (`RunHealth::state_found_finite`, [`state_is_finite`]: the Gear corrector, and velocity
/// Verlet's when it predicts ahead); the kinetic energy, wanted only in the run summary,
/// is computed there ([`kinetic_energy`]).
pub fn stability_monitor(
    particles: Res<Particles>,
    clock: Res<SimClock>,
    mut health: ResMut<RunHealth>,
) {
    let _span = tracing::info_span!("stability_monitor").entered();
    let [x, y, z] = &particles.position;
    let [vx, vy, vz] = &particles.velocity;
    let n = particles.len();
    // The first non-finite row of each chunk, in chunk order (none when the integrator
    // has checked already).
    let chunks = if std::mem::take(&mut health.state_found_finite) {
        0
    } else {
        n.div_ceil(CHUNK)
    };
    let first_bad = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let range = c * CHUNK..((c + 1) * CHUNK).min(n);
            let state =
                |i: usize| vx[i] * vx[i] + vy[i] * vy[i] + vz[i] * vz[i] + x[i] + y[i] + z[i];
            // Branch-free, four particles at a time in lanes: a non-finite value anywhere
            // makes `check` non-finite, and only then is the chunk searched for its first.
            let mut check = f64x4::ZERO;
            let whole = range.start + range.len() / 4 * 4;
            for i in (range.start..whole).step_by(4) {
                let (a, b, c) = (four_at(vx, i), four_at(vy, i), four_at(vz, i));
                check += a * a + b * b + c * c + four_at(x, i) + four_at(y, i) + four_at(z, i);
            }
            let check = (whole..range.end).fold(lane_sum(check), |s, i| s + state(i));
            if check.is_finite() {
                None
            } else {
                range.into_iter().find(|&i| !state(i).is_finite())
            }
        })
        .find_first(|bad| bad.is_some())
        .flatten();
    health.non_finite_particle = first_bad.map(|i| particles.id[i]);
    if health.failure.is_some() {
        return;
    }
    if let Some(id) = health.non_finite_particle {
        health.failure = Some(format!(
            "unstable at step {} (t = {:.6e} s): particle {id} has a non-finite position or velocity",
            clock.step, clock.time
        ));
    } else if health.max_overlap_ratio > health.overlap_limit {
        health.failure = Some(format!(
            "unstable at step {} (t = {:.6e} s): particle {} overlaps by {:.1} % of its radius (limit {:.0} %); \
             the time step is too large for the contact stiffness, or particles were placed overlapping",
            clock.step,
            clock.time,
            health.max_overlap_particle,
            100.0 * health.max_overlap_ratio,
            100.0 * health.overlap_limit
        ));
    }
}

/// Whether an integrator's own bounds on what it left, the bits of the largest |x| and
/// |v| (non-negative floats order like their bits; NaN above all), spare the monitor its
/// pass: below these bounds every sum of the monitor's check is finite (3 v^2 + 3 |x| <
/// 1e301), and NaN fails the comparisons.
pub fn state_is_finite(largest_position_bits: u64, largest_velocity_bits: u64) -> bool {
    f64::from_bits(largest_position_bits) < 1e300 && f64::from_bits(largest_velocity_bits) < 1e150
}

/// Kinetic energy of translation, sum of m v^2 / 2, J: per-chunk sums (four particles at a
/// time in lanes) added in chunk order, the same value for any thread count.
pub fn kinetic_energy(particles: &Particles) -> f64 {
    let [vx, vy, vz] = &particles.velocity;
    let im = &particles.inv_mass;
    let n = particles.len();
    let parts: Vec<f64> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let range = c * CHUNK..((c + 1) * CHUNK).min(n);
            let whole = range.start + range.len() / 4 * 4;
            let mut ke = f64x4::ZERO;
            for i in (range.start..whole).step_by(4) {
                let (a, b, c) = (four_at(vx, i), four_at(vy, i), four_at(vz, i));
                ke += f64x4::splat(0.5) * (a * a + b * b + c * c) / four_at(im, i);
            }
            (whole..range.end).fold(lane_sum(ke), |s, i| {
                s + 0.5 * (vx[i] * vx[i] + vy[i] * vy[i] + vz[i] * vz[i]) / im[i]
            })
        })
        .collect();
    parts.iter().sum()
}

/// Rows i..i + 4 of a column, in lanes.
#[inline(always)]
fn four_at(col: &[f64], i: usize) -> f64x4 {
    f64x4::new([col[i], col[i + 1], col[i + 2], col[i + 3]])
}
