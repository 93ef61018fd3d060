//! The wall stage of the contact pipeline, shared by both contact passes: every
//! wall-list entry (a sphere against a wall) in lanes of four entries of one wall
//! ([`wall_contacts`]: narrow phase by `walls::WallLanes`, laws by
//! [`super::pipeline::interact`]), one [`WallResult`] per entry, which each particle adds
//! after its pairs in list order ([`add_wall_results`]); and the wall-contact history
//! carried over a rebuild of the wall list ([`carry_wall_history`]).
use bevy_ecs::prelude::*;
use grainflow_components::{Particles, Wall, WallHistory, WallList, Walls};
use wide::f64x4;

use super::laws::hertz::NormalDamping;
use super::pipeline::{gather3, interact, Geometry, History, Laws};
use super::walls::WallLanes;
use crate::real::{gather, V3};
use crate::{row_chunks, Rows, CHUNK};

/// Contacts in lanes.
const LANES: usize = 4;

/// Per wall-list entry: force (3) and torque (3) on the particle, overlap, and 1 if the
/// contact acts (0: apart, nothing to add).
pub(crate) type WallResult = [f64; 8];

/// Per-entry `values` of the wall list (`width` per entry; `start` its row starts) split
/// at the chunks of particles, or `None`s without walls.
pub(crate) fn wall_entry_chunks<'a, T>(
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

/// The wall contacts of particles `rows`, wall by wall, four of the wall's entries at
/// a time in lanes (whatever their particles): `out` (the entries of `rows`) gets every
/// entry's [`WallResult`], `hist` (their history rows) is updated. An entry apart gets
/// zero force and history, as the models give lanes out of contact. Each entry's result
/// is the same whatever entries share its lanes: the sums do not change.
pub(crate) fn wall_contacts<D: NormalDamping>(
    laws: &Laws,
    p: &Rows,
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
        let mut flush = |pending: &[usize; LANES], count: usize| {
            wall_lanes::<D>(laws, p, (wall, &shape), wl, base, pending, count, hist, out)
        };
        let mut pending = [0; LANES];
        let mut count = 0;
        for e in entries.clone() {
            if wl.walls[e] as usize != w {
                continue;
            }
            pending[count] = e;
            count += 1;
            if count == LANES {
                flush(&pending, count);
                count = 0;
            }
        }
        if count > 0 {
            flush(&pending, count);
        }
    }
}

/// The first `count` of the wall-list entries `lanes` of `wall` (its geometry in lanes:
/// `shape`; lanes past them repeat the last and are not stored); `base` is the first
/// entry of `hist` and `out`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn wall_lanes<D: NormalDamping>(
    laws: &Laws,
    p: &Rows,
    (wall, shape): (&Wall, &WallLanes),
    wl: &WallList,
    base: usize,
    lanes: &[usize; LANES],
    count: usize,
    hist: &mut [f64],
    out: &mut [WallResult],
) {
    let width = laws.layout.width;
    let entries = [0, 1, 2, 3].map(|l| lanes[l.min(count - 1)]);
    let at = entries.map(|e| e - base);
    let is = entries.map(|e| wl.particle[e] as usize);
    let p = &p.cut();
    let ri = gather(p.radius, &is);
    let (dist, nrm) = shape.distance(gather3(&p.position, &is));
    // Spins only for the laws that use them (friction, rolling resistance).
    let (wi, surface) = if laws.spins() {
        let wi = gather3(&p.angular_velocity, &is);
        (wi, nrm.cross(wi).scale(ri))
    } else {
        (V3::zero(), V3::zero())
    };
    let geometry = Geometry {
        n: nrm,
        delta: ri - dist,
        r_eff: ri,
        radius_ratio: f64x4::ONE,
        inv_mass_sum: gather(p.inv_mass, &is),
        velocity: gather3(&p.velocity, &is),
        surface,
        spin: wi,
    };
    let layout = &laws.layout;
    let mut h = History::<f64x4>::load(layout, |v| f64x4::new(at.map(|a| hist[a * width + v])));
    let mut scratch = None;
    let coefficients = laws.lanes(|l| (wall.material, p.material[is[l]]), &mut scratch);
    let dt = f64x4::splat(laws.dt);
    let e = interact::<f64x4, D>(coefficients, layout, &mut h, &geometry, dt);
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
        h.store(layout, |v, x| hist[a * width + v] = x.as_array_ref()[l]);
        out[a] = values.map(|v| v[l]);
    }
}

/// Adds the results of particle `i`'s wall entries that act to `sum` (its first `N`
/// values: force, or force and torque), in list order; `out` holds the entries from
/// `base` on. Returns the deepest of their overlaps (zero if none acts).
#[inline(always)]
pub(crate) fn add_wall_results<const N: usize>(
    wl: &WallList,
    out: &[WallResult],
    base: usize,
    i: usize,
    sum: &mut [f64; N],
) -> f64 {
    let entries = wl.start[i] as usize - base..wl.start[i + 1] as usize - base;
    let mut deepest = 0.0f64;
    for r in &out[entries] {
        if r[7] == 0.0 {
            continue;
        }
        for d in 0..N {
            sum[d] += r[d];
        }
        deepest = deepest.max(r[6]);
    }
    deepest
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
