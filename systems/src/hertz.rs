//! Hertz normal contact with damping (Hertz 1896), between particles and with walls.
use bevy_ecs::prelude::*;
use grainflow_components::{
    Materials, PairParams, Particles, RunHealth, VerletList, WallList, Walls,
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

/// Pair parameter lookup; a scene with one material uses [`OneMaterial`], so the hot loop
/// does no table gather.
trait PairTable: Sync {
    fn get(&self, a: u16, b: u16) -> &PairParams;
}

struct OneMaterial(PairParams);

impl PairTable for OneMaterial {
    #[inline(always)]
    fn get(&self, _: u16, _: u16) -> &PairParams {
        &self.0
    }
}

impl PairTable for Materials {
    #[inline(always)]
    fn get(&self, a: u16, b: u16) -> &PairParams {
        self.pair(a, b)
    }
}

/// Contact forces of this step: every particle sums its pair forces over its row of the
/// Verlet list (in list order, so the sum does not depend on threads), then its wall
/// forces. Also finds the largest overlap ratio for the monitor.
pub fn hertz_contact(
    mut particles: ResMut<Particles>,
    list: Res<VerletList>,
    materials: Res<Materials>,
    walls: Option<Res<Walls>>,
    wall_list: Option<Res<WallList>>,
    mut health: ResMut<RunHealth>,
) {
    let _span = tracing::info_span!("hertz_contact").entered();
    let walls = walls.as_deref().zip(wall_list.as_deref());
    let worst = if materials.list.len() == 1 {
        contact_kernel(
            &mut particles,
            &list,
            &OneMaterial(materials.pairs[0]),
            walls,
        )
    } else {
        contact_kernel(&mut particles, &list, &*materials, walls)
    };
    health.max_overlap_ratio = worst.0;
    health.max_overlap_particle = worst.1;
    health.run_max_overlap_ratio = health.run_max_overlap_ratio.max(worst.0);
}

/// Returns the largest overlap ratio and the id of its particle (smallest id on ties).
fn contact_kernel<T: PairTable>(
    particles: &mut Particles,
    list: &VerletList,
    table: &T,
    walls: Option<(&Walls, &WallList)>,
) -> (f64, u32) {
    let Particles {
        position,
        velocity,
        radius,
        inv_mass,
        material,
        force,
        id,
        ..
    } = particles;
    let [x, y, z] = &*position;
    let [vx, vy, vz] = &*velocity;
    let (r, inv_m, mat, id) = (&*radius, &*inv_mass, &*material, &*id);
    let (start, nbr) = (&list.start, &list.neighbours);
    let [fx, fy, fz] = force;
    (
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
                // Largest overlap of this row; over both rows of a pair, max(delta/r_i,
                // delta/r_j) = delta / min(r_i, r_j).
                let mut deepest = 0.0f64;
                for &j in &nbr[start[i] as usize..start[i + 1] as usize] {
                    let j = j as usize;
                    let (dx, dy, dz) = (xi - x[j], yi - y[j], zi - z[j]);
                    let d2 = dx * dx + dy * dy + dz * dz;
                    let rj = r[j];
                    let rs = ri + rj;
                    if d2 >= rs * rs {
                        continue;
                    }
                    let d = d2.sqrt();
                    // One division for both 1/d and 1/(r_i + r_j).
                    let q = 1.0 / (d * rs);
                    let inv_d = q * rs;
                    let (nx, ny, nz) = (dx * inv_d, dy * inv_d, dz * inv_d);
                    let delta = rs - d;
                    let delta_dot = -((vxi - vx[j]) * nx + (vyi - vy[j]) * ny + (vzi - vz[j]) * nz);
                    let p = table.get(mi, mat[j]);
                    let f = hertz_normal_force(
                        p,
                        ri * rj * (q * d),
                        inv_mi + inv_m[j],
                        delta,
                        delta_dot,
                    );
                    sx += f * nx;
                    sy += f * ny;
                    sz += f * nz;
                    deepest = deepest.max(delta);
                }
                if let Some((walls, wl)) = walls {
                    for &w in &wl.walls[wl.start[i] as usize..wl.start[i + 1] as usize] {
                        let wall = &walls.list[w as usize];
                        let (dist, n) = wall_distance(&wall.shape, [xi, yi, zi]);
                        if dist >= ri {
                            continue;
                        }
                        let delta = ri - dist;
                        let delta_dot = -(vxi * n[0] + vyi * n[1] + vzi * n[2]);
                        let f = hertz_normal_force(
                            table.get(wall.material, mi),
                            ri,
                            inv_mi,
                            delta,
                            delta_dot,
                        );
                        sx += f * n[0];
                        sy += f * n[1];
                        sz += f * n[2];
                        deepest = deepest.max(delta);
                    }
                }
                fx[k] = sx;
                fy[k] = sy;
                fz[k] = sz;
                if deepest > 0.0 {
                    let ratio = deepest / ri;
                    if ratio > worst.0 || (ratio == worst.0 && id[i] < worst.1) {
                        worst = (ratio, id[i]);
                    }
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
        )
}
