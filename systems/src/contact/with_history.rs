//! The pair pass of the contact pipeline for scenes with friction, rolling resistance
//! or adhesion (frictionless scenes run `frictionless::hertz_contact`): the narrow phase
//! of sphere pairs, the laws of `pipeline::interact`, accumulation through the contact
//! store's scatter plan. A contact's history (tangential spring, rolling displacement,
//! JKR contact flag) lives in the contact store (`ContactHistory` for pairs,
//! `WallHistory` for walls); a contact that ends has its history reset.
//!
//! Two passes over the pairs of the contact store (`ContactHistory::pairs`: the listed
//! pairs within an inner skin, and those holding history): every pair once, four
//! consecutive pairs at a time in `f64x4` lanes, with its history stored in blocks of
//! four, in the work items of the store's scatter plan (`ScatterPlan`): each item adds
//! its pairs' force and torques to one record per particle it touches; then, per chunk
//! of particles, the wall stage (`wall_pass`), and every particle sums its records (in
//! item order) and its walls, in a fixed order: the result does not depend on the
//! thread count.
use bevy_ecs::prelude::*;
use grainflow_components::{
    Columns, ContactHistory, ContactLaws, Materials, PairList, Particles, Rotation, RunHealth,
    ScatterPlan, SimClock, WallHistory, WallList, Walls,
};
use rayon::prelude::*;
use wide::{f64x4, CmpGe, CmpGt, CmpLt};

use super::deeper;
use super::laws::hertz::{ConstantDamping, NormalDamping, RestitutionDamping};
use super::pipeline::{gather3, interact, Geometry, History, Laws};
use super::wall_pass::{add_wall_results, wall_contacts, wall_entry_chunks, WallResult};
use crate::real::{gather, group_masks, transpose4};
use crate::team::StaticSplit;
use crate::{Rows, CHUNK};

/// Whether the scene needs this system (some pair has friction, rolling or adhesion).
pub fn has_contact_laws(w: &World) -> bool {
    w.contains_resource::<ContactLaws>()
}

/// One particle's sum over the pairs of one work item of the pair pass (its slot of the
/// [`grainflow_components::ScatterPlan`]): force (3) and torque (3).
type SlotRecord = [f64; 6];

const LANES: usize = ContactHistory::LANES;

#[allow(clippy::too_many_arguments)]
pub fn granular_contact(
    mut slot_sums: Local<Vec<SlotRecord>>,
    mut wall_results: Local<Vec<WallResult>>,
    mut unused_torque: Local<Columns>,
    mut particles: ResMut<Particles>,
    rotation: Option<ResMut<Rotation>>,
    materials: Res<Materials>,
    laws: Res<ContactLaws>,
    mut history: ResMut<ContactHistory>,
    walls: Option<Res<Walls>>,
    wall_list: Option<Res<WallList>>,
    mut wall_history: Option<ResMut<WallHistory>>,
    clock: Res<SimClock>,
    mut health: ResMut<RunHealth>,
) {
    let _span = tracing::info_span!("granular_contact").entered();
    let ContactHistory { pairs, values, .. } = &mut *history;
    // The records of the slots, then one zero record (see `pair_sum`).
    slot_sums.resize(pairs.scatter.slots() + 1, [0.0; 6]);
    slot_sums[pairs.scatter.slots()] = [0.0; 6];
    let walls = match (
        walls.as_deref(),
        wall_list.as_deref(),
        wall_history.as_deref_mut(),
    ) {
        (Some(w), Some(l), Some(h)) => Some((w, l, h)),
        _ => None,
    };
    let restitution = materials.pairs.iter().any(|p| p.restitution_factor > 0.0);
    // Without rotation (adhesion only) the torques go to a scratch block.
    let mut rotation = rotation;
    let torque = match rotation.as_deref_mut() {
        Some(r) => &mut r.torque,
        None => {
            for col in unused_torque.iter_mut() {
                col.resize(particles.len(), 0.0);
            }
            &mut *unused_torque
        }
    };
    let (p, l, h) = (&mut *particles, &*pairs, values);
    if let Some((_, l, _)) = &walls {
        wall_results.resize(l.walls.len(), [0.0; 8]);
    }
    let buffers = (&mut slot_sums[..], &mut wall_results[..], torque);
    let worst = if restitution {
        both_passes::<RestitutionDamping>(p, l, &materials, &laws, buffers, h, walls, clock.dt)
    } else {
        both_passes::<ConstantDamping>(p, l, &materials, &laws, buffers, h, walls, clock.dt)
    };
    health.max_overlap_ratio = worst.0;
    health.max_overlap_particle = worst.1;
    health.run_max_overlap_ratio = health.run_max_overlap_ratio.max(worst.0);
}

