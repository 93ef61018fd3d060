//! Wall geometry: distance and normal from a sphere centre to each wall shape, and the
//! removal of walls at their time.
use bevy_ecs::prelude::*;
use grainflow_components::{
    NeighbourSettings, Particles, SimClock, VerletList, WallList, WallShape, Walls,
};
use rayon::prelude::*;

use crate::CHUNK;

/// Distance from point `p` to the wall surface and the unit normal pointing from the
/// wall towards `p`. For a plane the distance is signed (negative behind the plane).
/// For a surface of revolution the meridian segment (r0,h0)-(r1,h1) is the closest-point
/// target in the (radius, height) half-plane through `p`.
#[inline(always)]
pub fn wall_distance(shape: &WallShape, p: [f64; 3]) -> (f64, [f64; 3]) {
    // Only an infinite distance (an infinite coordinate) reaches infinity; NaN passes.
    wall_contact(shape, p, f64::INFINITY).unwrap_or((f64::INFINITY, [0.0; 3]))
}

/// [`wall_distance`] when the distance is below `reach` (a sphere's radius: a contact),
/// else `None`; the normal, with its divisions, is computed only for a contact.
#[inline(always)]
pub fn wall_contact(shape: &WallShape, p: [f64; 3], reach: f64) -> Option<(f64, [f64; 3])> {
    match *shape {
        WallShape::Plane { point, normal } => {
            let s = (p[0] - point[0]) * normal[0]
                + (p[1] - point[1]) * normal[1]
                + (p[2] - point[2]) * normal[2];
            if s >= reach {
                return None;
            }
            Some((s, normal))
        }
        WallShape::Revolution {
            origin,
            axis,
            r0,
            h0,
            r1,
            h1,
        } => {
            let q = [p[0] - origin[0], p[1] - origin[1], p[2] - origin[2]];
            let h = q[0] * axis[0] + q[1] * axis[1] + q[2] * axis[2];
            let radial = [q[0] - h * axis[0], q[1] - h * axis[1], q[2] - h * axis[2]];
            let rho =
                (radial[0] * radial[0] + radial[1] * radial[1] + radial[2] * radial[2]).sqrt();
            let (dr, dh) = (r1 - r0, h1 - h0);
            let len2 = dr * dr + dh * dh;
            let t = (((rho - r0) * dr + (h - h0) * dh) / len2).clamp(0.0, 1.0);
            let (cr, ch) = (r0 + t * dr, h0 + t * dh);
            let (gr, gh) = (rho - cr, h - ch);
            let dist = (gr * gr + gh * gh).sqrt();
            if dist >= reach {
                return None;
            }
            let e_r = if rho > 0.0 {
                [radial[0] / rho, radial[1] / rho, radial[2] / rho]
            } else {
                any_perpendicular(axis)
            };
            Some(if dist > 0.0 {
                let n = [
                    (gr * e_r[0] + gh * axis[0]) / dist,
                    (gr * e_r[1] + gh * axis[1]) / dist,
                    (gr * e_r[2] + gh * axis[2]) / dist,
                ];
                (dist, n)
            } else {
                (0.0, [-e_r[0], -e_r[1], -e_r[2]])
            })
        }
    }
}

/// Whether `p` lies on the particle side of the wall: in front of a plane, or inside the
/// surface of revolution within its axial extent. `None` where the wall does not decide
/// (beyond the axial ends of an open cylinder or cone).
pub fn wall_contains(shape: &WallShape, p: [f64; 3]) -> Option<bool> {
    match *shape {
        WallShape::Plane { .. } => Some(wall_distance(shape, p).0 >= 0.0),
        WallShape::Revolution {
            origin,
            axis,
            r0,
            h0,
            r1,
            h1,
        } => {
            let q = [p[0] - origin[0], p[1] - origin[1], p[2] - origin[2]];
            let h = q[0] * axis[0] + q[1] * axis[1] + q[2] * axis[2];
            let (lo, hi) = (h0.min(h1), h0.max(h1));
            if h < lo || h > hi {
                return None;
            }
            let rho2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] - h * h;
            let t = if h1 != h0 { (h - h0) / (h1 - h0) } else { 0.0 };
            let radius = r0 + t * (r1 - r0);
            Some(rho2.max(0.0).sqrt() <= radius)
        }
    }
}

fn any_perpendicular(a: [f64; 3]) -> [f64; 3] {
    let v = if a[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let d = v[0] * a[0] + v[1] * a[1] + v[2] * a[2];
    let w = [v[0] - d * a[0], v[1] - d * a[1], v[2] - d * a[2]];
    let n = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
    [w[0] / n, w[1] / n, w[2] / n]
}

/// Deactivate walls whose `remove_at` time has come (e.g. the hopper outlet plate).
pub fn wall_removal(clock: Res<SimClock>, mut walls: ResMut<Walls>, mut list: ResMut<VerletList>) {
    for wall in walls.list.iter_mut() {
        if wall.active && wall.remove_at.is_some_and(|t| clock.time >= t) {
            wall.active = false;
            list.stale = true;
            tracing::info!(wall = %wall.name, time = clock.time, "wall removed");
        }
    }
}

/// Rebuild the candidate wall contacts whenever the Verlet list was rebuilt.
pub fn wall_list(
    particles: Res<Particles>,
    list: Res<VerletList>,
    settings: Res<NeighbourSettings>,
    walls: Res<Walls>,
    mut wall_list: ResMut<WallList>,
) {
    if wall_list.built_for == list.builds && wall_list.start.len() == particles.len() + 1 {
        return;
    }
    let _span = tracing::info_span!("wall_list").entered();
    let [x, y, z] = &particles.position;
    let r = &particles.radius;
    let n = particles.len();
    let active: Vec<(u16, &WallShape)> = walls
        .list
        .iter()
        .enumerate()
        .filter(|(_, w)| w.active)
        .map(|(k, w)| (k as u16, &w.shape))
        .collect();
    let rows: Vec<(Vec<u16>, Vec<u32>)> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut ids = Vec::new();
            let mut counts = Vec::new();
            for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
                let before = ids.len();
                for (k, shape) in &active {
                    if wall_contact(shape, [x[i], y[i], z[i]], r[i] + settings.skin).is_some() {
                        ids.push(*k);
                    }
                }
                counts.push((ids.len() - before) as u32);
            }
            (ids, counts)
        })
        .collect();
    let WallList {
        start,
        walls: ids,
        built_for,
    } = &mut *wall_list;
    start.clear();
    start.push(0);
    ids.clear();
    let mut total = 0;
    for (chunk_ids, counts) in rows {
        for c in counts {
            total += c;
            start.push(total);
        }
        ids.extend(chunk_ids);
    }
    *built_for = list.builds;
}
