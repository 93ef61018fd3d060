//! Stable time-step estimates for `grainflow check` and run start-up.
use grainflow_components::{Material, Particles};

use crate::scene::{RegionSpec, Scene};

/// Rayleigh time step of a sphere: dt_R = pi R sqrt(rho/G) / (0.1631 nu + 0.8766),
/// G = E / (2 (1 + nu)) (Li, Xu & Thornton 2005; formula as in
/// `shared/reference/contact-benchmarks.md`).
pub fn rayleigh_time_step(radius: f64, m: &Material) -> f64 {
    let g = m.youngs_modulus / (2.0 * (1.0 + m.poisson_ratio));
    std::f64::consts::PI * radius * (m.density / g).sqrt() / (0.1631 * m.poisson_ratio + 0.8766)
}

/// Hertz contact duration of two equal spheres colliding at `speed`:
/// t_c = 2.868 (m*^2 / (R* E*^2 v))^(1/5) (Johnson 1985, sec. 11.4).
pub fn hertz_contact_time(radius: f64, m: &Material, speed: f64) -> f64 {
    let mass = m.density * 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3);
    let (m_eff, r_eff) = (0.5 * mass, 0.5 * radius);
    let e_star = m.youngs_modulus / (2.0 * (1.0 - m.poisson_ratio.powi(2)));
    2.868 * (m_eff * m_eff / (r_eff * e_star * e_star * speed)).powf(0.2)
}

/// The estimates for one scene.
#[derive(Debug, Clone)]
pub struct StepEstimate {
    pub rayleigh: f64,
    pub contact_time: f64,
    pub impact_speed: f64,
    /// dt above this is an error unless the scene allows it: min(0.4 dt_R, t_c / 10).
    pub limit: f64,
    /// dt above this draws a warning: min(0.2 dt_R, t_c / 20).
    pub recommended: f64,
}

/// Estimate over all particle radii and materials present (placed and inflowing). The
/// impact speed is twice (two particles meeting head-on) the largest of the initial and
/// inflow speeds and the free-fall speed sqrt(2 g H) over the scene's height H along
/// gravity (particles, inflow regions, plane and box walls).
pub fn estimate(
    scene: &Scene,
    particles: &Particles,
    materials: &[Material],
) -> Option<StepEstimate> {
    let mut sizes: Vec<(f64, u16)> = Vec::new();
    for i in 0..particles.len() {
        sizes.push((particles.radius[i], particles.material[i]));
    }
    for f in &scene.inflows {
        match (&f.clump, &f.material) {
            // A clump's members, with their material's density: a conservative bound (a
            // member moves with the heavier body).
            (Some(c), _) => {
                let t =
                    &scene.clump_types[crate::clumps::type_index(&scene.clump_types, c).ok()?];
                let m = scene.materials.iter().position(|x| x.name == t.material)? as u16;
                sizes.extend(t.spheres.iter().map(|s| (s.radius, m)));
            }
            (None, Some(material)) => {
                let m = scene.materials.iter().position(|x| &x.name == material)? as u16;
                sizes.extend(f.radii.iter().map(|&r| (r, m)));
            }
            (None, None) => return None,
        }
    }
    if sizes.is_empty() {
        return None;
    }
    let g = scene.simulation.gravity;
    let g_norm = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    let mut speed: f64 = 0.0;
    let mut along = |p: [f64; 3]| {
        if g_norm > 0.0 {
            let h = (p[0] * g[0] + p[1] * g[1] + p[2] * g[2]) / g_norm;
            lo = lo.min(h);
            hi = hi.max(h);
        }
    };
    for i in 0..particles.len() {
        along([
            particles.position[0][i],
            particles.position[1][i],
            particles.position[2][i],
        ]);
        let v2: f64 = (0..3).map(|d| particles.velocity[d][i].powi(2)).sum();
        speed = speed.max(v2.sqrt());
    }
    for f in &scene.inflows {
        match f.region {
            RegionSpec::Box { min, max } => {
                along(min);
                along(max);
            }
            RegionSpec::Cylinder {
                center,
                bottom,
                top,
                ..
            } => {
                along([center[0], center[1], bottom]);
                along([center[0], center[1], top]);
            }
        }
        let v2: f64 = f.velocity.iter().map(|v| v * v).sum();
        speed = speed.max(v2.sqrt() + 3f64.sqrt() * f.velocity_jitter);
    }
    for w in &scene.walls {
        match w {
            crate::scene::WallSpec::Plane { point, .. } => along(*point),
            crate::scene::WallSpec::Box { min, max, .. } => {
                along(*min);
                along(*max);
            }
            _ => {}
        }
    }
    let height = if hi > lo { hi - lo } else { 0.0 };
    // Two particles may meet head-on, each at the largest speed.
    let impact_speed = 2.0 * speed.max((2.0 * g_norm * height).sqrt()).max(1e-3);
    let mut rayleigh = f64::INFINITY;
    let mut contact_time = f64::INFINITY;
    for (r, m) in sizes {
        let mat = &materials[m as usize];
        rayleigh = rayleigh.min(rayleigh_time_step(r, mat));
        contact_time = contact_time.min(hertz_contact_time(r, mat, impact_speed));
    }
    Some(StepEstimate {
        rayleigh,
        contact_time,
        impact_speed,
        limit: (0.4 * rayleigh).min(contact_time / 10.0),
        recommended: (0.2 * rayleigh).min(contact_time / 20.0),
    })
}
