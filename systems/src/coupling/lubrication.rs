//! Lubrication correction between particles closer than the fluid grid resolves.
//!
//! The fictitious domain resolves the squeeze flow between two approaching spheres only
//! while the gap holds a few fluid cells; below about one cell the resolved force
//! levels off while the physical one grows like 1/gap. As resolved-particle codes do
//! (Breugem 2010, Proc. 7th Int. Conf. Multiphase Flow; Kempe & Froehlich 2012, J. Fluid
//! Mech. 709:445), the leading lubrication term is added below a `range` of about one
//! cell, minus its value at the range so that the force is continuous where the grid
//! takes over:
//!
//! `F_i = -6 pi mu R*^2 (1 / max(s, s_r) - 1 / s_c) ((v_i - v_j) . n) n`, `F_j = -F_i`,
//!
//! for surface gaps `s < s_c` (the range), with `n` the unit vector from `i` to `j`,
//! `R* = R_i R_j / (R_i + R_j)` and the roughness `s_r` below which (and in contact) the
//! gap is held at `s_r` so the force stays finite. `6 pi mu R*^2 V / s` is the leading
//! term of the squeeze force of two spheres at relative normal speed `V` (Jeffrey &
//! Onishi 1984, J. Fluid Mech. 139:261, `X^A_11 = g_1 / xi + O(ln xi)` with
//! `g_1 = 2 beta^2 / (1 + beta)^3`, `xi = 2 s / (R_i + R_j)`, `beta = R_j / R_i`): for
//! equal spheres `6 pi mu R^2 V / (4 s)`, against a plane (`R_j -> inf`) `6 pi mu R^2 V / s`.
//!
//! The correction acts on the relative normal motion only (approach and separation
//! alike), in every DEM substep, after the contact forces. It is a viscous damping of
//! rate `6 pi mu R*^2 / (s_r m*)`: `grainflow check` compares the DEM step with it.
use bevy_ecs::prelude::*;
use grainflow_components::{Lubrication, Particles, VerletList};
use rayon::prelude::*;

/// Whether the scene asks for the lubrication correction.
pub fn has_lubrication(w: &World) -> bool {
    w.contains_resource::<Lubrication>()
}

/// The coefficient `c` of the correction `F_i = -c ((v_i - v_j) . n) n` for spheres of
/// radii `ri`, `rj` at surface gap `gap` (module docs): zero at and beyond the range.
pub fn lubrication_coefficient(lub: &Lubrication, ri: f64, rj: f64, gap: f64) -> f64 {
    if gap >= lub.range {
        return 0.0;
    }
    let r_star = ri * rj / (ri + rj);
    6.0 * std::f64::consts::PI
        * lub.viscosity
        * r_star
        * r_star
        * (1.0 / gap.max(lub.roughness) - 1.0 / lub.range)
}

/// The largest damping rate `c / m*` of the correction over the particles (the pair of
/// the two smallest masses at the roughness gap bounds it): an explicit DEM step must
/// stay below about `2 m* / c`.
pub fn largest_damping_rate(lub: &Lubrication, radius: f64, mass: f64) -> f64 {
    let c = lubrication_coefficient(lub, radius, radius, 0.0);
    c / (0.5 * mass)
}

/// `lubrication`: adds the correction of every listed pair closer than the range to the
/// particle forces. Pair forces are computed in parallel and summed in pair order, so the
/// result does not depend on the thread count. The Verlet list holds every pair within
/// `r_i + r_j + skin`, and the build makes the skin at least the range. The pair forces
/// go into a buffer the system keeps between substeps (no allocation per step).
pub fn lubrication(
    lub: Res<Lubrication>,
    list: Res<VerletList>,
    mut particles: ResMut<Particles>,
    mut forces: Local<Vec<(u32, u32, [f64; 3])>>,
) {
    let _span = tracing::info_span!("lubrication").entered();
    let p = &*particles;
    forces.clear();
    forces.par_extend((0..list.pairs()).into_par_iter().filter_map(|k| {
        let (i, j) = (list.owner[k] as usize, list.neighbours[k] as usize);
        let d = [0, 1, 2].map(|a| p.position[a][j] - p.position[a][i]);
        let dist = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let gap = dist - p.radius[i] - p.radius[j];
        let c = lubrication_coefficient(&lub, p.radius[i], p.radius[j], gap);
        if c == 0.0 || dist == 0.0 {
            return None;
        }
        let n = d.map(|x| x / dist);
        let approach: f64 = (0..3)
            .map(|a| (p.velocity[a][i] - p.velocity[a][j]) * n[a])
            .sum();
        Some((i as u32, j as u32, n.map(|x| -c * approach * x)))
    }));
    let force = &mut particles.force;
    for &(i, j, f) in forces.iter() {
        for a in 0..3 {
            force[a][i as usize] += f[a];
            force[a][j as usize] -= f[a];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LUB: Lubrication = Lubrication {
        viscosity: 0.01,
        range: 0.1,
        roughness: 1e-4,
    };

    /// Equal spheres: `6 pi mu R^2 / 4 (1/s - 1/s_c)`; a sphere and a much larger one
    /// tend to the sphere-plane `6 pi mu R^2 (1/s - 1/s_c)`.
    #[test]
    fn coefficient_has_the_leading_lubrication_term() {
        let (r, s) = (0.5, 0.01);
        let equal = lubrication_coefficient(&LUB, r, r, s);
        let expected = 6.0 * std::f64::consts::PI * 0.01 * r * r / 4.0 * (1.0 / s - 1.0 / 0.1);
        assert!(
            (equal / expected - 1.0).abs() < 1e-14,
            "{equal} vs {expected}"
        );
        let plane = lubrication_coefficient(&LUB, r, 1e9, s);
        let expected = 6.0 * std::f64::consts::PI * 0.01 * r * r * (1.0 / s - 1.0 / 0.1);
        assert!(
            (plane / expected - 1.0).abs() < 1e-8,
            "{plane} vs {expected}"
        );
    }

    /// Zero at and beyond the range (continuous there), held at the roughness below it
    /// and in contact.
    #[test]
    fn coefficient_is_continuous_at_the_range_and_finite_in_contact() {
        assert_eq!(lubrication_coefficient(&LUB, 0.5, 0.5, 0.1), 0.0);
        assert_eq!(lubrication_coefficient(&LUB, 0.5, 0.5, 0.3), 0.0);
        let just_inside = lubrication_coefficient(&LUB, 0.5, 0.5, 0.1 - 1e-12);
        assert!(just_inside > 0.0 && just_inside < 1e-9, "{just_inside}");
        let rough = lubrication_coefficient(&LUB, 0.5, 0.5, 1e-4);
        assert_eq!(lubrication_coefficient(&LUB, 0.5, 0.5, 1e-6), rough);
        assert_eq!(lubrication_coefficient(&LUB, 0.5, 0.5, -0.01), rough);
    }
}
