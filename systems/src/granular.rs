//! Contact forces with per-contact history, for scenes with friction, rolling resistance
//! or adhesion (frictionless scenes run the branch-free `hertz_contact` instead):
//!
//! - normal force: Hertz with damping (`hertz.rs`), or JKR adhesion (`jkr.rs`) plus the
//!   same damping, with the JKR contact hysteresis (forms at touching, breaks at
//!   -delta_s);
//! - tangential force: Coulomb friction with a tangential spring (`friction.rs`);
//! - rolling resistance torque (`rolling.rs`);
//!
//! between particles and with walls. A contact's history (tangential spring, rolling
//! displacement, JKR contact flag) lives in the contact store (`ContactHistory` for
//! pairs, `WallHistory` for walls); a contact that ends has its history reset.
//!
//! Like `hertz_contact`, two passes over the half Verlet list: each row owner computes its
//! pairs once (force on the owner and torque on the partner kept per pair), then every
//! particle adds the partner halves and its walls, in a fixed order: the result does not
//! depend on the thread count.
use bevy_ecs::prelude::*;
use glam::DVec3;
use grainflow_components::{
    ContactHistory, ContactLaw, ContactLaws, HistoryLayout, Materials, PairParams, Particles,
    Rotation, RunHealth, SimClock, VerletList, WallHistory, WallList, Walls,
};
use rayon::prelude::*;

use crate::friction::{coulomb_tangential_force, tangential_stiffness};
use crate::hertz::{hertz_normal_force, ConstantDamping, NormalDamping, RestitutionDamping};
use crate::jkr::Jkr;
use crate::rolling::{rolling_resistance_force, rolling_stiffness, rolling_velocity};
use crate::walls::wall_distance;
use crate::{row_chunks, CHUNK};

/// Whether the scene needs this system (some pair has friction, rolling or adhesion).
pub fn has_contact_laws(w: &World) -> bool {
    w.contains_resource::<ContactLaws>()
}

/// One contact seen from particle i: unit normal `n` from j (or the wall) to i, overlap,
/// R*, (R_j - R_i)/(R_i + R_j), 1/m*, velocity of i relative to j, the surface term
/// R_i n x w_i + R_j n x w_j of the relative contact velocity, and w_i - w_j.
struct Geometry {
    n: DVec3,
    delta: f64,
    r_eff: f64,
    radius_ratio: f64,
    inv_mass_sum: f64,
    velocity: DVec3,
    surface: DVec3,
    spin: DVec3,
}

/// What a contact exerts: force on i, tangential force F_t, and rolling resistance f_r
/// (the torque on i is -R_i n x F_t + R* f_r x n).
struct Exerted {
    force: DVec3,
    tangential: DVec3,
    rolling: DVec3,
}

