//! Hertz normal contact with damping (Hertz 1896), between particles and with walls.
use bevy_ecs::prelude::*;
use grainflow_components::{
    Materials, PairParams, Particles, RunHealth, VerletList, WallShape, Walls,
};
use rayon::prelude::*;

use crate::walls::wall_distance;
use crate::CHUNK;

/// Normal force (positive = repulsive) of a Hertz contact with overlap `delta` and
/// approach speed `delta_dot`, seed slide "Models for DEM":
///
///   F = c_n delta^(3/2) + d_n delta_dot,  c_n = (4/3) E* sqrt(R*)
///
/// or, with the restitution law, damping -2 sqrt(5/6) beta sqrt(S_n m*) v_n with
/// S_n = 2 E* sqrt(R* delta) (Tsuji et al. 1992 form; see `DampingLaw::Restitution`).
/// `inv_mass_sum` = 1/m_i + 1/m_j = 1/m*. The force is not clipped at zero, so the
/// restitution law gives its coefficient exactly.
#[inline(always)]
pub fn hertz_normal_force(
    p: &PairParams,
    r_eff: f64,
    inv_mass_sum: f64,
    delta: f64,
    delta_dot: f64,
) -> f64 {
    let sqrt_rd = (r_eff * delta).sqrt();
    let elastic = p.hertz_factor * sqrt_rd * delta;
    let damping = if p.restitution_factor > 0.0 {
        p.restitution_factor * (1.5 * p.hertz_factor * sqrt_rd / inv_mass_sum).sqrt() * delta_dot
    } else {
        p.damping_constant * delta_dot
    };
    elastic + damping
}

/// Contact forces of this step: every particle sums its pair forces over its row of the
/// Verlet list (in list order, so the sum does not depend on threads), then its wall
/// forces in wall order. Also finds the largest overlap ratio for the monitor.
pub fn hertz_contact(
    mut particles: ResMut<Particles>,
    list: Res<VerletList>,
    materials: Res<Materials>,
    walls: Option<Res<Walls>>,
    mut health: ResMut<RunHealth>,
) {
    let _span = tracing::info_span!("hertz_contact").entered();
    let active: Vec<(WallShape, u16)> = walls
        .map(|w| {
            w.list
                .iter()
                .filter(|w| w.active)
                .map(|w| (w.shape.clone(), w.material))
                .collect()
        })
        .unwrap_or_default();
    let Particles {
        position,
        velocity,
        radius,
        inv_mass,
        material,
        force,
        id,
        ..
    } = &mut *particles;
    let [x, y, z] = &*position;
    let [vx, vy, vz] = &*velocity;
    let (r, inv_m, mat, id) = (&*radius, &*inv_mass, &*material, &*id);
    let (start, nbr) = (&list.start, &list.neighbours);
    let [fx, fy, fz] = force;
    let mats = &*materials;
    let worst = (
        fx.par_chunks_mut(CHUNK),
        fy.par_chunks_mut(CHUNK),
        fz.par_chunks_mut(CHUNK),
    )
        .into_par_iter()
        .enumerate()
        .map(|(c, (fx, fy, fz))| {
            let base = c * CHUNK;
            let mut worst = (0.0f64, u32::MAX);
            for k in 0..fx.len() {
                let i = base + k;
                let (xi, yi, zi, ri) = (x[i], y[i], z[i], r[i]);
                let (vxi, vyi, vzi, inv_mi, mi) = (vx[i], vy[i], vz[i], inv_m[i], mat[i]);
                let (mut sx, mut sy, mut sz) = (0.0, 0.0, 0.0);
                let mut ratio = 0.0f64;
                for &j in &nbr[start[i] as usize..start[i + 1] as usize] {
                    let j = j as usize;
                    let (dx, dy, dz) = (xi - x[j], yi - y[j], zi - z[j]);
                    let d2 = dx * dx + dy * dy + dz * dz;
                    let rs = ri + r[j];
                    if d2 >= rs * rs {
                        continue;
                    }
                    let d = d2.sqrt();
                    let inv_d = 1.0 / d;
                    let (nx, ny, nz) = (dx * inv_d, dy * inv_d, dz * inv_d);
                    let delta = rs - d;
                    let delta_dot = -((vxi - vx[j]) * nx + (vyi - vy[j]) * ny + (vzi - vz[j]) * nz);
                    let p = mats.pair(mi, mat[j]);
                    let f =
                        hertz_normal_force(p, ri * r[j] / rs, inv_mi + inv_m[j], delta, delta_dot);
                    sx += f * nx;
                    sy += f * ny;
                    sz += f * nz;
                    ratio = ratio.max(delta / ri.min(r[j]));
                }
                for (shape, wm) in &active {
                    let (dist, n) = wall_distance(shape, [xi, yi, zi]);
                    if dist >= ri {
                        continue;
                    }
                    let delta = ri - dist;
                    let delta_dot = -(vxi * n[0] + vyi * n[1] + vzi * n[2]);
                    let f = hertz_normal_force(mats.pair(*wm, mi), ri, inv_mi, delta, delta_dot);
                    sx += f * n[0];
                    sy += f * n[1];
                    sz += f * n[2];
                    ratio = ratio.max(delta / ri);
                }
                fx[k] = sx;
                fy[k] = sy;
                fz[k] = sz;
                if ratio > worst.0 || (ratio == worst.0 && ratio > 0.0 && id[i] < worst.1) {
                    worst = (ratio, id[i]);
                }
            }
            worst
        })
        .reduce(
            || (0.0, u32::MAX),
            |a, b| {
                if b.0 > a.0 || (b.0 == a.0 && b.1 < a.1) {
                    b
                } else {
                    a
                }
            },
        );
    health.max_overlap_ratio = worst.0;
    health.max_overlap_particle = worst.1;
    health.run_max_overlap_ratio = health.run_max_overlap_ratio.max(worst.0);
}
