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
        (4.5 * PI * self.work * self.r_eff * self.r_eff / self.e_star).cbrt()
    }

    /// F_s = 3/2 pi W R*, the largest tension the contact bears under load control.
    pub fn pull_off_force(&self) -> f64 {
        1.5 * PI * self.work * self.r_eff
    }

    /// delta_s = a0^2 / (2 6^(1/3) R*): the contact breaks at overlap -delta_s.
    pub fn critical_separation(&self) -> f64 {
        let a0 = self.equilibrium_radius();
        a0 * a0 / (2.0 * 6f64.cbrt() * self.r_eff)
    }

    /// Contact radius a on the stable branch (a >= a0/36^(1/3)) for the overlap `delta`
    /// (>= -delta_s; above -delta_s only by round-off it returns the branch point).
    ///
    /// With y = (a/a0)^(1/2) the displacement relation reads p(y) = 2 y^4 - 4/3 y =
    /// delta / (6^(1/3) delta_s) =: t. p is convex and increasing on the stable branch
    /// y >= y_b = 6^(-1/3), so Newton's method started right of the root converges
    /// monotonically from above and never crosses the branch point; the start
    /// y = 1 + (max(t, 0)/2)^(1/4) lies right of the root for every t.
    pub fn contact_radius(&self, delta: f64) -> f64 {
        let a0 = self.equilibrium_radius();
        let t = delta / (6f64.cbrt() * self.critical_separation());
        let y_branch = 6f64.powf(-1.0 / 3.0);
        if t <= -1.0 / 6f64.cbrt() {
            return a0 * y_branch * y_branch;
        }
        let mut y = 1.0 + (t.max(0.0) / 2.0).sqrt().sqrt();
        for _ in 0..60 {
            let y3 = y * y * y;
            let p = 2.0 * y3 * y - 4.0 / 3.0 * y - t;
            let step = p / (8.0 * y3 - 4.0 / 3.0);
            let next = (y - step).max(y_branch);
            if next >= y || y - next <= 1e-15 * y {
                y = next;
                break;
            }
            y = next;
        }
        a0 * y * y
    }

    /// Elastic JKR force (positive = repulsive) at contact radius `a`:
    /// F = F_s (4 (a/a0)^3 - 4 (a/a0)^(3/2)).
    pub fn force_at_radius(&self, a: f64) -> f64 {
        let x = a / self.equilibrium_radius();
        self.pull_off_force() * 4.0 * (x * x * x - x * x.sqrt())
    }

    /// Elastic JKR force at overlap `delta` (>= -delta_s), on the stable branch.
    pub fn elastic_force(&self, delta: f64) -> f64 {
        self.force_at_radius(self.contact_radius(delta))
    }
}