/// The models of one contact. `hist` is its history row; `flip` = -1 when the row is
/// stored for the pair oriented the other way (directed values change sign).
#[inline]
fn interact<D: NormalDamping>(
    params: &PairParams,
    law: &ContactLaw,
    layout: &HistoryLayout,
    hist: &mut [f64],
    flip: f64,
    c: &Geometry,
    dt: f64,
) -> Option<Exerted> {
    let jkr = law.adhesion.map(|a| Jkr {
        e_star: 0.75 * params.hertz_factor,
        r_eff: c.r_eff,
        work: a.work,
    });
    let bonded = layout.bond.is_some_and(|b| hist[b] > 0.0);
    let touching = match &jkr {
        Some(jkr) => c.delta >= 0.0 || (bonded && c.delta > -jkr.critical_separation()),
        None => c.delta > 0.0,
    };
    if !touching {
        hist.fill(0.0);
        return None;
    }
    let delta_dot = -c.velocity.dot(c.n);
    let coefficient = D::coefficient(params);
    let (f_n, a, load) = match &jkr {
        Some(jkr) => {
            let a = jkr.contact_radius(c.delta);
            let f = jkr.force_at_radius(a)
                + D::damping(
                    coefficient,
                    params.hertz_factor,
                    a,
                    c.inv_mass_sum,
                    delta_dot,
                );
            hist[layout.bond.expect("adhesion has a history slot")] = 1.0;
            // Thornton & Yin (1991): the Coulomb limit of an adhesive contact is
            // mu (F_n + 2 F_s).
            (f, a, (f + 2.0 * jkr.pull_off_force()).max(0.0))
        }
        None => {
            let f = hertz_normal_force::<f64, D>(
                params.hertz_factor,
                coefficient,
                c.r_eff,
                c.inv_mass_sum,
                c.delta,
                delta_dot,
            );
            (f, (c.r_eff * c.delta).sqrt(), f.max(0.0))
        }
    };
    let relative = c.velocity + c.surface;
    let u_t = relative - relative.dot(c.n) * c.n;
    let mut tangential = DVec3::ZERO;
    if let (Some(friction), Some(o)) = (&law.friction, layout.spring) {
        let mut g = flip * DVec3::from_slice(&hist[o..o + 3]);
        let c_s = tangential_stiffness(friction, a);
        tangential = coulomb_tangential_force(friction, &mut g, c.n, u_t, load, c_s, dt);
        (flip * g).write_to_slice(&mut hist[o..o + 3]);
    }
    let mut rolling = DVec3::ZERO;
    if let (Some(law), Some(o)) = (&law.rolling, layout.rolling) {
        // U_r is the same for both orientations of the pair: no flip.
        let mut xi = DVec3::from_slice(&hist[o..o + 3]);
        let u_r = rolling_velocity(c.r_eff, c.spin, c.n, c.radius_ratio, u_t);
        let c_r = rolling_stiffness(law, 0.75 * params.hertz_factor, a);
        rolling = rolling_resistance_force(law, &mut xi, c.n, u_r, load, c_r, dt);
        xi.write_to_slice(&mut hist[o..o + 3]);
    }
    Some(Exerted {
        force: f_n * c.n + tangential,
        tangential,
        rolling,
    })
}

/// Per-particle force and torque sums of this step.
type Sums = [DVec3; 2];

/// Per-pair result kept for the partner: force on the owner, torque on the partner.
type PairResult = [DVec3; 2];

#[allow(clippy::too_many_arguments)]
pub fn granular_contact(
    mut pair_results: Local<Vec<PairResult>>,
    mut sums: Local<Vec<Sums>>,
    mut particles: ResMut<Particles>,
    rotation: Option<ResMut<Rotation>>,
    list: Res<VerletList>,
    materials: Res<Materials>,
    laws: Res<ContactLaws>,
    mut history: ResMut<ContactHistory>,
    walls: Option<Res<Walls>>,
    wall_list: Option<Res<WallList>>,
    wall_history: Option<ResMut<WallHistory>>,
    clock: Res<SimClock>,
    mut health: ResMut<RunHealth>,
) {
    let _span = tracing::info_span!("granular_contact").entered();
    let n = particles.len();
    pair_results.resize(list.pairs(), [DVec3::ZERO; 2]);
    sums.resize(n, [DVec3::ZERO; 2]);
    let mut wall_history = wall_history;
    let walls = match (
        walls.as_deref(),
        wall_list.as_deref(),
        wall_history.as_deref_mut(),
    ) {
        (Some(w), Some(l), Some(h)) => Some((w, l, h)),
        _ => None,
    };
    let ctx = Context {
        particles: &particles,
        list: &list,
        materials: &materials,
        laws: &laws,
        dt: clock.dt,
    };
    let restitution = materials.pairs.iter().any(|p| p.restitution_factor > 0.0);
    let (results, sums_slice) = (&mut pair_results[..], &mut sums[..]);
    let worst = if restitution {
        ctx.both_passes::<RestitutionDamping>(results, sums_slice, &mut history.values, walls)
    } else {
        ctx.both_passes::<ConstantDamping>(results, sums_slice, &mut history.values, walls)
    };
    health.max_overlap_ratio = worst.0;
    health.max_overlap_particle = worst.1;
    health.run_max_overlap_ratio = health.run_max_overlap_ratio.max(worst.0);
    let Particles { force, .. } = &mut *particles;
    for (d, col) in force.iter_mut().enumerate() {
        col.par_iter_mut()
            .zip(&sums[..])
            .for_each(|(f, s)| *f = s[0][d]);
    }
    if let Some(mut rotation) = rotation {
        for (d, col) in rotation.torque.iter_mut().enumerate() {
            col.par_iter_mut()
                .zip(&sums[..])
                .for_each(|(t, s)| *t = s[1][d]);
        }
    }
}

