//! Hertz normal contact with damping (Hertz 1896), between particles and with walls.
//!
//! The pair pass runs four pairs at a time in `wide::f64x4` lanes, with no branch on
//! contact: lanes out of contact are masked.
use std::ops::{Add, Div, Mul, Sub};

use bevy_ecs::prelude::*;
use grainflow_components::{
    Materials, PairParams, Particles, RunHealth, VerletList, WallList, Walls,
};
use rayon::prelude::*;
use wide::{f64x4, CmpLt};

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
    /// (4/3) E* and the damping coefficient of the particle pairs (`is`, `js`), as lanes.
    #[inline(always)]
    fn lanes<D: NormalDamping>(
        &self,
        is: &[usize; 4],
        js: &[usize; 4],
        mat: &[u16],
    ) -> (f64x4, f64x4) {
        let p = [0, 1, 2, 3].map(|l| self.get(mat[is[l]], mat[js[l]]));
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
    fn lanes<D: NormalDamping>(&self, _: &[usize; 4], _: &[usize; 4], _: &[u16]) -> (f64x4, f64x4) {
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

/// Contact forces of this step, in two passes over the half Verlet list:
/// 1. every listed pair once: the Hertz force magnitude over the distance, s_k = F_k / d_k
///    (zero when apart), four pairs per `f64x4`, with no branch on contact;
/// 2. every particle sums s_k (x_i - x_other) over its pairs (its own row, then the pairs
///    it is partner in, in list order) and adds its wall forces.
///
/// Each pair force is computed once and its two halves are exact negatives; each particle
/// sums in a fixed order, so the result does not depend on the thread count. Also finds
/// the largest overlap ratio for the monitor.
pub fn hertz_contact(
    mut pair_scale: Local<Vec<f64>>,
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
    let p = &*particles;
    pair_scale.resize(list.pairs(), 0.0);
    let one = OneMaterial(materials.pairs[0]);
    let s = &mut pair_scale[..];
    let span = tracing::info_span!("pair_forces").entered();
    let worst_pair = match (materials.list.len() == 1, restitution) {
        (true, false) => pair_forces::<_, ConstantDamping>(p, &list, &one, s),
        (true, true) => pair_forces::<_, RestitutionDamping>(p, &list, &one, s),
        (false, false) => pair_forces::<_, ConstantDamping>(p, &list, &*materials, s),
        (false, true) => pair_forces::<_, RestitutionDamping>(p, &list, &*materials, s),
    };
    drop(span);
    let _span2 = tracing::info_span!("sum_forces").entered();
    let worst_wall = match (materials.list.len() == 1, restitution) {
        (true, false) => {
            sum_forces::<_, ConstantDamping>(&mut particles, &list, &pair_scale, &one, walls)
        }
        (true, true) => {
            sum_forces::<_, RestitutionDamping>(&mut particles, &list, &pair_scale, &one, walls)
        }
        (false, false) => {
            sum_forces::<_, ConstantDamping>(&mut particles, &list, &pair_scale, &*materials, walls)
        }
        (false, true) => sum_forces::<_, RestitutionDamping>(
            &mut particles,
            &list,
            &pair_scale,
            &*materials,
            walls,
        ),
    };
    let worst = deeper(worst_pair, worst_wall);
    health.max_overlap_ratio = worst.0;
    health.max_overlap_particle = worst.1;
    health.run_max_overlap_ratio = health.run_max_overlap_ratio.max(worst.0);
}

/// The deeper of two (overlap ratio, particle id) records; the smaller id on ties.
#[inline(always)]
fn deeper(a: (f64, u32), b: (f64, u32)) -> (f64, u32) {
    if b.0 > a.0 || (b.0 == a.0 && b.1 < a.1) {
        b
    } else {
        a
    }
}

/// Gather `col[js[0..4]]` into lanes.
#[inline(always)]
fn gather(col: &[f64], js: &[usize; 4]) -> f64x4 {
    f64x4::new([col[js[0]], col[js[1]], col[js[2]], col[js[3]]])
}

/// Pairs per parallel work item of the pair pass.
const PAIR_CHUNK: usize = 4 * CHUNK;

/// Pass 1: s_k = F_k / d_k for every pair (zero when apart). Returns the largest overlap
/// over the smaller radius, with the smaller id of its pair.
fn pair_forces<T: PairTable, D: NormalDamping>(
    p: &Particles,
    list: &VerletList,
    table: &T,
    scale: &mut [f64],
) -> (f64, u32) {
    let [x, y, z] = &p.position;
    let [vx, vy, vz] = &p.velocity;
    let (r, inv_m, mat, id) = (&p.radius, &p.inv_mass, &p.material, &p.id);
    let (owner, partner) = (&list.owner, &list.neighbours);
    let zero = f64x4::ZERO;
    scale
        .par_chunks_mut(PAIR_CHUNK)
        .enumerate()
        .map(|(c, out)| {
            let base = c * PAIR_CHUNK;
            let mut worst = (0.0f64, u32::MAX);
            for (g, out) in out.chunks_mut(4).enumerate() {
                let k0 = base + 4 * g;
                let lanes = out.len();
                // Lanes past the end repeat the last pair and are dropped.
                let is = [0, 1, 2, 3].map(|l| owner[k0 + l.min(lanes - 1)] as usize);
                let js = [0, 1, 2, 3].map(|l| partner[k0 + l.min(lanes - 1)] as usize);
                let (ri, rj) = (gather(r, &is), gather(r, &js));
                let dx = gather(x, &is) - gather(x, &js);
                let dy = gather(y, &is) - gather(y, &js);
                let dz = gather(z, &is) - gather(z, &js);
                let d2 = dx * dx + dy * dy + dz * dz;
                let rs = ri + rj;
                let touching = d2.cmp_lt(rs * rs);
                if touching.none() {
                    out.fill(0.0);
                    continue;
                }
                let d = d2.sqrt();
                // One division for both 1/d and 1/(r_i + r_j); zero in lanes apart.
                let q = touching.blend(f64x4::ONE / (d * rs), zero);
                let inv_d = q * rs;
                let delta = rs - d;
                let dvx = gather(vx, &is) - gather(vx, &js);
                let dvy = gather(vy, &is) - gather(vy, &js);
                let dvz = gather(vz, &is) - gather(vz, &js);
                let delta_dot = zero - (dvx * dx + dvy * dy + dvz * dz) * inv_d;
                let r_eff = ri * rj * (q * d);
                let inv_mass_sum = gather(inv_m, &is) + gather(inv_m, &js);
                let (hf, damp) = table.lanes::<D>(&is, &js, mat);
                let f =
                    hertz_normal_force::<f64x4, D>(hf, damp, r_eff, inv_mass_sum, delta, delta_dot);
                let s = touching.blend(f * inv_d, zero).to_array();
                out.copy_from_slice(&s[..lanes]);
                let ratio = touching.blend(delta / ri.min(rj), zero).to_array();
                for l in 0..lanes {
                    if ratio[l] > 0.0 {
                        worst = deeper(worst, (ratio[l], id[is[l]].min(id[js[l]])));
                    }
                }
            }
            worst
        })
        .reduce(|| (0.0, u32::MAX), deeper)
}

/// Pass 2: every particle's force from its pairs and walls. Returns the deepest wall
/// overlap ratio and its particle.
fn sum_forces<T: PairTable, D: NormalDamping>(
    particles: &mut Particles,
    list: &VerletList,
    scale: &[f64],
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
                let (xi, yi, zi) = (x[i], y[i], z[i]);
                let (mut sx, mut sy, mut sz) = (0.0, 0.0, 0.0);
                for p in list.start[i] as usize..list.start[i + 1] as usize {
                    let (j, s) = (list.neighbours[p] as usize, scale[p]);
                    sx += s * (xi - x[j]);
                    sy += s * (yi - y[j]);
                    sz += s * (zi - z[j]);
                }
                for &p in
                    &list.rev_pairs[list.rev_start[i] as usize..list.rev_start[i + 1] as usize]
                {
                    let (j, s) = (list.owner[p as usize] as usize, scale[p as usize]);
                    sx += s * (xi - x[j]);
                    sy += s * (yi - y[j]);
                    sz += s * (zi - z[j]);
                }
                if let Some((walls, wl)) = walls {
                    let ri = r[i];
                    let mut deepest = 0.0f64;
                    for &w in &wl.walls[wl.start[i] as usize..wl.start[i + 1] as usize] {
                        let wall = &walls.list[w as usize];
                        let (dist, n) = wall_distance(&wall.shape, [xi, yi, zi]);
                        if dist >= ri {
                            continue;
                        }
                        let delta = ri - dist;
                        let delta_dot = -(vx[i] * n[0] + vy[i] * n[1] + vz[i] * n[2]);
                        let p = table.get(wall.material, mat[i]);
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
                    if deepest > 0.0 {
                        worst = deeper(worst, (deepest / ri, id[i]));
                    }
                }
                fx[k] = sx;
                fy[k] = sy;
                fz[k] = sz;
            }
            worst
        })
        .reduce(|| (0.0, u32::MAX), deeper)
}
