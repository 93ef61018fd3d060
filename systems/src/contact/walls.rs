//! Wall geometry: distance and normal from a sphere centre to each wall shape, and the
//! removal of walls at their time.
use bevy_ecs::prelude::*;
use grainflow_components::{
    NeighbourSettings, Particles, SimClock, VerletList, WallList, WallShape, Walls,
};
use rayon::prelude::*;
use wide::f64x4;

use crate::neighbour::compressed_rows::join_rows;
use crate::real::{Real, V3};
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
    let p = V3::new(p[0], p[1], p[2]);
    match *shape {
        WallShape::Plane { point, normal } => {
            let s = plane_distance(point, normal, p);
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
            thickness,
        } => {
            let gap = MeridianGap::of(origin, axis, [r0, h0, r1, h1], p);
            if gap.dist - 0.5 * thickness >= reach {
                return None;
            }
            // The radial direction at the axis (rare): only then worked out.
            let on_axis = if gap.rho > 0.0 {
                V3::zero()
            } else {
                splat3(any_perpendicular(axis))
            };
            let (dist, n) = gap.normal(axis, on_axis);
            Some((dist - 0.5 * thickness, [n.x, n.y, n.z]))
        }
    }
}

/// One wall for [`wall_distance`] of four points at a time in lanes (whatever the
/// distances: every lane gets its normal, with the same arithmetic as one point at a time),
/// with what does not depend on the points worked out once.
pub struct WallLanes<'a> {
    shape: &'a WallShape,
    /// The radial direction at the axis of a surface of revolution.
    on_axis: V3<f64x4>,
}

impl<'a> WallLanes<'a> {
    pub fn new(shape: &'a WallShape) -> Self {
        let on_axis = match *shape {
            WallShape::Plane { .. } => V3::zero(),
            WallShape::Revolution { axis, .. } => splat3(any_perpendicular(axis)),
        };
        Self { shape, on_axis }
    }

    /// The distances of the points `p` from the wall and the unit normals towards them.
    #[inline(always)]
    pub fn distance(&self, p: V3<f64x4>) -> (f64x4, V3<f64x4>) {
        match *self.shape {
            WallShape::Plane { point, normal } => {
                (plane_distance(point, normal, p), splat3(normal))
            }
            WallShape::Revolution {
                origin,
                axis,
                r0,
                h0,
                r1,
                h1,
                thickness,
            } => {
                let (dist, n) =
                    MeridianGap::of(origin, axis, [r0, h0, r1, h1], p).normal(axis, self.on_axis);
                (dist - f64x4::splat(0.5 * thickness), n)
            }
        }
    }
}

#[inline(always)]
fn splat3<T: Real>(a: [f64; 3]) -> V3<T> {
    V3::new(T::splat(a[0]), T::splat(a[1]), T::splat(a[2]))
}

/// Signed distance (p - point) . normal of `p` from a plane.
#[inline(always)]
fn plane_distance<T: Real>(point: [f64; 3], normal: [f64; 3], p: V3<T>) -> T {
    (p - splat3(point)).dot(splat3(normal))
}

/// A point against the meridian segment (r0, h0)-(r1, h1) of a surface of revolution, in
/// the (radius, height) half-plane through the point: its height `h` along the axis, its
/// radial offset from the axis and that offset's length `rho`, its offset (gr, gh) from the
/// closest point of the segment, and the length `dist` of that offset.
struct MeridianGap<T> {
    radial: V3<T>,
    rho: T,
    gr: T,
    gh: T,
    dist: T,
}

impl<T: Real> MeridianGap<T> {
    /// For the wall of `origin`, unit `axis` and meridian `[r0, h0, r1, h1]`.
    #[inline(always)]
    fn of(origin: [f64; 3], axis: [f64; 3], [r0, h0, r1, h1]: [f64; 4], p: V3<T>) -> Self {
        let axis = splat3::<T>(axis);
        let q = p - splat3(origin);
        let h = q.dot(axis);
        let radial = q - axis.scale(h);
        let rho = radial.length();
        let (dr, dh) = (r1 - r0, h1 - h0);
        let len2 = T::splat(dr * dr + dh * dh);
        let (r0, h0, dr, dh) = (T::splat(r0), T::splat(h0), T::splat(dr), T::splat(dh));
        let (zero, one) = (T::splat(0.0), T::splat(1.0));
        // t clamped to [0, 1] as f64::clamp does (NaN passes).
        let t = ((rho - r0) * dr + (h - h0) * dh) / len2;
        let t = T::select(t.lt(zero), zero, T::select(t.gt(one), one, t));
        let (gr, gh) = (rho - (r0 + t * dr), h - (h0 + t * dh));
        Self {
            radial,
            rho,
            gr,
            gh,
            dist: (gr * gr + gh * gh).sqrt(),
        }
    }

    /// The distance and the unit normal from the wall towards the point; at the axis the
    /// radial direction is `on_axis` (any perpendicular to the axis), on the surface the
    /// normal is inward.
    #[inline(always)]
    fn normal(&self, axis: [f64; 3], on_axis: V3<T>) -> (T, V3<T>) {
        let zero = T::splat(0.0);
        let axis = splat3::<T>(axis);
        let off_axis = zero.lt(self.rho);
        let e_r = V3::select(
            off_axis,
            V3::new(
                self.radial.x / self.rho,
                self.radial.y / self.rho,
                self.radial.z / self.rho,
            ),
            on_axis,
        );
        let apart = zero.lt(self.dist);
        let n = e_r.scale(self.gr) + axis.scale(self.gh);
        let n = V3::new(n.x / self.dist, n.y / self.dist, n.z / self.dist);
        (
            T::select(apart, self.dist, zero),
            V3::select(apart, n, -e_r),
        )
    }
}

/// Whether `p` lies on the particle side of the wall: in front of a plane, or inside the
/// surface of revolution within its axial extent. `None` where the wall does not decide
/// (beyond the axial ends of an open cylinder or cone; anywhere outside the solid of a
/// shell, whose both sides hold particles).
pub fn wall_contains(shape: &WallShape, p: [f64; 3]) -> Option<bool> {
    match *shape {
        WallShape::Plane { .. } => Some(wall_distance(shape, p).0 >= 0.0),
        WallShape::Revolution { thickness, .. } if thickness > 0.0 => {
            (wall_distance(shape, p).0 < 0.0).then_some(false)
        }
        WallShape::Revolution {
            origin,
            axis,
            r0,
            h0,
            r1,
            h1,
            ..
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
    let chunks: Vec<_> = rows
        .iter()
        .map(|(ids, counts)| (&ids[..], &counts[..]))
        .collect();
    let wall_list = &mut *wall_list;
    (wall_list.start, wall_list.particle, wall_list.walls) = join_rows(&chunks);
    wall_list.built_for = list.builds;
}