struct Context<'a> {
    particles: &'a Particles,
    list: &'a VerletList,
    materials: &'a Materials,
    laws: &'a ContactLaws,
    dt: f64,
}

/// The deeper of two (overlap ratio, particle id) records; the smaller id on ties.
fn deeper(a: (f64, u32), b: (f64, u32)) -> (f64, u32) {
    if b.0 > a.0 || (b.0 == a.0 && b.1 < a.1) {
        b
    } else {
        a
    }
}

impl Context<'_> {
    #[inline]
    fn vec(&self, col: &[Vec<f64>; 3], i: usize) -> DVec3 {
        DVec3::new(col[0][i], col[1][i], col[2][i])
    }

    fn both_passes<D: NormalDamping>(
        &self,
        results: &mut [PairResult],
        sums: &mut [Sums],
        history: &mut [f64],
        walls: Option<(&Walls, &WallList, &mut WallHistory)>,
    ) -> (f64, u32) {
        let rows = {
            let _span = tracing::info_span!("row_contacts").entered();
            self.row_contacts::<D>(results, sums, history)
        };
        let _span = tracing::info_span!("partner_and_wall_contacts").entered();
        deeper(
            rows,
            self.partner_and_wall_contacts::<D>(results, sums, walls),
        )
    }

    /// Pass 1: the pairs of each particle's own row.
    fn row_contacts<D: NormalDamping>(
        &self,
        results: &mut [PairResult],
        sums: &mut [Sums],
        history: &mut [f64],
    ) -> (f64, u32) {
        let p = self.particles;
        let n = p.len();
        let list = self.list;
        let layout = &self.laws.layout;
        let width = layout.width;
        (
            sums.par_chunks_mut(CHUNK),
            row_chunks(results, &list.start, n, 1),
            row_chunks(history, &list.start, n, width),
        )
            .into_par_iter()
            .enumerate()
            .map(|(c, (sums, results, history))| {
                let base = c * CHUNK;
                let pair_base = list.start[base] as usize;
                let mut worst = (0.0f64, u32::MAX);
                for (k, sum) in sums.iter_mut().enumerate() {
                    let i = base + k;
                    let (xi, vi, wi) = (
                        self.vec(&p.position, i),
                        self.vec(&p.velocity, i),
                        self.vec(&p.angular_velocity, i),
                    );
                    let ri = p.radius[i];
                    let mut total = [DVec3::ZERO; 2];
                    for pair in list.start[i] as usize..list.start[i + 1] as usize {
                        let j = list.neighbours[pair] as usize;
                        let local = pair - pair_base;
                        let hist = &mut history[local * width..(local + 1) * width];
                        let rj = p.radius[j];
                        let gap = xi - self.vec(&p.position, j);
                        let d2 = gap.length_squared();
                        // Apart beyond any adhesive range: nothing to compute.
                        let reach = ri + rj;
                        if d2 > reach * reach && hist.iter().all(|&h| h == 0.0) {
                            results[local] = [DVec3::ZERO; 2];
                            continue;
                        }
                        let d = d2.sqrt();
                        let nrm = gap / d;
                        let wj = self.vec(&p.angular_velocity, j);
                        let geometry = Geometry {
                            n: nrm,
                            delta: reach - d,
                            r_eff: ri * rj / reach,
                            radius_ratio: (rj - ri) / reach,
                            inv_mass_sum: p.inv_mass[i] + p.inv_mass[j],
                            velocity: vi - self.vec(&p.velocity, j),
                            surface: ri * nrm.cross(wi) + rj * nrm.cross(wj),
                            spin: wi - wj,
                        };
                        let (mi, mj) = (p.material[i], p.material[j]);
                        let flip = if p.id[i] < p.id[j] { 1.0 } else { -1.0 };
                        let exerted = interact::<D>(
                            self.materials.pair(mi, mj),
                            self.laws.pair(mi, mj),
                            layout,
                            hist,
                            flip,
                            &geometry,
                            self.dt,
                        );
                        let Some(e) = exerted else {
                            results[local] = [DVec3::ZERO; 2];
                            continue;
                        };
                        let arm = nrm.cross(e.tangential);
                        let roll = geometry.r_eff * e.rolling.cross(nrm);
                        total[0] += e.force;
                        total[1] += -ri * arm + roll;
                        results[local] = [e.force, -rj * arm - roll];
                        if geometry.delta > 0.0 {
                            worst = deeper(worst, (geometry.delta / ri.min(rj), p.id[i]));
                        }
                    }
                    *sum = total;
                }
                worst
            })
            .reduce(|| (0.0, u32::MAX), deeper)
    }

    /// Pass 2: partner halves of the pairs, then the walls.
    fn partner_and_wall_contacts<D: NormalDamping>(
        &self,
        results: &[PairResult],
        sums: &mut [Sums],
        walls: Option<(&Walls, &WallList, &mut WallHistory)>,
    ) -> (f64, u32) {
        let p = self.particles;
        let n = p.len();
        let list = self.list;
        let layout = &self.laws.layout;
        let width = layout.width;
        let (wall_set, wall_chunks): (_, Vec<Option<&mut [f64]>>) = match walls {
            Some((w, l, h)) => (
                Some((w, l)),
                row_chunks(&mut h.values, &l.start, n, width)
                    .into_iter()
                    .map(Some)
                    .collect(),
            ),
            None => (None, (0..n.div_ceil(CHUNK)).map(|_| None).collect()),
        };
        (sums.par_chunks_mut(CHUNK), wall_chunks)
            .into_par_iter()
            .enumerate()
            .map(|(c, (sums, mut wall_hist))| {
                let base = c * CHUNK;
                let mut worst = (0.0f64, u32::MAX);
                for (k, sum) in sums.iter_mut().enumerate() {
                    let i = base + k;
                    let rev = list.rev_start[i] as usize..list.rev_start[i + 1] as usize;
                    for &pair in &list.rev_pairs[rev] {
                        let [f, t] = results[pair as usize];
                        sum[0] -= f;
                        sum[1] += t;
                    }
                    let (Some((walls, wl)), Some(hist)) = (wall_set, wall_hist.as_deref_mut())
                    else {
                        continue;
                    };
                    let xi = self.vec(&p.position, i);
                    let wi = self.vec(&p.angular_velocity, i);
                    let ri = p.radius[i];
                    let entry_base = wl.start[base] as usize;
                    let mut deepest = 0.0f64;
                    for e in wl.start[i] as usize..wl.start[i + 1] as usize {
                        let wall = &walls.list[wl.walls[e] as usize];
                        let local = e - entry_base;
                        let h = &mut hist[local * width..(local + 1) * width];
                        let (dist, nrm) = wall_distance(&wall.shape, xi.to_array());
                        let nrm = DVec3::from_array(nrm);
                        let geometry = Geometry {
                            n: nrm,
                            delta: ri - dist,
                            r_eff: ri,
                            radius_ratio: 1.0,
                            inv_mass_sum: p.inv_mass[i],
                            velocity: self.vec(&p.velocity, i),
                            surface: ri * nrm.cross(wi),
                            spin: wi,
                        };
                        let (mw, mi) = (wall.material, p.material[i]);
                        let Some(e) = interact::<D>(
                            self.materials.pair(mw, mi),
                            self.laws.pair(mw, mi),
                            layout,
                            h,
                            1.0,
                            &geometry,
                            self.dt,
                        ) else {
                            continue;
                        };
                        sum[0] += e.force;
                        sum[1] += -ri * nrm.cross(e.tangential) + ri * e.rolling.cross(nrm);
                        deepest = deepest.max(geometry.delta);
                    }
                    if deepest > 0.0 {
                        worst = deeper(worst, (deepest / ri, p.id[i]));
                    }
                }
                worst
            })
            .reduce(|| (0.0, u32::MAX), deeper)
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
