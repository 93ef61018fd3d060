//! Rolling resistance (Iwashita & Oda 1998; Marshall 2008), seed slide "Rolling
//! resistance", as a spring-dashpot on the integrated rolling displacement capped at
//! M_r,crit = mu_r R* F_n (Ai, Chen, Rotter & Ooi 2011, Powder Technol. 206:269, model
//! type C).
use crate::contact::laws::friction::capped_spring_dashpot;
use crate::real::{Real, V3};

/// Rolling velocity of a contact with unit normal `n` (from j to i):
///
///   U_r = -R* (w_i - w_j) x n - 1/2 ((R_j - R_i)/(R_i + R_j)) U_t
///
/// `radius_ratio` = (R_j - R_i)/(R_i + R_j) (1 against a wall). U_r is the same for both
/// orientations of the pair.
#[inline(always)]
pub fn rolling_velocity<T: Real>(
    r_eff: T,
    relative_spin: V3<T>,
    n: V3<T>,
    radius_ratio: T,
    u_t: V3<T>,
) -> V3<T> {
    -(relative_spin.cross(n).scale(r_eff) + u_t.scale(T::splat(0.5) * radius_ratio))
}

/// Rolling resistance of a contact, as the force f_r whose moment arm is R*: the torque
/// on i is R* f_r x n, on j its negative (seed: M_r = -c_r (integral of U_r) - d_r U_r,
/// |M_r| <= M_r,crit = mu_r R* F_n). The rolling displacement `xi` (contact history) is
/// kept in the tangent plane, grows by U_r dt while |f_r| <= mu_r F_n, and is reset to
/// the cap when the cap is reached, as the tangential spring of the Coulomb criteria.
/// `c_r` is the rolling stiffness in N/m, `d_r` the rolling damping in N s/m.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn rolling_resistance_force<T: Real>(
    xi: &mut V3<T>,
    n: V3<T>,
    u_r: V3<T>,
    normal_load: T,
    mu_r: T,
    c_r: T,
    d_r: T,
    dt: T,
) -> V3<T> {
    let cap = mu_r * normal_load;
    capped_spring_dashpot(xi, n, u_r, c_r, d_r, [cap, cap], dt).0
}
