//! Contact forces with per-contact history, for scenes with friction, rolling resistance
//! or adhesion (frictionless scenes run the branch-free `hertz_contact` instead):
//!
//! - normal force: Hertz with damping (`laws/hertz.rs`), or JKR adhesion (`laws/jkr.rs`) plus the
//!   same damping, with the JKR contact hysteresis (forms at touching, breaks at
//!   -delta_s);
//! - tangential force: Coulomb friction with a tangential spring (`laws/friction.rs`);
//! - rolling resistance torque (`laws/rolling.rs`);
//!
//! between particles and with walls. A contact's history (tangential spring, rolling
//! displacement, JKR contact flag) lives in the contact store (`ContactHistory` for
//! pairs, `WallHistory` for walls); a contact that ends has its history reset.
//!
//! Two passes over the pairs of the contact store (`ContactHistory::pairs`: the listed
//! pairs within an inner skin, and those holding history): every pair once, four
//! consecutive pairs at a time in `f64x4` lanes, with its history stored in blocks of
//! four, in the work items of the store's scatter plan (`ScatterPlan`): each item adds
//! its pairs' force and torques to one record per particle it touches; then, per chunk
//! of particles, the wall contacts four wall-list entries at a time in lanes, and every
//! particle sums its records (in item order) and its walls, in a fixed order: the result
//! does not depend on the thread count. The model code is written once over [`Real`].
use bevy_ecs::prelude::*;
use grainflow_components::{
    Columns, ContactHistory, ContactLaws, HistoryLayout, Materials, PairList, Particles, Rotation,
    RunHealth, ScatterPlan, SimClock, TangentialStiffness, Wall, WallHistory, WallList, Walls,
};
use rayon::prelude::*;
use wide::{f64x4, CmpGe, CmpGt, CmpLt};

use super::deeper;
use crate::contact::laws::friction::coulomb_tangential_force;
use crate::contact::laws::hertz::{
    hertz_normal_force, ConstantDamping, NormalDamping, RestitutionDamping,
};
use crate::contact::laws::jkr::{
    jkr_contact_radius, jkr_critical_separation, jkr_equilibrium_radius, jkr_force_at_radius,
};
use crate::contact::laws::rolling::{rolling_resistance_force, rolling_velocity};
use crate::contact::walls::WallLanes;
use crate::real::{gather, group_masks, transpose4, Real, V3};
use crate::team::StaticSplit;
use crate::{row_chunks, Rows, CHUNK};

/// Whether the scene needs this system (some pair has friction, rolling or adhesion).
pub fn has_contact_laws(w: &World) -> bool {
    w.contains_resource::<ContactLaws>()
}

/// The numbers of one material pair's laws, as the kernel uses them (lanes of pairs, or
/// one pair). A model a pair lacks has zero coefficients: friction and rolling with a
/// zero cap exert nothing, and W = 0 selects Hertz.
#[derive(Debug, Clone, Copy)]
struct Coefficients<T> {
    /// (4/3) E* and the normal damping coefficient of the damping law.
    hertz_factor: T,
    damping: T,
    mu_s: T,
    mu_d: T,
    /// c_s = stiffness_per_radius a + stiffness (Mindlin 8 G* a, or constant).
    tangential_per_radius: T,
    tangential_constant: T,
    tangential_damping: T,
    mu_r: T,
    /// c_r = rolling_per_radius a + rolling_constant (2.25 mu_r^2 2 E* a by default).
    rolling_per_radius: T,
    rolling_constant: T,
    rolling_damping: T,
    work: T,
}

