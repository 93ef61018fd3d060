//! Hertz normal contact with damping (Hertz 1896), between particles and with walls.
//!
//! The pair loop runs four neighbours at a time in `wide::f64x4` lanes (gathered from the
//! structure-of-arrays columns), with no branch on contact: lanes out of contact are
//! masked. Each particle sums its own force in a fixed order (lane by lane, then
//! lanes 0+1+2+3), so results do not depend on the thread count.
use std::ops::{Add, Div, Mul, Sub};

use bevy_ecs::prelude::*;
use grainflow_components::{
    Materials, PairParams, Particles, RunHealth, VerletList, WallList, Walls,
};
use rayon::prelude::*;
use wide::{f64x4, CmpGt, CmpLt};

use crate::walls::wall_distance;
use crate::CHUNK;

/// The arithmetic of the contact formulas, for scalars and for SIMD lanes.
pub trait Real:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self>
{
    fn sqrt(self) -> Self;
    fn splat(x: f64) -> Self;
}

impl Real for f64 {
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn splat(x: f64) -> Self {
        x
    }
}

impl Real for f64x4 {
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64x4::sqrt(self)
    }
    #[inline(always)]
    fn splat(x: f64) -> Self {
        f64x4::splat(x)
    }
}

/// Normal damping law of a scene (all pairs share one: mixing laws is rejected at load,
/// so the kernel is compiled once per law and has no branch on it).
pub trait NormalDamping: Sync {
    /// Damping force for the pair's `coefficient`, elastic factor (4/3) E*
    /// `hertz_factor`, sqrt(R* delta) `sqrt_rd`, 1/m* `inv_mass_sum`, approach speed
    /// `delta_dot`.
    fn damping<T: Real>(
        coefficient: T,
        hertz_factor: T,
        sqrt_rd: T,
        inv_mass_sum: T,
        delta_dot: T,
    ) -> T;
    /// The pair's damping coefficient for this law.
    fn coefficient(p: &PairParams) -> f64;
}

/// F_d = d_n delta_dot with a constant d_n (seed slide "Models for DEM").
pub struct ConstantDamping;

impl NormalDamping for ConstantDamping {
    #[inline(always)]
    fn damping<T: Real>(d_n: T, _: T, _: T, _: T, delta_dot: T) -> T {
        d_n * delta_dot
    }
    fn coefficient(p: &PairParams) -> f64 {
        p.damping_constant
    }
}

/// F_d = -2 sqrt(5/6) beta sqrt(S_n m*) v_n with S_n = 2 E* sqrt(R* delta) =
/// (3/2) hertz_factor sqrt(R* delta) and beta = ln e / sqrt(ln^2 e + pi^2) (Tsuji et al.
/// 1992 form, as in LIGGGHTS and EDEM); with the force not clipped at zero it gives the
/// coefficient of restitution e at any impact speed.
pub struct RestitutionDamping;

impl NormalDamping for RestitutionDamping {
    #[inline(always)]
    fn damping<T: Real>(
        factor: T,
        hertz_factor: T,
        sqrt_rd: T,
        inv_mass_sum: T,
        delta_dot: T,
    ) -> T {
        factor * (T::splat(1.5) * hertz_factor * sqrt_rd / inv_mass_sum).sqrt() * delta_dot
    }
    fn coefficient(p: &PairParams) -> f64 {
        p.restitution_factor
    }
}

/// Normal force (positive = repulsive) of a Hertz contact with overlap `delta` and
/// approach speed `delta_dot`, seed slide "Models for DEM" (Hertz 1896):
///
///   F = c_n delta^(3/2) + damping,  c_n = (4/3) E* sqrt(R*)
///
/// `hertz_factor` = (4/3) E*, `inv_mass_sum` = 1/m_i + 1/m_j = 1/m*.
#[inline(always)]
pub fn hertz_normal_force<T: Real, D: NormalDamping>(
    hertz_factor: T,
    damping: T,
    r_eff: T,
    inv_mass_sum: T,
    delta: T,
    delta_dot: T,
) -> T {
    let sqrt_rd = (r_eff * delta).sqrt();
    hertz_factor * sqrt_rd * delta
        + D::damping(damping, hertz_factor, sqrt_rd, inv_mass_sum, delta_dot)
}

/// Pair parameter lookup; a scene with one material uses [`OneMaterial`], so the hot loop
/// does no table gather.
trait PairTable: Sync {
    fn get(&self, a: u16, b: u16) -> &PairParams;
    /// (4/3) E* and the damping coefficient of particle material `a` with the particles
    /// `js`, as lanes.
    #[inline(always)]
    fn lanes<D: NormalDamping>(&self, a: u16, mat: &[u16], js: &[usize; 4]) -> (f64x4, f64x4) {
        let p = js.map(|j| self.get(a, mat[j]));
        (
            f64x4::new(p.map(|p| p.hertz_factor)),
            f64x4::new(p.map(D::coefficient)),
        )
    }
}

struct OneMaterial(PairParams);

impl PairTable for OneMaterial {
    #[inline(always)]
    fn get(&self, _: u16, _: u16) -> &PairParams {
        &self.0
    }
    #[inline(always)]
    fn lanes<D: NormalDamping>(&self, _: u16, _: &[u16], _: &[usize; 4]) -> (f64x4, f64x4) {
        (
            f64x4::splat(self.0.hertz_factor),
            f64x4::splat(D::coefficient(&self.0)),
        )
    }
}

impl PairTable for Materials {
    #[inline(always)]
    fn get(&self, a: u16, b: u16) -> &PairParams {
        self.pair(a, b)
    }
}

