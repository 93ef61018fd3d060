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

/// Kinetic energy, the first non-finite particle row, and the failure verdict.
pub fn stability_monitor(
    particles: Res<Particles>,
    clock: Res<SimClock>,
    mut health: ResMut<RunHealth>,
) {
    let _span = tracing::info_span!("stability_monitor").entered();
    let [x, y, z] = &particles.position;
    let [vx, vy, vz] = &particles.velocity;
    let im = &particles.inv_mass;
    let n = particles.len();
    // Per-chunk sums added in chunk order: the same value for any thread count.
    let parts: Vec<(f64, Option<usize>)> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let range = c * CHUNK..((c + 1) * CHUNK).min(n);
            // Branch-free sums, four particles at a time in lanes (one running sum would
            // wait on the previous addition at every particle); a non-finite value
            // anywhere makes `check` non-finite, and only then is the chunk searched for
            // its first one. Lanes and the tail are added in a fixed order.
            let (mut ke, mut check) = (f64x4::ZERO, f64x4::ZERO);
            let lanes =
                |col: &[f64], i: usize| f64x4::new([col[i], col[i + 1], col[i + 2], col[i + 3]]);
            let whole = range.start + range.len() / 4 * 4;
            for i in (range.start..whole).step_by(4) {
                let (a, b, c) = (lanes(vx, i), lanes(vy, i), lanes(vz, i));
                let v2 = a * a + b * b + c * c;
                ke += f64x4::splat(0.5) * v2 / lanes(im, i);
                check += v2 + lanes(x, i) + lanes(y, i) + lanes(z, i);
            }
            let (mut ke, mut check) = (lane_sum(ke), lane_sum(check));
            for i in whole..range.end {
                let v2 = vx[i] * vx[i] + vy[i] * vy[i] + vz[i] * vz[i];
                ke += 0.5 * v2 / im[i];
                check += v2 + x[i] + y[i] + z[i];
            }
            let bad = if check.is_finite() {
                None
            } else {
                range.into_iter().find(|&i| {
                    !(vx[i] * vx[i] + vy[i] * vy[i] + vz[i] * vz[i] + x[i] + y[i] + z[i])
                        .is_finite()
                })
            };
            (ke, bad)
        })
        .collect();
    health.kinetic_energy = parts.iter().map(|p| p.0).sum();
    health.non_finite_particle = parts.iter().find_map(|p| p.1).map(|i| particles.id[i]);
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
