//! The sphere: one contact sphere, I = (2/5) m r^2 about any axis through its centre.
use glam::{DMat3, DVec3};
use grainflow_components::ClumpMember;

use grainflow_components::SphereRule;

use super::{MassProperties, ParticleShape, SurfacePoint};

/// A sphere of `radius` centred on the body origin.
pub struct Sphere {
    pub radius: f64,
}

impl ParticleShape for Sphere {
    fn bounding_radius(&self) -> f64 {
        self.radius
    }
    fn contact_spheres(&self) -> Vec<ClumpMember> {
        vec![ClumpMember {
            offset: DVec3::ZERO,
            radius: self.radius,
        }]
    }
    fn mass_properties(&self) -> MassProperties {
        let volume = 4.0 / 3.0 * std::f64::consts::PI * self.radius.powi(3);
        MassProperties {
            volume,
            centre: DVec3::ZERO,
            inertia: DMat3::from_diagonal(DVec3::splat(0.4 * volume * self.radius.powi(2))),
        }
    }
    fn contains(&self, p: DVec3) -> bool {
        p.length_squared() < self.radius * self.radius
    }
    /// `r - |p|`, the exact signed distance.
    fn depth(&self, p: DVec3) -> f64 {
        self.radius - p.length()
    }
    /// The rule's points on the sphere: `x_i = r n_i`, `a_i = 4 pi r^2 w_i`.
    fn surface_points(&self, rule: &SphereRule) -> Vec<SurfacePoint> {
        let area = 4.0 * std::f64::consts::PI * self.radius * self.radius;
        rule.direction
            .iter()
            .zip(&rule.weight)
            .map(|(n, w)| {
                let normal = DVec3::from_array(*n);
                SurfacePoint {
                    position: normal * self.radius,
                    normal,
                    area: area * w,
                }
            })
            .collect()
    }
}