/// Contact forces of this step: every particle sums its pair forces over its row of the
/// Verlet list, then its wall forces. Also finds the largest overlap ratio for the monitor.
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
    let restitution = materials.pairs.iter().any(|p| p.restitution_factor > 0.0);
    let p = &mut *particles;
    let one = OneMaterial(materials.pairs[0]);
    let worst = match (materials.list.len() == 1, restitution) {
        (true, false) => contact_kernel::<_, ConstantDamping>(p, &list, &one, walls),
        (true, true) => contact_kernel::<_, RestitutionDamping>(p, &list, &one, walls),
        (false, false) => contact_kernel::<_, ConstantDamping>(p, &list, &*materials, walls),
        (false, true) => contact_kernel::<_, RestitutionDamping>(p, &list, &*materials, walls),
    };
    health.max_overlap_ratio = worst.0;
    health.max_overlap_particle = worst.1;
    health.run_max_overlap_ratio = health.run_max_overlap_ratio.max(worst.0);
}

/// Gather `col[js[0..4]]` into lanes.
#[inline(always)]
fn gather(col: &[f64], js: &[usize; 4]) -> f64x4 {
    f64x4::new([col[js[0]], col[js[1]], col[js[2]], col[js[3]]])
}

/// Sum of the lanes in a fixed order.
#[inline(always)]
fn lane_sum(v: f64x4) -> f64 {
    let a = v.to_array();
    (a[0] + a[1]) + (a[2] + a[3])
}

/// Returns the largest overlap ratio and the id of its particle (smallest id on ties).
fn contact_kernel<T: PairTable, D: NormalDamping>(
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
    let zero = f64x4::ZERO;
    // Lane masks of a group of 1, 2, 3 or 4 neighbours.
    let row_mask = [1, 2, 3, 4].map(|n| {
        f64x4::new([0, 1, 2, 3].map(|l| if l < n { 1.0 } else { 0.0 })).cmp_gt(f64x4::splat(0.5))
    });
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
                let (xi, yi, zi, ri) = (
                    f64x4::splat(x[i]),
                    f64x4::splat(y[i]),
                    f64x4::splat(z[i]),
                    r[i],
                );
                let (vxi, vyi, vzi) = (
                    f64x4::splat(vx[i]),
                    f64x4::splat(vy[i]),
                    f64x4::splat(vz[i]),
                );
                let (inv_mi, mi) = (f64x4::splat(inv_m[i]), mat[i]);
                let (mut sx, mut sy, mut sz, mut deepest) = (zero, zero, zero, zero);
                for group in nbr[start[i] as usize..start[i + 1] as usize].chunks(4) {
                    // Lanes past the row's end point at particle i itself and are masked.
                    let mut js = [i; 4];
                    for (l, &j) in group.iter().enumerate() {
                        js[l] = j as usize;
                    }
                    let (hf, damp) = table.lanes::<D>(mi, mat, &js);
                    let rj = gather(r, &js);
                    let (dx, dy, dz) = (
                        xi - gather(x, &js),
                        yi - gather(y, &js),
                        zi - gather(z, &js),
                    );
                    let d2 = dx * dx + dy * dy + dz * dz;
                    let ri4 = f64x4::splat(ri);
                    let rs = ri4 + rj;
                    let touching = d2.cmp_lt(rs * rs) & row_mask[group.len() - 1];
                    if touching.none() {
                        continue;
                    }
                    let d = d2.sqrt();
                    // One division for both 1/d and 1/(r_i + r_j); zero in masked lanes, whose
                    // d may be zero (padding), so that no NaN reaches the sums.
                    let q = touching.blend(f64x4::ONE / (d * rs), zero);
                    let inv_d = q * rs;
                    let (nx, ny, nz) = (dx * inv_d, dy * inv_d, dz * inv_d);
                    let delta = rs - d;
                    let delta_dot = zero
                        - ((vxi - gather(vx, &js)) * nx
                            + (vyi - gather(vy, &js)) * ny
                            + (vzi - gather(vz, &js)) * nz);
                    let r_eff = ri4 * rj * (q * d);
                    let inv_mass_sum = inv_mi + gather(inv_m, &js);
                    let f = hertz_normal_force::<f64x4, D>(
                        hf,
                        damp,
                        r_eff,
                        inv_mass_sum,
                        delta,
                        delta_dot,
                    );
                    let f = touching.blend(f, zero);
                    sx += f * nx;
                    sy += f * ny;
                    sz += f * nz;
                    deepest = deepest.max(touching.blend(delta, zero));
                }
                let (mut sx, mut sy, mut sz) = (lane_sum(sx), lane_sum(sy), lane_sum(sz));
                // Over both rows of a pair, max(delta/r_i, delta/r_j) = delta/min(r_i, r_j).
                let mut deepest = deepest.to_array().into_iter().fold(0.0, f64::max);
                if let Some((walls, wl)) = walls {
                    let (xi, yi, zi) = (x[i], y[i], z[i]);
                    for &w in &wl.walls[wl.start[i] as usize..wl.start[i + 1] as usize] {
                        let wall = &walls.list[w as usize];
                        let (dist, n) = wall_distance(&wall.shape, [xi, yi, zi]);
                        if dist >= ri {
                            continue;
                        }
                        let delta = ri - dist;
                        let delta_dot = -(vx[i] * n[0] + vy[i] * n[1] + vz[i] * n[2]);
                        let p = table.get(wall.material, mi);
                        let f = hertz_normal_force::<f64, D>(
                            p.hertz_factor,
                            D::coefficient(p),
                            ri,
                            inv_m[i],
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