#[allow(clippy::too_many_arguments)]
fn both_passes<D: NormalDamping>(
    particles: &mut Particles,
    list: &PairList,
    materials: &Materials,
    laws: &ContactLaws,
    (sums, wall_results, torque): (&mut [SlotRecord], &mut [WallResult], &mut Columns),
    history: &mut [f64],
    walls: Option<(&Walls, &WallList, &mut WallHistory)>,
    dt: f64,
) -> (f64, u32) {
    let laws = Laws::new::<D>(materials, Some(laws), dt);
    let mut force = std::mem::take(&mut particles.force);
    let worst = contacts::<D>(
        &laws,
        particles,
        list,
        (sums, wall_results),
        history,
        [&mut force, torque],
        walls,
    );
    particles.force = force;
    worst
}

/// The force and torque on particle `i` from its pairs: its records over the work items
/// of the pair pass, in item order. Its walls follow, in list order
/// ([`wall_contacts`]). The first two records are read without a branch on the
/// particle's count of records (most have one or two; adding the zero record that ends
/// `sums` in place of a missing one changes no sum).
#[inline(always)]
fn pair_sum(plan: &ScatterPlan, i: usize, sums: &[SlotRecord]) -> [f64; 6] {
    let records = &plan.gather[plan.gather_start[i] as usize..plan.gather_start[i + 1] as usize];
    let zero = sums.len() - 1;
    let first = records.first().map_or(zero, |&s| s as usize);
    let second = records.get(1).map_or(zero, |&s| s as usize);
    let mut sum = [0.0; 6];
    for s in [first, second] {
        let r = &sums[s];
        for d in 0..6 {
            sum[d] += r[d];
        }
    }
    for &s in records.get(2..).unwrap_or_default() {
        let r = &sums[s as usize];
        for d in 0..6 {
            sum[d] += r[d];
        }
    }
    sum
}

/// `record += (head, tail)`: the first four values in one 4-wide add.
#[inline(always)]
fn add_to_record(record: &mut SlotRecord, head: f64x4, tail: [f64; 2]) {
    let (first, last) = record.split_at_mut(4);
    let first: &mut [f64; 4] = first.try_into().expect("six values");
    *first = (f64x4::new(*first) + head).to_array();
    last[0] += tail[0];
    last[1] += tail[1];
}

/// The records of every work item of the pair pass (`item_start`: the slots of each).
fn item_records<'a>(
    mut sums: &'a mut [SlotRecord],
    item_start: &[u32],
) -> Vec<&'a mut [SlotRecord]> {
    item_start
        .windows(2)
        .map(|w| {
            let (head, tail) = std::mem::take(&mut sums).split_at_mut((w[1] - w[0]) as usize);
            sums = tail;
            head
        })
        .collect()
}

