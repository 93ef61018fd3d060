//! Hertz normal contact with damping (Hertz 1896), between particles and with walls.
//!
//! The pair pass runs four pairs at a time in `wide::f64x4` lanes, with no branch on
//! contact: lanes out of contact are masked.
use bevy_ecs::prelude::*;
use grainflow_components::{
    Materials, PairParams, Particles, RunHealth, VerletList, WallList, Walls,
};
use rayon::prelude::*;
use wide::{f64x4, CmpLt};

use crate::real::{gather, group_masks, lane_sum, store_lanes, Real};
use crate::walls::wall_contact;
use crate::{row_chunks, CHUNK};

/// Normal damping law of a scene (all pairs share one: mixing laws is rejected at load,
/// so the kernel is compiled once per law and has no branch on it).
pub trait NormalDamping: Sync {
    /// Damping force for the pair's `coefficient`, elastic factor (4/3) E*
    /// `hertz_factor`, contact radius `sqrt_rd` (sqrt(R* delta) for Hertz), 1/m*
    /// `inv_mass_sum`, approach speed `delta_dot`.
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

/// Normal force (positive = repulsive) of a Hertz contact with overlap `delta`, contact
/// radius `a` = sqrt(R* delta) and approach speed `delta_dot`, seed slide "Models for
/// DEM" (Hertz 1896):
///
///   F = c_n delta^(3/2) + damping,  c_n = (4/3) E* sqrt(R*),  so F = (4/3) E* a delta + ...
///
/// `hertz_factor` = (4/3) E*, `inv_mass_sum` = 1/m_i + 1/m_j = 1/m*.
#[inline(always)]
pub fn hertz_normal_force<T: Real, D: NormalDamping>(
    hertz_factor: T,
    damping: T,
    a: T,
    inv_mass_sum: T,
    delta: T,
    delta_dot: T,
) -> T {
    hertz_factor * a * delta + D::damping(damping, hertz_factor, a, inv_mass_sum, delta_dot)
}

/// Pair parameter lookup; a scene with one material uses [`OneMaterial`], so the hot loop
/// does no table gather.
trait PairTable: Sync {
    fn get(&self, a: u16, b: u16) -> &PairParams;
    /// (4/3) E* and the damping coefficient of material `a` with the particles `js`, as
    /// lanes.
    #[inline(always)]
    fn lanes<D: NormalDamping>(&self, a: u16, js: &[usize; 4], mat: &[u16]) -> (f64x4, f64x4) {
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
    fn lanes<D: NormalDamping>(&self, _: u16, _: &[usize; 4], _: &[u16]) -> (f64x4, f64x4) {
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
/// 1. every particle i, for the pairs of its own row (partners j > i), four at a time in
///    `f64x4` lanes with no branch on contact: the Hertz force magnitude over the
///    distance, s_k = F_k / d_k (zero when apart), stored per pair, and the row's forces
///    on i summed;
/// 2. every particle adds s_k (x_i - x_owner) over the pairs it is partner in (the other
///    half of each pair force, an exact negative), then its wall forces.
///
/// Each pair force is computed once; each particle sums in a fixed order (own row, then
/// partner pairs in list order, then walls), so the result does not depend on the thread
/// count. Also finds the largest overlap ratio for the monitor.
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
    pair_scale.resize(list.pairs(), 0.0);
    let one = OneMaterial(materials.pairs[0]);
    let (p, s) = (&mut *particles, &mut pair_scale[..]);
    let worst = match (materials.list.len() == 1, restitution) {
        (true, false) => both_passes::<_, ConstantDamping>(p, &list, &one, s, walls),
        (true, true) => both_passes::<_, RestitutionDamping>(p, &list, &one, s, walls),
        (false, false) => both_passes::<_, ConstantDamping>(p, &list, &*materials, s, walls),
        (false, true) => both_passes::<_, RestitutionDamping>(p, &list, &*materials, s, walls),
    };
    health.max_overlap_ratio = worst.0;
    health.max_overlap_particle = worst.1;
    health.run_max_overlap_ratio = health.run_max_overlap_ratio.max(worst.0);
}

/// The two passes for one material table and damping law.
fn both_passes<T: PairTable, D: NormalDamping>(
    particles: &mut Particles,
    list: &VerletList,
    table: &T,
    scale: &mut [f64],
    walls: Option<(&Walls, &WallList)>,
) -> (f64, u32) {
    let rows = {
        let _span = tracing::info_span!("row_forces").entered();
        row_forces::<T, D>(particles, list, table, scale)
    };
    let _span = tracing::info_span!("partner_forces").entered();
    deeper(
        rows,
        partner_and_wall_forces::<T, D>(particles, list, scale, table, walls),
    )
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

/// Pass 1: the pairs of each particle's own row. Writes the row sums into the force
/// columns and s_k for every pair; returns the largest overlap over the smaller radius of
/// its pair, with the id of the pair's row owner.
fn row_forces<T: PairTable, D: NormalDamping>(
    particles: &mut Particles,
    list: &VerletList,
    table: &T,
    scale: &mut [f64],
) -> (f64, u32) {
    let n = particles.len();
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
    let row_mask = group_masks();
    (
        fx.par_chunks_mut(CHUNK),
        fy.par_chunks_mut(CHUNK),
        fz.par_chunks_mut(CHUNK),
        row_chunks(scale, start, n, 1),
    )
        .into_par_iter()
        .enumerate()
        .map(|(c, (fx, fy, fz, scale))| {
            // Columns cut to the particle count: a lane index checked once against `n`
            // needs no bounds check in the gathers that follow.
            let (x, y, z, r) = (&x[..n], &y[..n], &z[..n], &r[..n]);
            let (vx, vy, vz, inv_m, mat) = (&vx[..n], &vy[..n], &vz[..n], &inv_m[..n], &mat[..n]);
            let base = c * CHUNK;
            let pair_base = start[base] as usize;
            let mut worst = (0.0f64, u32::MAX);
            for k in 0..fx.len() {
                let i = base + k;
                let row = start[i] as usize..start[i + 1] as usize;
                if row.is_empty() {
                    (fx[k], fy[k], fz[k]) = (0.0, 0.0, 0.0);
                    continue;
                }
                let (xi, yi, zi) = (f64x4::splat(x[i]), f64x4::splat(y[i]), f64x4::splat(z[i]));
                let (vxi, vyi, vzi) = (
                    f64x4::splat(vx[i]),
                    f64x4::splat(vy[i]),
                    f64x4::splat(vz[i]),
                );
                let (ri, inv_mi) = (f64x4::splat(r[i]), f64x4::splat(inv_m[i]));
                let (mut sx, mut sy, mut sz, mut deepest) = (zero, zero, zero, zero);
                for (g, group) in nbr[row.clone()].chunks(4).enumerate() {
                    let first = row.start + 4 * g;
                    // Lanes past the row's end repeat its last partner and are masked.
                    let js = [0, 1, 2, 3].map(|l| group[l.min(group.len() - 1)] as usize);
                    assert!(js.iter().all(|&j| j < n), "listed pairs index particles");
                    let rj = gather(r, &js);
                    let (dx, dy, dz) = (
                        xi - gather(x, &js),
                        yi - gather(y, &js),
                        zi - gather(z, &js),
                    );
                    let d2 = dx * dx + dy * dy + dz * dz;
                    let rs = ri + rj;
                    let touching = d2.cmp_lt(rs * rs) & row_mask[group.len() - 1];
                    let out = &mut scale[first - pair_base..first - pair_base + group.len()];
                    if touching.none() {
                        store_lanes(out, zero);
                        continue;
                    }
                    let d = d2.sqrt();
                    // One division for both 1/d and 1/(r_i + r_j); zero in lanes apart.
                    let q = touching.blend(f64x4::ONE / (d * rs), zero);
                    let inv_d = q * rs;
                    let delta = rs - d;
                    let delta_dot = zero
                        - ((vxi - gather(vx, &js)) * dx
                            + (vyi - gather(vy, &js)) * dy
                            + (vzi - gather(vz, &js)) * dz)
                            * inv_d;
                    let r_eff = ri * rj * (q * d);
                    let (hf, damp) = table.lanes::<D>(mat[i], &js, mat);
                    let f = hertz_normal_force::<f64x4, D>(
                        hf,
                        damp,
                        (r_eff * delta).sqrt(),
                        inv_mi + gather(inv_m, &js),
                        delta,
                        delta_dot,
                    );
                    let s = touching.blend(f * inv_d, zero);
                    sx += s * dx;
                    sy += s * dy;
                    sz += s * dz;
                    store_lanes(out, s);
                    deepest = deepest.max(touching.blend(delta / ri.min(rj), zero));
                }
                let ratio = deepest.to_array().into_iter().fold(0.0, f64::max);
                if ratio > 0.0 {
                    worst = deeper(worst, (ratio, id[i]));
                }
                fx[k] = lane_sum(sx);
                fy[k] = lane_sum(sy);
                fz[k] = lane_sum(sz);
            }
            worst
        })
        .reduce(|| (0.0, u32::MAX), deeper)
}

/// Pass 2: every particle adds the other half of the pairs it is partner in, then its
/// wall forces. Returns the deepest wall overlap ratio and its particle.
fn partner_and_wall_forces<T: PairTable, D: NormalDamping>(
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
            // A chunk of free particles (no partner pairs, no wall candidates: a falling
            // cloud) keeps its row sums untouched.
            let end = base + fx.len();
            let partnered = list.rev_start[base] != list.rev_start[end];
            if !partnered && walls.is_none_or(|(_, wl)| wl.start[base] == wl.start[end]) {
                return worst;
            }
            for k in 0..fx.len() {
                let i = base + k;
                let (xi, yi, zi) = (x[i], y[i], z[i]);
                let (mut sx, mut sy, mut sz) = (fx[k], fy[k], fz[k]);
                let rev = list.rev_start[i] as usize..list.rev_start[i + 1] as usize;
                for (&p, &j) in list.rev_pairs[rev.clone()].iter().zip(&list.rev_owner[rev]) {
                    let (j, s) = (j as usize, scale[p as usize]);
                    sx += s * (xi - x[j]);
                    sy += s * (yi - y[j]);
                    sz += s * (zi - z[j]);
                }
                if let Some((walls, wl)) = walls {
                    let ri = r[i];
                    let mut deepest = 0.0f64;
                    for &w in &wl.walls[wl.start[i] as usize..wl.start[i + 1] as usize] {
                        let wall = &walls.list[w as usize];
                        let Some((dist, n)) = wall_contact(&wall.shape, [xi, yi, zi], ri) else {
                            continue;
                        };
                        let delta = ri - dist;
                        let delta_dot = -(vx[i] * n[0] + vy[i] * n[1] + vz[i] * n[2]);
                        let p = table.get(wall.material, mat[i]);
                        let f = hertz_normal_force::<f64, D>(
                            p.hertz_factor,
                            D::coefficient(p),
                            (ri * delta).sqrt(),
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
