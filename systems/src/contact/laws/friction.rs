//! Tangential contact with static and dynamic friction (Cundall & Strack 1979; Luding
//! 2005), seed slide "Tangential contact with static / dynamic friction".
use crate::real::{Real, V3};

/// Tangential force on particle i of a contact with unit normal `n` (from j to i),
/// tangential velocity `u_t` of i's surface relative to j's, spring `g` (contact
/// history, updated here to g' for the next step), Coulomb load `normal_load` (>= 0),
/// spring stiffness `c_s` and damping `d_s`, by the seed's table of the Coulomb criteria;
/// see [`capped_spring_dashpot`] with caps mu_s F_n (sticking) and mu_d F_n (sliding).
/// `sliding` (contact history, 1 while the contact slides) makes a sliding contact keep
/// sliding as long as its test force exceeds mu_d F_n: a contact sticks again only when
/// its slip stops or reverses, so with mu_s > mu_d a steady slip feels mu_d (without the
/// flag, the spring reset to mu_d F_n would stick at once and climb back to mu_s F_n: a
/// stick-slip sawtooth of the model, not of the physics; tests/friction.rs).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn coulomb_tangential_force<T: Real>(
    g: &mut V3<T>,
    sliding: &mut T,
    n: V3<T>,
    u_t: V3<T>,
    normal_load: T,
    [mu_s, mu_d]: [T; 2],
    c_s: T,
    d_s: T,
    dt: T,
) -> V3<T> {
    let (cap_static, cap_dynamic) = (mu_s * normal_load, mu_d * normal_load);
    let zero = T::splat(0.0);
    let was_sliding = zero.lt(*sliding);
    let cap = T::select(was_sliding, cap_dynamic, cap_static);
    let (force, stuck) = capped_spring_dashpot(g, n, u_t, c_s, d_s, [cap, cap_dynamic], dt);
    *sliding = T::select(stuck, zero, T::splat(1.0));
    force
}

/// A tangent-plane spring-dashpot with a cap (seed, Coulomb criteria):
///
///   g = g' - (g'.n) n + U dt                 (projection into the tangent plane, and
///                                             this step's increment)
///   F_e = -c g                               (elastic test force)
///   |F_e| <= cap_static:  F = F_e - d U, at most cap_static long;  g' = g   (sticking)
///   |F_e| >  cap_static:  F = cap_dynamic t,  g' = -F/c                    (sliding)
///
/// with t = F_e / |F_e| (g' = 0 when c = 0). Returns F and the lanes that stuck, and
/// leaves g' in `spring`. Both outcomes are computed and selected per lane.
///
/// Three departures from the seed's table, each found by a test:
/// - the increment U dt comes before the test (as in Cundall & Strack's incremental
///   scheme and LAMMPS' `granular` history); the seed adds it after the test, in the
///   sticking row only, so that a sliding contact without damping never sees its velocity
///   again and keeps its friction direction after its slip has reversed (Chung & Ooi's
///   oblique impacts, tests/chung_ooi.rs);
/// - the Coulomb test is on the elastic force, the dashpot acts only while sticking (as
///   in PFC), and the total is capped: with the seed's F_0 = -c g - d U, velocity noise
///   times a large d_s makes lightly loaded contacts of a resting packing slip and lose
///   their spring, and a damped block never comes to rest (tests/friction.rs);
/// - on sliding the spring keeps the elastic share only, g' = -F/c, not the seed's
///   -(F + d U)/c, which holds F + d U: a contact that stops after sliding would be
///   pushed on along its old slip (tests/friction.rs).
#[inline(always)]
pub fn capped_spring_dashpot<T: Real>(
    spring: &mut V3<T>,
    n: V3<T>,
    u: V3<T>,
    stiffness: T,
    damping: T,
    [cap_static, cap_dynamic]: [T; 2],
    dt: T,
) -> (V3<T>, T::Mask) {
    let trial = *spring - n.scale(spring.dot(n)) + u.scale(dt);
    let elastic = -trial.scale(stiffness);
    let total = elastic - u.scale(damping);
    let elastic2 = elastic.dot(elastic);
    let total2 = total.dot(total);
    let threshold = cap_static * cap_static;
    let stick = elastic2.le(threshold);
    // All lanes sticking within the cap (the common case in a resting packing): no
    // division.
    if T::none(threshold.lt(elastic2) | threshold.lt(total2)) {
        *spring = trial;
        return (total, stick);
    }
    let zero = T::splat(0.0);
    // Sliding lanes have |elastic| > cap_static >= 0: no division by zero is selected.
    let slide = elastic.scale(cap_dynamic / elastic2.sqrt());
    let reset = -slide.scale(T::splat(1.0) / stiffness);
    let reset = V3::select(zero.lt(stiffness), reset, V3::zero());
    *spring = V3::select(stick, trial, reset);
    // A sticking spring with its damping above the cap: the force is limited, the spring
    // kept.
    let limited = total.scale(cap_static / total2.sqrt());
    let stuck = V3::select(total2.le(threshold), total, limited);
    (V3::select(stick, stuck, slide), stick)
}
