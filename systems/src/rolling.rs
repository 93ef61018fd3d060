//! Rolling resistance (Iwashita & Oda 1998; Marshall 2008), seed slide "Rolling
//! resistance", as a spring-dashpot on the integrated rolling displacement capped at
//! M_r,crit = mu_r R* F_n (Ai, Chen, Rotter & Ooi 2011, Powder Technol. 206:269, model
//! type C).
use glam::DVec3;
use grainflow_components::RollingLaw;

use crate::friction::capped_spring_dashpot;

/// Rolling velocity of a contact with unit normal `n` (from j to i):
///
///   U_r = -R* (w_i - w_j) x n - 1/2 ((R_j - R_i)/(R_i + R_j)) U_t
///
/// `radius_ratio` = (R_j - R_i)/(R_i + R_j) (1 against a wall).
#[inline]
pub fn rolling_velocity(
    r_eff: f64,
    relative_spin: DVec3,
    n: DVec3,
    radius_ratio: f64,
    u_t: DVec3,
) -> DVec3 {
    -r_eff * relative_spin.cross(n) - 0.5 * radius_ratio * u_t
}

/// Rolling resistance of a contact, as the force f_r whose moment arm is R*: the torque
/// on i is R* f_r x n, on j its negative (seed: M_r = -c_r (integral of U_r) - d_r U_r,
/// |M_r| <= M_r,crit). The rolling displacement `xi` (contact history) is kept in the
/// tangent plane, grows by U_r dt while |f_r| <= mu_r F_n, and is reset to the cap when
/// the cap is reached (as the tangential spring of the Coulomb criteria). `c_r` is the
/// rolling stiffness in N/m.
#[inline]
pub fn rolling_resistance_force(
    law: &RollingLaw,
    xi: &mut DVec3,
    n: DVec3,
    u_r: DVec3,
    normal_load: f64,
    c_r: f64,
    dt: f64,
) -> DVec3 {
    let cap = law.coefficient * normal_load;
    capped_spring_dashpot(xi, n, u_r, c_r, law.damping, [cap, cap], dt)
}

/// Rolling stiffness c_r in N/m: the law's, or 2.25 mu_r^2 k_n with the normal contact
/// stiffness k_n = 2 E* a (Ai et al. 2011: k_r = 2.25 k_n mu_r^2 R*^2 as a torque per
/// radian, divided by R*^2 for a force per rolling displacement).
#[inline]
pub fn rolling_stiffness(law: &RollingLaw, e_star: f64, a: f64) -> f64 {
    law.stiffness
        .unwrap_or(2.25 * law.coefficient * law.coefficient * 2.0 * e_star * a)
}