impl Coefficients<f64> {
    fn of_pair<D: NormalDamping>(
        materials: &Materials,
        laws: &ContactLaws,
        a: u16,
        b: u16,
    ) -> Self {
        let p = materials.pair(a, b);
        let law = laws.pair(a, b);
        let e_star = 0.75 * p.hertz_factor;
        let (mu_s, mu_d, kt_a, kt_c, d_s) = law.friction.map_or((0.0, 0.0, 0.0, 0.0, 0.0), |f| {
            let (per_a, constant) = match f.stiffness {
                TangentialStiffness::Mindlin(eight_g) => (eight_g, 0.0),
                TangentialStiffness::Constant(c) => (0.0, c),
            };
            (
                f.static_coefficient,
                f.dynamic_coefficient,
                per_a,
                constant,
                f.damping,
            )
        });
        let (mu_r, kr_a, kr_c, d_r) = law.rolling.map_or((0.0, 0.0, 0.0, 0.0), |r| {
            let (per_a, constant) = match r.stiffness {
                Some(c) => (0.0, c),
                None => (2.25 * r.coefficient * r.coefficient * 2.0 * e_star, 0.0),
            };
            (r.coefficient, per_a, constant, r.damping)
        });
        Self {
            hertz_factor: p.hertz_factor,
            damping: D::coefficient(p),
            mu_s,
            mu_d,
            tangential_per_radius: kt_a,
            tangential_constant: kt_c,
            tangential_damping: d_s,
            mu_r,
            rolling_per_radius: kr_a,
            rolling_constant: kr_c,
            rolling_damping: d_r,
            work: law.adhesion.map_or(0.0, |a| a.work),
        }
    }
}

impl<T: Real> Coefficients<T> {
    fn splat(c: &Coefficients<f64>) -> Self {
        Self::gather(&[c], |_| 0)
    }
    /// Lane `l` from `table[index(l)]`.
    #[inline(always)]
    fn gather(table: &[&Coefficients<f64>], index: impl Fn(usize) -> usize) -> Self {
        let lane = |f: fn(&Coefficients<f64>) -> f64| T::from_lanes(|l| f(table[index(l)]));
        Self {
            hertz_factor: lane(|c| c.hertz_factor),
            damping: lane(|c| c.damping),
            mu_s: lane(|c| c.mu_s),
            mu_d: lane(|c| c.mu_d),
            tangential_per_radius: lane(|c| c.tangential_per_radius),
            tangential_constant: lane(|c| c.tangential_constant),
            tangential_damping: lane(|c| c.tangential_damping),
            mu_r: lane(|c| c.mu_r),
            rolling_per_radius: lane(|c| c.rolling_per_radius),
            rolling_constant: lane(|c| c.rolling_constant),
            rolling_damping: lane(|c| c.rolling_damping),
            work: lane(|c| c.work),
        }
    }
}

/// Contacts seen from particle i: unit normal `n` from j (or the wall) to i, overlap,
/// R*, (R_j - R_i)/(R_i + R_j), 1/m*, velocity of i relative to j, the surface term
/// R_i n x w_i + R_j n x w_j of the relative contact velocity, and w_i - w_j.
struct Geometry<T> {
    n: V3<T>,
    delta: T,
    r_eff: T,
    radius_ratio: T,
    inv_mass_sum: T,
    velocity: V3<T>,
    surface: V3<T>,
    spin: V3<T>,
}

/// Per-contact history in lanes: tangential spring and sliding flag, rolling
/// displacement, JKR flag.
#[derive(Clone, Copy)]
struct History<T> {
    spring: V3<T>,
    sliding: T,
    rolling: V3<T>,
    bond: T,
}

/// What contacts exert, zero in lanes out of contact: force on i, tangential force F_t,
/// rolling resistance f_r (the torque on i is -R_i n x F_t + R* f_r x n).
struct Exerted<T: Real> {
    touching: T::Mask,
    force: V3<T>,
    tangential: V3<T>,
    rolling: V3<T>,
}

