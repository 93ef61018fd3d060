//! Hertz normal contact with damping (Hertz 1896), the seed's slide "Models for DEM": the
//! elastic force c_n delta^(3/2) and the two normal damping laws.
use grainflow_components::PairParams;

use crate::real::Real;

/// Normal damping law of a scene (all pairs share one: mixing laws is rejected at load,
/// so the kernel is compiled once per law and has no branch on it).
pub trait NormalDamping: Sync {
    /// Damping force for the pair's `coefficient`, elastic factor (4/3) E*
    /// `hertz_factor`, contact radius `sqrt_rd` (sqrt(R* delta) for Hertz), 1/m*
    /// `inv_mass_sum`, approach speed `delta_dot`.
    fn damping<T: Real>(
        coefficient: T,
        hertz_factor: T,
        sqrt_rd: T,
        inv_mass_sum: T,
        delta_dot: T,
    ) -> T;
    /// The pair's damping coefficient for this law.
    fn coefficient(p: &PairParams) -> f64;
}

/// F_d = d_n delta_dot with a constant d_n (seed slide "Models for DEM").
pub struct ConstantDamping;

impl NormalDamping for ConstantDamping {
    #[inline(always)]
    fn damping<T: Real>(d_n: T, _: T, _: T, _: T, delta_dot: T) -> T {
        d_n * delta_dot
    }
    fn coefficient(p: &PairParams) -> f64 {
        p.damping_constant
    }
}

/// F_d = -2 sqrt(5/6) beta sqrt(S_n m*) v_n with S_n = 2 E* sqrt(R* delta) =
/// (3/2) hertz_factor sqrt(R* delta) and beta = ln e / sqrt(ln^2 e + pi^2) (Tsuji et al.
/// 1992 form, as in LIGGGHTS and EDEM); with the force not clipped at zero it gives the
/// coefficient of restitution e at any impact speed.
pub struct RestitutionDamping;

impl NormalDamping for RestitutionDamping {
    #[inline(always)]
    fn damping<T: Real>(
        factor: T,
        hertz_factor: T,
        sqrt_rd: T,
        inv_mass_sum: T,
        delta_dot: T,
    ) -> T {
        factor * (T::splat(1.5) * hertz_factor * sqrt_rd / inv_mass_sum).sqrt() * delta_dot
    }
    fn coefficient(p: &PairParams) -> f64 {
        p.restitution_factor
    }
}

/// Normal force (positive = repulsive) of a Hertz contact with overlap `delta`, contact
/// radius `a` = sqrt(R* delta) and approach speed `delta_dot`, seed slide "Models for
/// DEM" (Hertz 1896):
///
///   F = c_n delta^(3/2) + damping,  c_n = (4/3) E* sqrt(R*),  so F = (4/3) E* a delta + ...
///
/// `hertz_factor` = (4/3) E*, `inv_mass_sum` = 1/m_i + 1/m_j = 1/m*.
#[inline(always)]
pub fn hertz_normal_force<T: Real, D: NormalDamping>(
    hertz_factor: T,
    damping: T,
    a: T,
    inv_mass_sum: T,
    delta: T,
    delta_dot: T,
) -> T {
    hertz_factor * a * delta + D::damping(damping, hertz_factor, a, inv_mass_sum, delta_dot)
}
