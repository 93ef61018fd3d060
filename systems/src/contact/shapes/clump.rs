//! Clumps: rigid unions of spheres (multi-sphere particles; Favier et al. 1999, Eng.
//! Comput. 16; LIGGGHTS' multisphere). The members may overlap: the mass properties are
//! those of the union, not the sum of the members.
//!
//! Mass properties: the exact sums over the members (sphere volume, centre, inertia
//! (2/5) m r^2 plus the parallel-axis term) less the integral over the region covered by
//! k > 1 members of (k - 1) times the integrand (volume, first and second moments), which
//! the members counted k times. That integral is taken by the midpoint rule on a lattice
//! over the bounding box of the overlaps (spacing `OVERLAP_CELLS_PER_RADIUS` per smallest
//! overlapping radius): exact for members that do not overlap, and with an error confined
//! to the lens-shaped overlaps otherwise.
use glam::{DMat3, DVec3};
use grainflow_components::ClumpMember;

use grainflow_components::SphereRule;

use super::{sphere::Sphere, MassProperties, ParticleShape, SurfacePoint};

/// Lattice cells per smallest radius of the overlapping members for the overlap integral
/// (tests/clump_mass.rs: two spheres overlapping by half a radius within 1e-4 of the
/// analytic volume and inertia).
const OVERLAP_CELLS_PER_RADIUS: f64 = 96.0;

/// Relative tolerance of "on another member's surface" in [`Clump::surface_points`]:
/// round-off of `|o_k + r_k n_i - o_j|^2` against `r_j^2`.
const SURFACE_TIE: f64 = 1e-12;

/// A union of member spheres (body-frame offsets and radii).
pub struct Clump {
    pub members: Vec<ClumpMember>,
}

impl Clump {
    /// The clump of the `spheres` (offset, radius); at least one, radii positive and the
    /// union connected.
    pub fn from_spheres(spheres: &[([f64; 3], f64)]) -> Result<Box<dyn ParticleShape>, String> {
        if spheres.is_empty() {
            return Err("expected at least one member sphere".into());
        }
        if let Some((k, _)) = spheres
            .iter()
            .enumerate()
            .find(|(_, s)| !(s.1 > 0.0 && s.1.is_finite() && s.0.iter().all(|x| x.is_finite())))
        {
            return Err(format!(
                "member {k}: expected a positive radius and a finite offset"
            ));
        }
        let members: Vec<ClumpMember> = spheres
            .iter()
            .map(|&(o, r)| ClumpMember {
                offset: DVec3::from_array(o),
                radius: r,
            })
            .collect();
        // Connected: every member reachable from the first through touching members.
        let mut reached = vec![false; members.len()];
        let mut stack = vec![0];
        reached[0] = true;
        while let Some(a) = stack.pop() {
            for (b, m) in members.iter().enumerate() {
                let touch = (m.offset - members[a].offset).length() <= m.radius + members[a].radius;
                if !reached[b] && touch {
                    reached[b] = true;
                    stack.push(b);
                }
            }
        }
        if let Some(k) = reached.iter().position(|r| !r) {
            return Err(format!(
                "member {k} touches no other member: expected one connected body"
            ));
        }
        Ok(Box::new(Clump { members }))
    }

    /// How many members hold the point `p`.
    fn cover(&self, p: DVec3) -> usize {
        self.members
            .iter()
            .filter(|m| (p - m.offset).length_squared() < m.radius * m.radius)
            .count()
    }

    /// (volume, first moment, second moment sum p p^T) of the region covered more than
    /// once, each point weighted by its cover less one.
    fn excess_moments(&self) -> (f64, DVec3, DMat3) {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        let mut r_min = f64::INFINITY;
        for (i, a) in self.members.iter().enumerate() {
            for b in &self.members[i + 1..] {
                if (a.offset - b.offset).length() >= a.radius + b.radius {
                    continue;
                }
                // The overlap lies in both spheres' boxes.
                let (alo, ahi) = (a.offset - a.radius, a.offset + a.radius);
                let (blo, bhi) = (b.offset - b.radius, b.offset + b.radius);
                lo = lo.min(alo.max(blo));
                hi = hi.max(ahi.min(bhi));
                r_min = r_min.min(a.radius.min(b.radius));
            }
        }
        if !r_min.is_finite() {
            return (0.0, DVec3::ZERO, DMat3::ZERO);
        }
        let h = r_min / OVERLAP_CELLS_PER_RADIUS;
        let n = ((hi - lo) / h).ceil().max(DVec3::ONE);
        let (nx, ny, nz) = (n.x as usize, n.y as usize, n.z as usize);
        let step = (hi - lo) / n;
        let dv = step.x * step.y * step.z;
        let (mut v, mut first, mut second) = (0.0, DVec3::ZERO, DMat3::ZERO);
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let p = lo + step * DVec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5);
                    let extra = self.cover(p).saturating_sub(1) as f64;
                    if extra > 0.0 {
                        let w = extra * dv;
                        v += w;
                        first += p * w;
                        second += outer(p, p) * w;
                    }
                }
            }
        }
        (v, first, second)
    }
}