/// The models of a contact (lanes of contacts), seen from particle i (the row owner of a
/// pair, or the particle of a wall contact): `hist` is updated in place, its tangential
/// spring directed from i (the contact store keeps it so, see `ContactHistory`); lanes out
/// of contact get zero history.
#[inline(always)]
fn interact<T: Real, D: NormalDamping>(
    c: &Coefficients<T>,
    layout: &HistoryLayout,
    hist: &mut History<T>,
    g: &Geometry<T>,
    dt: T,
) -> Exerted<T> {
    let zero = T::splat(0.0);
    let mut touching = zero.lt(g.delta);
    let delta_dot = -g.velocity.dot(g.n);
    // Hertz: c_n delta^(3/2) + damping, with the contact radius a = sqrt(R* delta).
    let mut a = (g.r_eff * g.delta.max(zero)).sqrt();
    let mut f_n = hertz_normal_force::<T, D>(
        c.hertz_factor,
        c.damping,
        a,
        g.inv_mass_sum,
        g.delta,
        delta_dot,
    );
    let mut load_offset = zero;
    let mut bonded = touching;
    if layout.bond.is_some() {
        let adhesive = zero.lt(c.work);
        // Lanes without adhesion get a dummy W (their result is not selected).
        let work = T::select(adhesive, c.work, T::splat(1.0));
        let e_star = T::splat(0.75) * c.hertz_factor;
        let a0 = jkr_equilibrium_radius(e_star, g.r_eff, work);
        let delta_s = jkr_critical_separation(a0, g.r_eff);
        let holds = zero.le(g.delta) | (zero.lt(hist.bond) & (-delta_s).lt(g.delta));
        bonded = adhesive & holds;
        touching = touching | bonded;
        // JKR: the JKR force at its contact radius plus the same damping.
        let a_jkr = jkr_contact_radius(a0, delta_s, g.delta);
        let pull_off = T::splat(1.5 * std::f64::consts::PI) * work * g.r_eff;
        let f_jkr = jkr_force_at_radius(a0, pull_off, a_jkr)
            + D::damping(c.damping, c.hertz_factor, a_jkr, g.inv_mass_sum, delta_dot);
        a = T::select(adhesive, a_jkr, a);
        f_n = T::select(adhesive, f_jkr, f_n);
        // Thornton & Yin (1991): the Coulomb limit of an adhesive contact is
        // mu (F_n + 2 F_s).
        load_offset = T::select(adhesive, T::splat(2.0) * pull_off, zero);
    }
    let load = (f_n + load_offset).max(zero);
    let relative = g.velocity + g.surface;
    let u_t = relative - g.n.scale(relative.dot(g.n));
    let mut tangential = V3::zero();
    if layout.spring.is_some() {
        let mut spring = hist.spring;
        let c_s = c.tangential_per_radius * a + c.tangential_constant;
        let mut sliding = hist.sliding;
        tangential = coulomb_tangential_force(
            &mut spring,
            &mut sliding,
            g.n,
            u_t,
            load,
            [c.mu_s, c.mu_d],
            c_s,
            c.tangential_damping,
            dt,
        );
        hist.spring = V3::select(touching, spring, V3::zero());
        hist.sliding = T::select(touching, sliding, zero);
    }
    let mut rolling = V3::zero();
    if layout.rolling.is_some() {
        let mut xi = hist.rolling;
        let u_r = rolling_velocity(g.r_eff, g.spin, g.n, g.radius_ratio, u_t);
        let c_r = c.rolling_per_radius * a + c.rolling_constant;
        rolling =
            rolling_resistance_force(&mut xi, g.n, u_r, load, c.mu_r, c_r, c.rolling_damping, dt);
        hist.rolling = V3::select(touching, xi, V3::zero());
    }
    hist.bond = T::select(bonded, T::splat(1.0), zero);
    Exerted {
        touching,
        force: V3::select(touching, g.n.scale(f_n) + tangential, V3::zero()),
        tangential: V3::select(touching, tangential, V3::zero()),
        rolling: V3::select(touching, rolling, V3::zero()),
    }
}