/// Pass 1: every listed pair, in blocks of four consecutive pairs ([`Self::block`]),
/// in the work items of the list's [`grainflow_components::ScatterPlan`]: each item
/// adds its pairs' forces and torques to the records of its own slots. Pass 2, `CHUNK`
/// particles per work item: their wall contacts ([`Self::wall_contacts`]), then every
/// particle sums its records ([`Self::pair_sum`]) and its walls in a fixed order: the
/// result does not depend on the thread count.
fn contacts<D: NormalDamping>(
    laws: &Laws,
    p: &Particles,
    list: &PairList,
    (sums, wall_results): (&mut [SlotRecord], &mut [WallResult]),
    history: &mut [f64],
    [force, torque]: [&mut Columns; 2],
    mut walls: Option<(&Walls, &WallList, &mut WallHistory)>,
) -> (f64, u32) {
    let n = p.len();
    let width = laws.layout.width;
    let plan = &list.scatter;
    let pairs_worst = {
        let _span = tracing::info_span!("pair_contacts").entered();
        // (The empty plan before the store's first selection has no item size.)
        let per_item = plan.pairs_per_item.max(LANES);
        (
            item_records(sums, &plan.item_start),
            history.par_chunks_mut(per_item * width),
        )
            .into_par_iter()
            .enumerate()
            .static_map_reduce(
                |(c, (records, history))| {
                    let rows = Rows::of(p);
                    records.fill([0.0; 6]);
                    let mut worst = (0.0f64, u32::MAX);
                    for (b, hist) in history.chunks_mut(LANES * width).enumerate() {
                        let k0 = c * per_item + b * LANES;
                        block::<D>(laws, &rows, list, k0, records, hist, &mut worst);
                    }
                    worst
                },
                || (0.0, u32::MAX),
                deeper,
            )
    };
    let _span = tracing::info_span!("contact_sums_and_walls").entered();
    let wall_set = walls.as_ref().map(|(w, l, _)| (*w, *l));
    let [fx, fy, fz] = force;
    let [tx, ty, tz] = torque;
    let sums = &*sums;
    let sums_worst = (
        (
            fx.par_chunks_mut(CHUNK),
            fy.par_chunks_mut(CHUNK),
            fz.par_chunks_mut(CHUNK),
            tx.par_chunks_mut(CHUNK),
            ty.par_chunks_mut(CHUNK),
            tz.par_chunks_mut(CHUNK),
        ),
        wall_entry_chunks(
            walls
                .as_mut()
                .map(|(_, l, h)| (&mut h.values[..], &l.start[..])),
            n,
            width,
        ),
        wall_entry_chunks(wall_set.map(|(_, l)| (wall_results, &l.start[..])), n, 1),
    )
        .into_par_iter()
        .enumerate()
        .static_map_reduce(
            |(c, ((fx, fy, fz, tx, ty, tz), wall_hist, wall_out))| {
                let base = c * CHUNK;
                let rows = base..base + fx.len();
                let mut worst = (0.0f64, u32::MAX);
                let walls = match (wall_set, wall_hist, wall_out) {
                    (Some((walls, wl)), Some(hist), Some(out)) => {
                        wall_contacts::<D>(laws, &Rows::of(p), walls, wl, rows.clone(), hist, out);
                        Some((wl, &*out))
                    }
                    _ => None,
                };
                for (k, i) in rows.enumerate() {
                    let mut sum = pair_sum(plan, i, sums);
                    if let Some((wl, out)) = walls {
                        let deepest =
                            add_wall_results(wl, out, wl.start[base] as usize, i, &mut sum);
                        if deepest > 0.0 {
                            worst = deeper(worst, (deepest / p.radius[i], p.id[i]));
                        }
                    }
                    [fx[k], fy[k], fz[k], tx[k], ty[k], tz[k]] = sum;
                }
                worst
            },
            || (0.0, u32::MAX),
            deeper,
        );
    deeper(pairs_worst, sums_worst)
}

