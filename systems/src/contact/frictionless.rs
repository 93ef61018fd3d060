//! The frictionless instance of the contact pipeline: Hertz normal contact with damping
//! (Hertz 1896, `laws/hertz.rs`) between sphere pairs, a central force with no
//! per-contact state, and the shared wall stage (`wall_pass`) with the laws of no history.
//!
//! The pair pass runs four pairs at a time in `wide::f64x4` lanes, with no branch on
//! contact: lanes out of contact are masked. Dense chunks of rows take the pairs of one
//! particle at a time; sparse chunks (a falling cloud) take them in list order, whatever
//! row they belong to.
use bevy_ecs::prelude::*;
use grainflow_components::{
    Materials, PairParams, Particles, RunHealth, SimClock, VerletList, WallList, Walls,
};
use rayon::prelude::*;
use wide::{f64x4, CmpLt};

use super::deeper;
use super::laws::hertz::{hertz_normal_force, ConstantDamping, NormalDamping, RestitutionDamping};
use super::pipeline::Laws;
use super::wall_pass::{add_wall_results, wall_contacts, wall_entry_chunks, WallResult};
use crate::real::{gather, group_masks, lane_sum, store_lanes};
use crate::team::{PartTimes, StaticSplit};
use crate::{row_chunks, Rows, CHUNK};

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
    /// The same for pairs of four owners `is` with four partners `js`.
    #[inline(always)]
    fn pair_lanes<D: NormalDamping>(
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
    fn lanes<D: NormalDamping>(&self, _: u16, _: &[usize; 4], _: &[u16]) -> (f64x4, f64x4) {
        self.pair_lanes::<D>(&[0; 4], &[0; 4], &[])
    }
    #[inline(always)]
    fn pair_lanes<D: NormalDamping>(
        &self,
        _: &[usize; 4],
        _: &[usize; 4],
        _: &[u16],
    ) -> (f64x4, f64x4) {
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

/// What [`hertz_contact`] keeps from step to step: s_k of every pair, the wall stage's
/// results, and the part times
/// of its two passes ([`StaticSplit::timed_map_reduce`]).
#[derive(Default)]
pub struct KeptFromStep {
    pair_scale: Vec<f64>,
    wall_results: Vec<WallResult>,
    times: [PartTimes; 2],
}

/// Contact forces of this step, in two passes over the half Verlet list:
/// 1. every particle i, for the pairs of its own row (partners j > i), four at a time in
///    `f64x4` lanes with no branch on contact: the Hertz force magnitude over the
///    distance, s_k = F_k / d_k (zero when apart), stored per pair, and the row's forces
///    on i summed;
/// 2. every particle adds s_k (x_i - x_owner) over the pairs it is partner in (the other
///    half of each pair force, an exact negative), then its wall forces.
///
/// Chunks with few pairs per particle run both passes in pair order instead of particle
/// by particle (see `SPARSE_PAIRS_PER_PARTICLE`); the sums keep a fixed order.
///
/// Each pair force is computed once; each particle sums in a fixed order (own row, then
/// partner pairs in list order, then walls), so the result does not depend on the thread
/// count. Also finds the largest overlap ratio for the monitor.
pub fn hertz_contact(
    mut kept: Local<KeptFromStep>,
    mut particles: ResMut<Particles>,
    list: Res<VerletList>,
    materials: Res<Materials>,
    (walls, wall_list): (Option<Res<Walls>>, Option<Res<WallList>>),
    clock: Res<SimClock>,
    mut health: ResMut<RunHealth>,
) {
    let _span = tracing::info_span!("hertz_contact").entered();
    let walls = walls.as_deref().zip(wall_list.as_deref());
    let restitution = materials.pairs.iter().any(|p| p.restitution_factor > 0.0);
    let KeptFromStep {
        pair_scale,
        wall_results,
        times,
    } = &mut *kept;
    pair_scale.resize(list.pairs(), 0.0);
    if let Some((_, wl)) = walls {
        wall_results.resize(wl.walls.len(), [0.0; 8]);
    }
    let one = OneMaterial(materials.pairs[0]);
    let m = &*materials;
    let (p, s, t) = (&mut *particles, &mut pair_scale[..], times);
    let w = (walls, &mut wall_results[..], clock.dt);
    let worst = match (materials.list.len() == 1, restitution) {
        (true, false) => both_passes::<_, ConstantDamping>(p, &list, &one, m, s, w, t),
        (true, true) => both_passes::<_, RestitutionDamping>(p, &list, &one, m, s, w, t),
        (false, false) => both_passes::<_, ConstantDamping>(p, &list, m, m, s, w, t),
        (false, true) => both_passes::<_, RestitutionDamping>(p, &list, m, m, s, w, t),
    };
    health.max_overlap_ratio = worst.0;
    health.max_overlap_particle = worst.1;
    health.run_max_overlap_ratio = health.run_max_overlap_ratio.max(worst.0);
}

/// The two passes for one material table and damping law; the walls (with the buffer of
/// their results and the step) go through the wall stage with the laws of `materials`.
fn both_passes<T: PairTable, D: NormalDamping>(
    particles: &mut Particles,
    list: &VerletList,
    table: &T,
    materials: &Materials,
    scale: &mut [f64],
    (walls, wall_results, dt): (Option<(&Walls, &WallList)>, &mut [WallResult], f64),
    [row_times, partner_times]: &mut [PartTimes; 2],
) -> (f64, u32) {
    let rows = {
        let _span = tracing::info_span!("row_forces").entered();
        row_forces::<T, D>(particles, list, table, scale, row_times)
    };
    let _span = tracing::info_span!("partner_forces").entered();
    let laws = walls.map(|_| Laws::new::<D>(materials, None, dt));
    let walls = walls
        .zip(laws.as_ref())
        .map(|((w, wl), laws)| (w, wl, laws));
    deeper(
        rows,
        partner_and_wall_forces::<D>(particles, list, scale, walls, wall_results, partner_times),
    )
}

/// A chunk whose rows hold fewer listed pairs than this per particle (a falling cloud, a
/// loose packing) runs the pair-ordered passes ([`flat_rows`], [`flat_partners`]): with
/// most rows empty or of one pair, a loop per particle costs more in mispredicted row
/// ends than the pairs cost. Denser chunks run the per-particle passes. The choice
/// depends on the list only, so the results do not depend on the thread count.
const SPARSE_PAIRS_PER_PARTICLE: usize = 2;

/// Whether a chunk of `particles` rows with `pairs` listed pairs is sparse.
#[inline(always)]
fn sparse(pairs: usize, particles: usize) -> bool {
    pairs < SPARSE_PAIRS_PER_PARTICLE * particles
}

/// s = F/d of four pairs (zero in lanes not `touching`) and their overlap over the
/// smaller radius, from the radii, the squared distance `d2`, the approach product
/// (v_i - v_j).(x_i - x_j) and 1/m_i + 1/m_j; (4/3) E* and the damping coefficient as
/// [`PairTable::lanes`] gives them.
#[inline(always)]
fn pair_scale<D: NormalDamping>(
    (hf, damp): (f64x4, f64x4),
    touching: f64x4,
    [ri, rj]: [f64x4; 2],
    d2: f64x4,
    approach: f64x4,
    inv_mass_sum: f64x4,
) -> (f64x4, f64x4) {
    let zero = f64x4::ZERO;
    let rs = ri + rj;
    let d = d2.sqrt();
    // One division for both 1/d and 1/(r_i + r_j); zero in lanes apart.
    let q = touching.blend(f64x4::ONE / (d * rs), zero);
    let inv_d = q * rs;
    let delta = rs - d;
    let delta_dot = zero - approach * inv_d;
    let r_eff = ri * rj * (q * d);
    let f = hertz_normal_force::<f64x4, D>(
        hf,
        damp,
        (r_eff * delta).sqrt(),
        inv_mass_sum,
        delta,
        delta_dot,
    );
    (
        touching.blend(f * inv_d, zero),
        touching.blend(delta / ri.min(rj), zero),
    )
}

/// Pass 1: the pairs of each particle's own row. Writes the row sums into the force
/// columns and s_k for every pair; returns the largest overlap over the smaller radius of
/// its pair, with the id of the pair's row owner.
fn row_forces<T: PairTable, D: NormalDamping>(
    particles: &mut Particles,
    list: &VerletList,
    table: &T,
    scale: &mut [f64],
    times: &mut PartTimes,
) -> (f64, u32) {
    let n = particles.len();
    let mut force = std::mem::take(&mut particles.force);
    let cols = Rows::of(particles);
    let [fx, fy, fz] = &mut force;
    let worst = (
        fx.par_chunks_mut(CHUNK),
        fy.par_chunks_mut(CHUNK),
        fz.par_chunks_mut(CHUNK),
        row_chunks(scale, &list.start, n, 1),
    )
        .into_par_iter()
        .enumerate()
        .timed_map_reduce(
            times,
            |(c, (fx, fy, fz, scale))| {
                if sparse(scale.len(), fx.len()) {
                    flat_rows::<T, D>(&cols, list, table, c * CHUNK, [fx, fy, fz], scale)
                } else {
                    owner_rows::<T, D>(&cols, list, table, c * CHUNK, [fx, fy, fz], scale)
                }
            },
            || (0.0, u32::MAX),
            deeper,
        );
    particles.force = force;
    worst
}

/// Pass 1 over the rows `base..` of a chunk, one particle at a time: its pairs in lanes
/// beside the particle's own values, the row sum kept in lanes. Every group is computed,
/// in contact or not: in a dense chunk a branch skipping groups with no contact is
/// mispredicted often enough to cost more than it saves (3-4 % of the dense hopper
/// step, measured 2026-11-30).
fn owner_rows<T: PairTable, D: NormalDamping>(
    p: &Rows,
    list: &VerletList,
    table: &T,
    base: usize,
    [fx, fy, fz]: [&mut [f64]; 3],
    scale: &mut [f64],
) -> (f64, u32) {
    let p = &p.cut();
    let (start, nbr) = (&list.start[..], &list.neighbours[..]);
    let zero = f64x4::ZERO;
    let row_mask = group_masks();
    let pair_base = start[base] as usize;
    let mut worst = (0.0f64, u32::MAX);
    for k in 0..fx.len() {
        let i = base + k;
        let row = start[i] as usize..list.near_end[i] as usize;
        if row.is_empty() {
            (fx[k], fy[k], fz[k]) = (0.0, 0.0, 0.0);
            continue;
        }
        let (xi, yi, zi) = (
            f64x4::splat(p.position[0][i]),
            f64x4::splat(p.position[1][i]),
            f64x4::splat(p.position[2][i]),
        );
        let (vxi, vyi, vzi) = (
            f64x4::splat(p.velocity[0][i]),
            f64x4::splat(p.velocity[1][i]),
            f64x4::splat(p.velocity[2][i]),
        );
        let (ri, inv_mi) = (f64x4::splat(p.radius[i]), f64x4::splat(p.inv_mass[i]));
        let (mut sx, mut sy, mut sz, mut deepest) = (zero, zero, zero, zero);
        for (g, group) in nbr[row.clone()].chunks(4).enumerate() {
            let first = row.start + 4 * g;
            // Lanes past the row's end repeat its last partner and are masked.
            let js = [0, 1, 2, 3].map(|l| group[l.min(group.len() - 1)] as usize);
            assert!(js.iter().all(|&j| j < p.n), "listed pairs index particles");
            let rj = gather(p.radius, &js);
            let (dx, dy, dz) = (
                xi - gather(p.position[0], &js),
                yi - gather(p.position[1], &js),
                zi - gather(p.position[2], &js),
            );
            let d2 = dx * dx + dy * dy + dz * dz;
            let rs = ri + rj;
            let touching = d2.cmp_lt(rs * rs) & row_mask[group.len() - 1];
            let out = &mut scale[first - pair_base..first - pair_base + group.len()];
            let approach = (vxi - gather(p.velocity[0], &js)) * dx
                + (vyi - gather(p.velocity[1], &js)) * dy
                + (vzi - gather(p.velocity[2], &js)) * dz;
            let (s, ratio) = pair_scale::<D>(
                table.lanes::<D>(p.material[i], &js, p.material),
                touching,
                [ri, rj],
                d2,
                approach,
                inv_mi + gather(p.inv_mass, &js),
            );
            sx += s * dx;
            sy += s * dy;
            sz += s * dz;
            store_lanes(out, s);
            deepest = deepest.max(ratio);
        }
        let ratio = deepest.to_array().into_iter().fold(0.0, f64::max);
        if ratio > 0.0 {
            worst = deeper(worst, (ratio, p.id[i]));
        }
        fx[k] = lane_sum(sx);
        fy[k] = lane_sum(sy);
        fz[k] = lane_sum(sz);
    }
    worst
}

/// Pass 1 over the rows `base..` of a sparse chunk, in pair order: four pairs at a time
/// whatever rows they belong to, each pair force added to its owner's row sum in pair
/// order. Groups with no contact (most, in a sparse chunk) cost a distance test.
fn flat_rows<T: PairTable, D: NormalDamping>(
    p: &Rows,
    list: &VerletList,
    table: &T,
    base: usize,
    [fx, fy, fz]: [&mut [f64]; 3],
    scale: &mut [f64],
) -> (f64, u32) {
    let p = &p.cut();
    fx.fill(0.0);
    fy.fill(0.0);
    fz.fill(0.0);
    let pairs = list.start[base] as usize..list.start[base + fx.len()] as usize;
    let (owner, nbr) = (&list.owner[pairs.clone()], &list.neighbours[pairs]);
    let zero = f64x4::ZERO;
    let row_mask = group_masks();
    let mut worst = (0.0f64, u32::MAX);
    for (g, (own, group)) in owner.chunks(4).zip(nbr.chunks(4)).enumerate() {
        let m = group.len();
        // Lanes past the chunk's last pair repeat it and are masked.
        let is = [0, 1, 2, 3].map(|l| own[l.min(m - 1)] as usize);
        let js = [0, 1, 2, 3].map(|l| group[l.min(m - 1)] as usize);
        assert!(
            is.iter().chain(&js).all(|&k| k < p.n),
            "listed pairs index particles"
        );
        let (ri, rj) = (gather(p.radius, &is), gather(p.radius, &js));
        let (dx, dy, dz) = (
            gather(p.position[0], &is) - gather(p.position[0], &js),
            gather(p.position[1], &is) - gather(p.position[1], &js),
            gather(p.position[2], &is) - gather(p.position[2], &js),
        );
        let d2 = dx * dx + dy * dy + dz * dz;
        let rs = ri + rj;
        let touching = d2.cmp_lt(rs * rs) & row_mask[m - 1];
        let out = &mut scale[4 * g..4 * g + m];
        if touching.none() {
            store_lanes(out, zero);
            continue;
        }
        let approach = (gather(p.velocity[0], &is) - gather(p.velocity[0], &js)) * dx
            + (gather(p.velocity[1], &is) - gather(p.velocity[1], &js)) * dy
            + (gather(p.velocity[2], &is) - gather(p.velocity[2], &js)) * dz;
        let (s, ratio) = pair_scale::<D>(
            table.pair_lanes::<D>(&is, &js, p.material),
            touching,
            [ri, rj],
            d2,
            approach,
            gather(p.inv_mass, &is) + gather(p.inv_mass, &js),
        );
        store_lanes(out, s);
        let (ax, ay, az, ratio) = (
            (s * dx).to_array(),
            (s * dy).to_array(),
            (s * dz).to_array(),
            ratio.to_array(),
        );
        for l in 0..m {
            // Lanes out of contact add a zero: the sums do not change.
            let k = is[l] - base;
            fx[k] += ax[l];
            fy[k] += ay[l];
            fz[k] += az[l];
            if ratio[l] > 0.0 {
                worst = deeper(worst, (ratio[l], p.id[is[l]]));
            }
        }
    }
    worst
}

/// Pass 2: every particle adds the other half of the pairs it is partner in, then its
/// wall forces (the wall stage, [`wall_contacts`], run for the chunk's entries first).
/// Returns the deepest wall overlap ratio and its particle.
fn partner_and_wall_forces<D: NormalDamping>(
    particles: &mut Particles,
    list: &VerletList,
    scale: &[f64],
    walls: Option<(&Walls, &WallList, &Laws)>,
    wall_results: &mut [WallResult],
    times: &mut PartTimes,
) -> (f64, u32) {
    let n = particles.len();
    let mut force = std::mem::take(&mut particles.force);
    let cols = Rows::of(particles);
    let [fx, fy, fz] = &mut force;
    let out = wall_entry_chunks(walls.map(|(_, wl, _)| (wall_results, &wl.start[..])), n, 1);
    let worst = (
        fx.par_chunks_mut(CHUNK),
        fy.par_chunks_mut(CHUNK),
        fz.par_chunks_mut(CHUNK),
        out,
    )
        .into_par_iter()
        .enumerate()
        // `move`: the closure holds its own copy of the column slices, kept in registers.
        .timed_map_reduce(
            times,
            move |(c, (fx, fy, fz, out))| {
                let base = c * CHUNK;
                let end = base + fx.len();
                let rows = base..end;
                let partnered = (list.rev_start[end] - list.rev_start[base]) as usize;
                // The chunk's wall results, when it has wall entries.
                let walls = match (walls, out) {
                    (Some((walls, wl, laws)), Some(out)) if wl.start[base] != wl.start[end] => {
                        wall_contacts::<D>(laws, &cols, walls, wl, rows.clone(), &mut [], out);
                        Some((wl, &*out, wl.start[base] as usize))
                    }
                    _ => None,
                };
                let mut worst = (0.0f64, u32::MAX);
                let mut add_walls = |i: usize, f: &mut [f64; 3]| {
                    if let Some((wl, out, first)) = walls {
                        let deepest = add_wall_results(wl, out, first, i, f);
                        if deepest > 0.0 {
                            worst = deeper(worst, (deepest / cols.radius[i], cols.id[i]));
                        }
                    }
                };
                if sparse(partnered, fx.len()) {
                    flat_partners(&cols, list, scale, base, [&mut *fx, &mut *fy, &mut *fz]);
                    if let Some((wl, _, _)) = walls {
                        for i in rows.filter(|&i| wl.start[i] != wl.start[i + 1]) {
                            let k = i - base;
                            let mut f = [fx[k], fy[k], fz[k]];
                            add_walls(i, &mut f);
                            [fx[k], fy[k], fz[k]] = f;
                        }
                    }
                    return worst;
                }
                for i in rows {
                    let k = i - base;
                    let (xi, yi, zi) = (
                        cols.position[0][i],
                        cols.position[1][i],
                        cols.position[2][i],
                    );
                    let mut f = [fx[k], fy[k], fz[k]];
                    let rev = list.rev_start[i] as usize..list.rev_start[i + 1] as usize;
                    for (&p, &j) in list.rev_pairs[rev.clone()].iter().zip(&list.rev_owner[rev]) {
                        let (j, s) = (j as usize, scale[p as usize]);
                        f[0] += s * (xi - cols.position[0][j]);
                        f[1] += s * (yi - cols.position[1][j]);
                        f[2] += s * (zi - cols.position[2][j]);
                    }
                    add_walls(i, &mut f);
                    [fx[k], fy[k], fz[k]] = f;
                }
                worst
            },
            || (0.0, u32::MAX),
            deeper,
        );
    particles.force = force;
    worst
}

/// Pass 2's pair halves for the rows `base..` of a sparse chunk, in the order of the
/// reverse index (by particle, then by pair, as the per-particle loop): only the pairs in
/// contact (s != 0, few in a sparse chunk) are looked up and added.
fn flat_partners(
    p: &Rows,
    list: &VerletList,
    scale: &[f64],
    base: usize,
    [fx, fy, fz]: [&mut [f64]; 3],
) {
    let row_start = &list.rev_start[base..=base + fx.len()];
    let rev = row_start[0] as usize..row_start[fx.len()] as usize;
    for (e, &pair) in rev.clone().zip(&list.rev_pairs[rev]) {
        let s = scale[pair as usize];
        if s == 0.0 {
            continue;
        }
        // The particle whose reverse row holds entry e.
        let k = row_start.partition_point(|&r| r as usize <= e) - 1;
        let (i, j) = (base + k, list.rev_owner[e] as usize);
        fx[k] += s * (p.position[0][i] - p.position[0][j]);
        fy[k] += s * (p.position[1][i] - p.position[1][j]);
        fz[k] += s * (p.position[2][i] - p.position[2][j]);
    }
}
