//! JKR adhesion (Johnson, Kendall & Roberts 1971), seed slides "Normal contact with
//! adhesion: JKR contact model", in the normalised form of the seed:
//!
//!   a0 = (6 pi W R^2 / K)^(1/3), K = 4/3 E*   (zero-load contact radius)
//!   F_s = 3/2 pi R W                          (pull-off force under load control)
//!   F / F_s = 4 (a/a0)^3 - 4 (a/a0)^(3/2)     (force against contact radius)
//!   delta / delta_s = 6^(1/3) [2 (a/a0)^2 - 4/3 (a/a0)^(1/2)]
//!   delta_s = a0^2 / (2 6^(1/3) R)            (critical separation)
//!
//! with R = R* and E = E*, 1/E* = (1-nu_i^2)/E_i + (1-nu_j^2)/E_j. (The seed prints the
//! displacement relation with (a/a0)^3 and E with 1 - nu: both are misprints; the forms
//! above equal F = 4 E* a^3/(3R) - sqrt(8 pi W E* a^3), delta = a^2/R - sqrt(2 pi W a/E*),
//! Johnson, Contact Mechanics, 1985, eq. 5.61.) A contact forms when the surfaces touch
//! (delta = 0) and breaks at delta = -delta_s, where a = a0/36^(1/3) and
//! F = -5/9 F_s: the hysteresis of the model.
use std::f64::consts::PI;

use crate::real::Real;

/// Newton steps of [`jkr_contact_radius`]: from its start (within a factor 2 of the
/// root, from above) the error ratio falls as q -> (q^2 + 1)/(2q) at worst: below
/// 1 + 1e-15 in 6 steps; 8 leave a margin.
const NEWTON_STEPS: usize = 8;

/// Contact radius a on the stable branch (a >= a0/36^(1/3)) for the overlap `delta`
/// (>= -delta_s; below, the branch point), lane by lane, from a0 and delta_s.
///
/// With y = (a/a0)^(1/2) the displacement relation reads p(y) = 2 y^4 - 4/3 y =
/// delta / (6^(1/3) delta_s) =: t, stable for y >= y_b = 6^(-1/3), where p'(y_b) = 0 and
/// t_b = p(y_b) = -6^(-1/3) (delta = -delta_s). Newton's method on p converges only
/// linearly at that double root; instead, with y = y_b + s, the Taylor series of p about
/// y_b ends at the fourth term, p(y) - t_b = s^2 h(s), h(s) = 12 y_b^2 + 8 y_b s + 2 s^2,
/// so s solves g(s) = s sqrt(h(s)) = sqrt(t - t_b), with g increasing, convex and
/// g'(0) = sqrt(12) y_b > 0: Newton converges quadratically everywhere, monotonically
/// from above. Both sqrt(12) y_b s <= g(s) and sqrt(2) s^2 <= g(s), so the smaller of
/// the two bounds they give lies above the root, within a factor 2 of it.
#[inline(always)]
pub fn jkr_contact_radius<T: Real>(a0: T, delta_s: T, delta: T) -> T {
    let zero = T::splat(0.0);
    let yb = 6f64.powf(-1.0 / 3.0);
    let t = delta / (T::splat(6f64.cbrt()) * delta_s);
    let sigma = (t + T::splat(yb)).max(zero).sqrt();
    let linear_bound = sigma / T::splat(12f64.sqrt() * yb);
    let quadratic_bound = (sigma / T::splat(2f64.sqrt())).sqrt();
    let mut s = T::select(
        linear_bound.lt(quadratic_bound),
        linear_bound,
        quadratic_bound,
    );
    let (c2, c1) = (T::splat(12.0 * yb * yb), T::splat(8.0 * yb));
    for _ in 0..NEWTON_STEPS {
        let root_h = (c2 + c1 * s + T::splat(2.0) * s * s).sqrt();
        let slope = root_h + s * (c1 + T::splat(4.0) * s) / (T::splat(2.0) * root_h);
        s = (s - (s * root_h - sigma) / slope).max(zero);
    }
    let y = T::splat(yb) + s;
    a0 * y * y
}

/// Elastic JKR force (positive = repulsive) at contact radius `a`:
/// F = F_s (4 (a/a0)^3 - 4 (a/a0)^(3/2)).
#[inline(always)]
pub fn jkr_force_at_radius<T: Real>(a0: T, pull_off: T, a: T) -> T {
    let x = a / a0;
    pull_off * T::splat(4.0) * (x * x * x - x * x.sqrt())
}

/// a0 = (9 pi W R*^2 / (2 E*))^(1/3), lane by lane.
#[inline(always)]
pub fn jkr_equilibrium_radius<T: Real>(e_star: T, r_eff: T, work: T) -> T {
    (T::splat(4.5 * PI) * work * r_eff * r_eff / e_star).map(f64::cbrt)
}

/// delta_s = a0^2 / (2 6^(1/3) R*).
#[inline(always)]
pub fn jkr_critical_separation<T: Real>(a0: T, r_eff: T) -> T {
    a0 * a0 / (T::splat(2.0 * 6f64.cbrt()) * r_eff)
}

/// The JKR relations of one contact: E*, R* and the work of adhesion W (J/m^2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Jkr {
    pub e_star: f64,
    pub r_eff: f64,
    pub work: f64,
}

impl Jkr {
    /// a0 = (9 pi W R*^2 / (2 E*))^(1/3), the contact radius at zero load.
    pub fn equilibrium_radius(&self) -> f64 {
        jkr_equilibrium_radius(self.e_star, self.r_eff, self.work)
    }

    /// F_s = 3/2 pi W R*, the largest tension the contact bears under load control.
    pub fn pull_off_force(&self) -> f64 {
        1.5 * PI * self.work * self.r_eff
    }

    /// delta_s = a0^2 / (2 6^(1/3) R*): the contact breaks at overlap -delta_s.
    pub fn critical_separation(&self) -> f64 {
        jkr_critical_separation(self.equilibrium_radius(), self.r_eff)
    }

    /// Contact radius on the stable branch at overlap `delta` ([`jkr_contact_radius`]).
    pub fn contact_radius(&self, delta: f64) -> f64 {
        jkr_contact_radius(self.equilibrium_radius(), self.critical_separation(), delta)
    }

    /// Elastic JKR force at contact radius `a` ([`jkr_force_at_radius`]).
    pub fn force_at_radius(&self, a: f64) -> f64 {
        jkr_force_at_radius(self.equilibrium_radius(), self.pull_off_force(), a)
    }

    /// Elastic JKR force at overlap `delta` (>= -delta_s), on the stable branch.
    pub fn elastic_force(&self, delta: f64) -> f64 {
        self.force_at_radius(self.contact_radius(delta))
    }
}