/// p q^T.
fn outer(p: DVec3, q: DVec3) -> DMat3 {
    DMat3::from_cols(p * q.x, p * q.y, p * q.z)
}

/// Inertia tensor (unit density) about the origin of a region with second moment
/// `second` = S = integral of p p^T: I = tr(S) 1 - S.
fn inertia_from_second_moment(second: DMat3) -> DMat3 {
    let trace = second.x_axis.x + second.y_axis.y + second.z_axis.z;
    DMat3::from_diagonal(DVec3::splat(trace)) - second
}

impl ParticleShape for Clump {
    fn contact_spheres(&self) -> Vec<ClumpMember> {
        self.members.clone()
    }

    fn mass_properties(&self) -> MassProperties {
        // Members' exact volume, first and second moments, less the overlaps' excess.
        let (mut v, mut first, mut second) = (0.0, DVec3::ZERO, DMat3::ZERO);
        for m in &self.members {
            let s = Sphere { radius: m.radius }.mass_properties();
            v += s.volume;
            first += m.offset * s.volume;
            // A centred sphere's second moment is (r^2/5) V 1 (its inertia (2/5) r^2 V).
            second += DMat3::from_diagonal(DVec3::splat(0.2 * m.radius * m.radius * s.volume))
                + outer(m.offset, m.offset) * s.volume;
        }
        let (ev, efirst, esecond) = self.excess_moments();
        v -= ev;
        first -= efirst;
        second -= esecond;
        let centre = first / v;
        // Second moment about the centre: S_c = S - V c c^T.
        let about_centre = second - outer(centre, centre) * v;
        MassProperties {
            volume: v,
            centre,
            inertia: inertia_from_second_moment(about_centre),
        }
    }

    fn contains(&self, p: DVec3) -> bool {
        self.cover(p) > 0
    }

    /// The largest member depth `max_k (r_k - |p - o_k|)`: outside the union minus the
    /// distance to it (the distance to a union is the smallest distance to a member),
    /// inside the depth below the surface of the member the point lies deepest in, a lower
    /// bound of its depth below the union's surface.
    fn depth(&self, p: DVec3) -> f64 {
        self.members
            .iter()
            .map(|m| m.radius - (p - m.offset).length())
            .fold(f64::NEG_INFINITY, f64::max)
    }

    /// Every member's points of the rule (`x = o_k + r_k n_i`, `a = 4 pi r_k^2 w_i`),
    /// less those inside another member: the union's surface is the part of each member's
    /// sphere outside all the others, so a point there is counted once and the overlap's
    /// buried surface not at all. A point on another member's surface (to a relative
    /// `SURFACE_TIE` in the squared distance) counts as buried only by an earlier member,
    /// so of coinciding members the first keeps its points.
    fn surface_points(&self, rule: &SphereRule) -> Vec<SurfacePoint> {
        let mut points = Vec::new();
        for (k, m) in self.members.iter().enumerate() {
            for p in (Sphere { radius: m.radius }).surface_points(rule) {
                let x = m.offset + p.position;
                let buried = self.members.iter().enumerate().any(|(j, other)| {
                    let (d2, r2) = ((x - other.offset).length_squared(), other.radius.powi(2));
                    j != k
                        && (d2 < r2 * (1.0 - SURFACE_TIE)
                            || (j < k && d2 <= r2 * (1.0 + SURFACE_TIE)))
                });
                if !buried {
                    points.push(SurfacePoint { position: x, ..p });
                }
            }
        }
        points
    }
}
