//! Tangential contact with static and dynamic friction (Cundall & Strack 1979; Luding
//! 2005), seed slide "Tangential contact with static / dynamic friction".
use glam::DVec3;
use grainflow_components::{FrictionLaw, TangentialStiffness};

/// Tangential spring stiffness c_s: Mindlin's 8 G* a at contact radius `a`, or constant.
#[inline]
pub fn tangential_stiffness(law: &FrictionLaw, a: f64) -> f64 {
    match law.stiffness {
        TangentialStiffness::Mindlin(eight_g) => eight_g * a,
        TangentialStiffness::Constant(c_s) => c_s,
    }
}

/// Tangential force on particle i of a contact with unit normal `n` (from j to i),
/// tangential velocity `u_t` of i's surface relative to j's, spring `g` (contact
/// history, updated here to g' for the next step), Coulomb load `normal_load` (>= 0)
/// and spring stiffness `c_s`, by the seed's table of the Coulomb criteria; see
/// [`capped_spring_dashpot`] with caps mu_s F_n (sticking) and mu_d F_n (sliding).
#[inline]
pub fn coulomb_tangential_force(
    law: &FrictionLaw,
    g: &mut DVec3,
    n: DVec3,
    u_t: DVec3,
    normal_load: f64,
    c_s: f64,
    dt: f64,
) -> DVec3 {
    capped_spring_dashpot(
        g,
        n,
        u_t,
        c_s,
        law.damping,
        [law.static_coefficient, law.dynamic_coefficient].map(|mu| mu * normal_load),
        dt,
    )
}

/// A tangent-plane spring-dashpot with a cap (seed, Coulomb criteria):
///
///   g = g' - (g'.n) n                        (projection into the tangent plane)
///   F_0 = -c g - d U                         (test force)
///   |F_0| <= cap_static:  F = F_0,            g' = g + U dt      (sticking)
///   |F_0| >  cap_static:  F = cap_dynamic t,  g' = -(F + d U)/c  (sliding)
///
/// with t = F_0 / |F_0|. Returns F and leaves g' in `spring`.
#[inline]
pub fn capped_spring_dashpot(
    spring: &mut DVec3,
    n: DVec3,
    u: DVec3,
    stiffness: f64,
    damping: f64,
    [cap_static, cap_dynamic]: [f64; 2],
    dt: f64,
) -> DVec3 {
    let projected = *spring - spring.dot(n) * n;
    let test = -stiffness * projected - damping * u;
    let size = test.length();
    if size <= cap_static {
        *spring = projected + u * dt;
        test
    } else {
        let f = (cap_dynamic / size) * test;
        *spring = if stiffness > 0.0 {
            -(f + damping * u) / stiffness
        } else {
            DVec3::ZERO
        };
        f
    }
}
