//! Tangential contact with static and dynamic friction (Cundall & Strack 1979; Luding
//! 2005), seed slide "Tangential contact with static / dynamic friction".
use crate::real::{Real, V3};

/// Tangential force on particle i of a contact with unit normal `n` (from j to i),
/// tangential velocity `u_t` of i's surface relative to j's, spring `g` (contact
/// history, updated here to g' for the next step), Coulomb load `normal_load` (>= 0),
/// spring stiffness `c_s` and damping `d_s`, by the seed's table of the Coulomb criteria;
/// see [`capped_spring_dashpot`] with caps mu_s F_n (sticking) and mu_d F_n (sliding).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn coulomb_tangential_force<T: Real>(
    g: &mut V3<T>,
    n: V3<T>,
    u_t: V3<T>,
    normal_load: T,
    [mu_s, mu_d]: [T; 2],
    c_s: T,
    d_s: T,
    dt: T,
) -> V3<T> {
    capped_spring_dashpot(
        g,
        n,
        u_t,
        c_s,
        d_s,
        [mu_s * normal_load, mu_d * normal_load],
        dt,
    )
}

/// A tangent-plane spring-dashpot with a cap (seed, Coulomb criteria):
///
///   g = g' - (g'.n) n + U dt                 (projection into the tangent plane, and
///                                             this step's increment)
///   F_0 = -c g - d U                         (test force)
///   |F_0| <= cap_static:  F = F_0,            g' = g                 (sticking)
///   |F_0| >  cap_static:  F = cap_dynamic t,  g' = -F/c             (sliding)
///
/// with t = F_0 / |F_0| (g' = 0 when c = 0). Returns F and leaves g' in `spring`. Both
/// outcomes are computed and selected per lane.
///
/// The seed's table adds U dt to the spring after the test (in the sticking row only);
/// here the increment comes first, as in Cundall & Strack's incremental scheme and
/// LAMMPS' `granular` history: with the seed's order, a sliding contact without
/// tangential damping never sees its velocity again (the reset spring carries the old
/// direction, and while the normal force falls, as in the rebound half of an impact, the
/// test force stays above the cap), so friction keeps its direction after the slip
/// velocity has reversed. Checked by Chung & Ooi's oblique impacts (tests/chung_ooi.rs).
///
/// On sliding the seed (after Luding 2005) resets the spring to g' = -(F + d U)/c, so
/// that -c g' - d U = F. With damping, that spring holds F + d U, which points along the
/// slip when d |U| > |F|: a contact that stops after sliding would then be pushed on in
/// its old slip direction. Here the spring keeps only the elastic share, g' = -F/c (the
/// force while sliding is the same: F, capped). Checked in tests/friction.rs.
#[inline(always)]
pub fn capped_spring_dashpot<T: Real>(
    spring: &mut V3<T>,
    n: V3<T>,
    u: V3<T>,
    stiffness: T,
    damping: T,
    [cap_static, cap_dynamic]: [T; 2],
    dt: T,
) -> V3<T> {
    let trial = *spring - n.scale(spring.dot(n)) + u.scale(dt);
    let test = -(trial.scale(stiffness) + u.scale(damping));
    let size2 = test.dot(test);
    let threshold = cap_static * cap_static;
    let stick = size2.le(threshold);
    // All lanes sticking (the common case in a resting packing): no division.
    if T::none(threshold.lt(size2)) {
        *spring = trial;
        return test;
    }
    let zero = T::splat(0.0);
    // Sliding lanes have |F_0| > cap_static >= 0: no division by zero is selected.
    let slide = test.scale(cap_dynamic / size2.sqrt());
    let reset = -slide.scale(T::splat(1.0) / stiffness);
    let reset = V3::select(zero.lt(stiffness), reset, V3::zero());
    *spring = V3::select(stick, trial, reset);
    V3::select(stick, test, slide)
}