impl<T: Real> History<T> {
    /// The history from `value(c)`, the lanes of its component `c` in the layout.
    #[inline(always)]
    fn load(layout: &HistoryLayout, value: impl Fn(usize) -> T) -> Self {
        let v3 = |o: Option<usize>| {
            o.map_or(V3::zero(), |o| {
                V3::new(value(o), value(o + 1), value(o + 2))
            })
        };
        Self {
            spring: v3(layout.spring),
            sliding: layout.sliding.map_or(T::splat(0.0), &value),
            rolling: v3(layout.rolling),
            bond: layout.bond.map_or(T::splat(0.0), &value),
        }
    }

    /// Hand every component `c` of the layout to `put(c, lanes)`.
    #[inline(always)]
    fn store(&self, layout: &HistoryLayout, mut put: impl FnMut(usize, T)) {
        for (o, v) in [(layout.spring, self.spring), (layout.rolling, self.rolling)] {
            if let Some(o) = o {
                put(o, v.x);
                put(o + 1, v.y);
                put(o + 2, v.z);
            }
        }
        if let Some(o) = layout.sliding {
            put(o, self.sliding);
        }
        if let Some(o) = layout.bond {
            put(o, self.bond);
        }
    }
}

/// One particle's sum over the pairs of one work item of the pair pass (its slot of the
/// [`grainflow_components::ScatterPlan`]): force (3) and torque (3).
type SlotRecord = [f64; 6];

/// Per wall-list entry: force (3) and torque (3) on the particle, overlap, and 1 if the
/// contact acts (0: apart, nothing to add).
type WallResult = [f64; 8];

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

#[inline(always)]
fn gather3(cols: &[&[f64]; 3], js: &[usize; 4]) -> V3<f64x4> {
    V3::new(
        gather(cols[0], js),
        gather(cols[1], js),
        gather(cols[2], js),
    )
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
    let m = materials.list.len();
    let table: Vec<Coefficients<f64>> = (0..m * m)
        .map(|k| Coefficients::of_pair::<D>(materials, laws, (k / m) as u16, (k % m) as u16))
        .collect();
    let kernel = Kernel {
        table: &table,
        one: (m == 1).then(|| Coefficients::splat(&table[0])),
        materials: m,
        layout: &laws.layout,
        dt,
    };
    let mut force = std::mem::take(&mut particles.force);
    let worst = kernel.contacts::<D>(
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
/// ([`Kernel::wall_contacts`]). The first two records are read without a branch on the
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

/// Per-entry `values` of the wall list (`width` per entry; `start` its row starts) split
/// at the chunks of particles, or `None`s without walls.
fn wall_entry_chunks<'a, T>(
    values: Option<(&'a mut [T], &[u32])>,
    n: usize,
    width: usize,
) -> Vec<Option<&'a mut [T]>> {
    match values {
        Some((values, start)) => row_chunks(values, start, n, width)
            .into_iter()
            .map(Some)
            .collect(),
        None => (0..n.div_ceil(CHUNK)).map(|_| None).collect(),
    }
}

struct Kernel<'a> {
    table: &'a [Coefficients<f64>],
    /// The coefficients in lanes when there is one material.
    one: Option<Coefficients<f64x4>>,
    materials: usize,
    layout: &'a HistoryLayout,
    dt: f64,
}