/// One block of four consecutive pairs from pair `k0` (one per lane, whatever their
/// rows), with its history block: adds the pairs' forces and torques to the records
/// of their particles' slots in `records` (the slots of the block's work item),
/// writes the history, and records the largest overlap over the smaller radius, with
/// the id of the pair's row owner.
#[inline(always)]
fn block<D: NormalDamping>(
    laws: &Laws,
    p: &Rows,
    list: &PairList,
    k0: usize,
    records: &mut [SlotRecord],
    hist: &mut [f64],
    worst: &mut (f64, u32),
) {
    let zero = f64x4::ZERO;
    let dt = f64x4::splat(laws.dt);
    let lane_mask = group_masks();
    let valid = (list.pairs() - k0).min(LANES);
    // Lanes past the last pair repeat it and are masked.
    let ks = [0, 1, 2, 3].map(|l| k0 + l.min(valid - 1));
    let is = ks.map(|k| list.owner[k] as usize);
    let js = ks.map(|k| list.neighbours[k] as usize);
    // Checked once here, the indices need no check in the gathers.
    assert!(
        is.iter().chain(&js).all(|&k| k < p.n),
        "listed pairs index particles"
    );
    let (ri, rj) = (gather(p.radius, &is), gather(p.radius, &js));
    let gap = gather3(&p.position, &is) - gather3(&p.position, &js);
    let d2 = gap.dot(gap);
    let reach = ri + rj;
    let component = |v: usize| {
        f64x4::new(
            hist[v * LANES..(v + 1) * LANES]
                .try_into()
                .expect("4 lanes"),
        )
    };
    let mut h = History::<f64x4>::load(&laws.layout, component);
    let live = (d2.cmp_lt(reach * reach) | h.bond.cmp_gt(zero)) & lane_mask[valid - 1];
    if live.none() {
        hist.fill(0.0);
        return;
    }
    let d = d2.sqrt();
    // One division for both 1/d and 1/(r_i + r_j).
    let q = f64x4::ONE / (d * reach);
    let (inv_d, inv_reach) = (q * reach, q * d);
    let nrm = gap.scale(inv_d);
    let (wi, wj) = (
        gather3(&p.angular_velocity, &is),
        gather3(&p.angular_velocity, &js),
    );
    let geometry = Geometry {
        n: nrm,
        delta: reach - d,
        r_eff: ri * rj * inv_reach,
        radius_ratio: (rj - ri) * inv_reach,
        inv_mass_sum: gather(p.inv_mass, &is) + gather(p.inv_mass, &js),
        velocity: gather3(&p.velocity, &is) - gather3(&p.velocity, &js),
        surface: nrm.cross(wi).scale(ri) + nrm.cross(wj).scale(rj),
        spin: wi - wj,
    };
    let mut scratch = None;
    let coefficients = laws.lanes(|l| (p.material[is[l]], p.material[js[l]]), &mut scratch);
    let e = interact::<f64x4, D>(coefficients, &laws.layout, &mut h, &geometry, dt);
    h.store(&laws.layout, |v, lanes| {
        hist[v * LANES..(v + 1) * LANES].copy_from_slice(lanes.as_array_ref())
    });
    let arm = nrm.cross(e.tangential);
    let roll = e.rolling.cross(nrm).scale(geometry.r_eff);
    let owner = roll - arm.scale(ri);
    let partner = -(arm.scale(rj) + roll);
    // Per lane: (F, T_x) on the owner, (-F, T_x) on the partner, and both (T_y, T_z).
    let to_owner = transpose4([e.force.x, e.force.y, e.force.z, owner.x]);
    let to_partner = transpose4([-e.force.x, -e.force.y, -e.force.z, partner.x]);
    let rest = transpose4([owner.y, owner.z, partner.y, partner.z]);
    let slots = &list.scatter.pair_slot[k0..k0 + valid];
    // Lanes out of contact add zeros (the sums do not change); masked lanes nothing.
    for (l, [so, sp]) in slots.iter().enumerate() {
        let rest = rest[l].as_array_ref();
        add_to_record(&mut records[*so as usize], to_owner[l], [rest[0], rest[1]]);
        add_to_record(
            &mut records[*sp as usize],
            to_partner[l],
            [rest[2], rest[3]],
        );
    }
    let overlap = e.touching & geometry.delta.cmp_gt(zero) & lane_mask[valid - 1];
    let ratio = overlap.blend(geometry.delta / ri.min(rj), zero);
    // Most blocks hold no overlap as deep as the chunk's deepest so far.
    let record = ratio.cmp_gt(zero) & ratio.cmp_ge(f64x4::splat(worst.0));
    if record.none() {
        return;
    }
    for (l, &x) in ratio.as_array_ref().iter().enumerate() {
        if x > 0.0 {
            *worst = deeper(*worst, (x, p.id[is[l]]));
        }
    }
}