impl Kernel<'_> {
    #[inline(always)]
    fn pair(&self, a: u16, b: u16) -> &Coefficients<f64> {
        &self.table[a as usize * self.materials + b as usize]
    }

    /// Pass 1: every listed pair, in blocks of four consecutive pairs ([`Self::block`]),
    /// in the work items of the list's [`grainflow_components::ScatterPlan`]: each item
    /// adds its pairs' forces and torques to the records of its own slots. Pass 2, `CHUNK`
    /// particles per work item: their wall contacts ([`Self::wall_contacts`]), then every
    /// particle sums its records ([`Self::pair_sum`]) and its walls in a fixed order: the
    /// result does not depend on the thread count.
    fn contacts<D: NormalDamping>(
        &self,
        p: &Particles,
        list: &PairList,
        (sums, wall_results): (&mut [SlotRecord], &mut [WallResult]),
        history: &mut [f64],
        [force, torque]: [&mut Columns; 2],
        mut walls: Option<(&Walls, &WallList, &mut WallHistory)>,
    ) -> (f64, u32) {
        let n = p.len();
        let width = self.layout.width;
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
                            self.block::<D>(&rows, list, k0, records, hist, &mut worst);
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
                            self.wall_contacts::<D>(p, walls, wl, rows.clone(), hist, out);
                            Some((wl, &*out))
                        }
                        _ => None,
                    };
                    for (k, i) in rows.enumerate() {
                        let mut sum = pair_sum(plan, i, sums);
                        if let Some((wl, out)) = walls {
                            let entries = wl.start[i] as usize..wl.start[i + 1] as usize;
                            let local = entries.start - wl.start[base] as usize;
                            let mut deepest = 0.0f64;
                            for r in &out[local..local + entries.len()] {
                                if r[7] == 0.0 {
                                    continue;
                                }
                                for d in 0..6 {
                                    sum[d] += r[d];
                                }
                                deepest = deepest.max(r[6]);
                            }
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
        &self,
        p: &Rows,
        list: &PairList,
        k0: usize,
        records: &mut [SlotRecord],
        hist: &mut [f64],
        worst: &mut (f64, u32),
    ) {
        let zero = f64x4::ZERO;
        let dt = f64x4::splat(self.dt);
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
        let mut h = History::<f64x4>::load(self.layout, component);
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
        let gathered;
        let coefficients = match &self.one {
            Some(c) => c,
            None => {
                let refs = [0, 1, 2, 3].map(|l| self.pair(p.material[is[l]], p.material[js[l]]));
                gathered = Coefficients::gather(&refs, |l| l);
                &gathered
            }
        };
        let e = interact::<f64x4, D>(coefficients, self.layout, &mut h, &geometry, dt);
        h.store(self.layout, |v, lanes| {
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

    /// The wall contacts of particles `rows`, wall by wall, four of the wall's entries at
    /// a time in lanes (whatever their particles): `out` (the entries of `rows`) gets every
    /// entry's [`WallResult`], `hist` (their history rows) is updated. An entry apart gets
    /// zero force and history, as the models give lanes out of contact. Each entry's result
    /// is the same whatever entries share its lanes: the sums do not change.
    fn wall_contacts<D: NormalDamping>(
        &self,
        p: &Particles,
        walls: &Walls,
        wl: &WallList,
        rows: std::ops::Range<usize>,
        hist: &mut [f64],
        out: &mut [WallResult],
    ) {
        let entries = wl.start[rows.start] as usize..wl.start[rows.end] as usize;
        let base = entries.start;
        for (w, wall) in walls.list.iter().enumerate() {
            let shape = WallLanes::new(&wall.shape);
            let mut pending = [0; LANES];
            let mut count = 0;
            for e in entries.clone() {
                if wl.walls[e] as usize != w {
                    continue;
                }
                pending[count] = e;
                count += 1;
                if count == LANES {
                    self.wall_lanes::<D>(p, (wall, &shape), wl, base, &pending, count, hist, out);
                    count = 0;
                }
            }
            if count > 0 {
                self.wall_lanes::<D>(p, (wall, &shape), wl, base, &pending, count, hist, out);
            }
        }
    }

    /// The first `count` of the wall-list entries `lanes` of `wall` (its geometry in lanes:
    /// `shape`; lanes past them repeat the last and are not stored); `base` is the first
    /// entry of `hist` and `out`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn wall_lanes<D: NormalDamping>(
        &self,
        p: &Particles,
        (wall, shape): (&Wall, &WallLanes),
        wl: &WallList,
        base: usize,
        lanes: &[usize; LANES],
        count: usize,
        hist: &mut [f64],
        out: &mut [WallResult],
    ) {
        let width = self.layout.width;
        let entries = [0, 1, 2, 3].map(|l| lanes[l.min(count - 1)]);
        let at = entries.map(|e| e - base);
        let is = entries.map(|e| wl.particle[e] as usize);
        let ri = gather(&p.radius, &is);
        let (dist, nrm) = shape.distance(gather3(&p.position.each_ref().map(|c| &c[..]), &is));
        let wi = gather3(&p.angular_velocity.each_ref().map(|c| &c[..]), &is);
        let geometry = Geometry {
            n: nrm,
            delta: ri - dist,
            r_eff: ri,
            radius_ratio: f64x4::ONE,
            inv_mass_sum: gather(&p.inv_mass, &is),
            velocity: gather3(&p.velocity.each_ref().map(|c| &c[..]), &is),
            surface: nrm.cross(wi).scale(ri),
            spin: wi,
        };
        let mut h =
            History::<f64x4>::load(self.layout, |v| f64x4::new(at.map(|a| hist[a * width + v])));
        let gathered;
        let coefficients = match &self.one {
            Some(c) => c,
            None => {
                let refs = is.map(|i| self.pair(wall.material, p.material[i]));
                gathered = Coefficients::gather(&refs, |l| l);
                &gathered
            }
        };
        let dt = f64x4::splat(self.dt);
        let e = interact::<f64x4, D>(coefficients, self.layout, &mut h, &geometry, dt);
        let t = e.rolling.cross(nrm).scale(ri) - nrm.cross(e.tangential).scale(ri);
        let acts = e.touching.blend(f64x4::ONE, f64x4::ZERO);
        let values = [
            e.force.x,
            e.force.y,
            e.force.z,
            t.x,
            t.y,
            t.z,
            geometry.delta,
            acts,
        ]
        .map(|v| v.to_array());
        for (l, &a) in at[..count].iter().enumerate() {
            h.store(self.layout, |v, x| {
                hist[a * width + v] = x.as_array_ref()[l]
            });
            out[a] = values.map(|v| v[l]);
        }
    }
}

/// Carry the wall-contact history over a rebuild of the wall list: an entry (particle id,
/// wall) still listed keeps its values, a new one starts at zero.
pub fn carry_wall_history(
    particles: Res<Particles>,
    wall_list: Res<WallList>,
    mut history: ResMut<WallHistory>,
) {
    if history.built_for == Some(wall_list.built_for)
        && history.values.len() == wall_list.walls.len() * history.width
    {
        return;
    }
    let _span = tracing::info_span!("carry_wall_history").entered();
    let history = &mut *history;
    let width = history.width;
    let mut values = vec![0.0; wall_list.walls.len() * width];
    let max_id = particles
        .id
        .iter()
        .chain(&history.ids)
        .copied()
        .max()
        .map_or(0, |m| m as usize + 1);
    let mut old_row = vec![u32::MAX; max_id];
    for (row, &id) in history.ids.iter().enumerate() {
        old_row[id as usize] = row as u32;
    }
    for (i, &id) in particles.id.iter().enumerate() {
        let o = old_row[id as usize] as usize;
        if o + 1 >= history.start.len() {
            continue;
        }
        let old = history.start[o] as usize..history.start[o + 1] as usize;
        for e in wall_list.start[i] as usize..wall_list.start[i + 1] as usize {
            let wall = wall_list.walls[e];
            if let Some(pos) = history.walls[old.clone()].iter().position(|&w| w == wall) {
                let src = (old.start + pos) * width;
                values[e * width..(e + 1) * width]
                    .copy_from_slice(&history.values[src..src + width]);
            }
        }
    }
    history.values = values;
    history.ids.clone_from(&particles.id);
    history.start.clone_from(&wall_list.start);
    history.walls.clone_from(&wall_list.walls);
    history.built_for = Some(wall_list.built_for);
}
