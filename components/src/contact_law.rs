use bevy_ecs::prelude::Resource;

/// Tangential spring stiffness c_s of a material pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TangentialStiffness {
    /// Mindlin (1949) no-slip stiffness c_s = 8 G* a, a the contact radius, with
    /// 1/G* = (2 - nu_i)/G_i + (2 - nu_j)/G_j; the value held is 8 G*.
    Mindlin(f64),
    /// A constant c_s, N/m.
    Constant(f64),
}

/// Coulomb friction with a tangential spring (Cundall & Strack 1979; Luding 2005), seed
/// slide "Tangential contact with static / dynamic friction".
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrictionLaw {
    /// Static coefficient mu_s.
    pub static_coefficient: f64,
    /// Dynamic coefficient mu_d.
    pub dynamic_coefficient: f64,
    pub stiffness: TangentialStiffness,
    /// Tangential damping d_s, N s/m.
    pub damping: f64,
}

/// Rolling resistance (Iwashita & Oda 1998; Marshall 2008), seed slide "Rolling
/// resistance": a spring-dashpot on the integrated rolling displacement, capped at
/// M_r,crit = mu_r R* F_n (Ai, Chen, Rotter & Ooi 2011, model type C).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RollingLaw {
    /// Rolling friction coefficient mu_r.
    pub coefficient: f64,
    /// Rolling stiffness c_r in N/m; `None`: 2.25 mu_r^2 k_n with k_n = 2 E* a (Ai et al.
    /// 2011, their k_r = 2.25 k_n mu_r^2 R*^2 as a torque stiffness).
    pub stiffness: Option<f64>,
    /// Rolling damping d_r, N s/m.
    pub damping: f64,
}

/// JKR adhesion (Johnson, Kendall & Roberts 1971) with the work of adhesion W, J/m^2.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdhesionLaw {
    pub work: f64,
}

/// The contact models of one material pair beyond frictionless Hertz; `None`: model off.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ContactLaw {
    pub friction: Option<FrictionLaw>,
    pub rolling: Option<RollingLaw>,
    pub adhesion: Option<AdhesionLaw>,
}

/// Where each model keeps its per-contact history in a row of [`crate::ContactHistory`]
/// (and of [`WallHistory`]): the tangential spring g (3 values), the sliding flag (1
/// value, 1 while the contact slides; kept only when some pair's dynamic friction
/// coefficient differs from its static one, since with mu_d = mu_s the flag changes no
/// force), the rolling displacement (3 values), the JKR contact flag (1 value: 1 while
/// the contact holds).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct HistoryLayout {
    pub spring: Option<usize>,
    pub sliding: Option<usize>,
    pub rolling: Option<usize>,
    pub bond: Option<usize>,
    pub width: usize,
}

impl HistoryLayout {
    /// The layout for the models that some pair of `laws` uses.
    pub fn for_laws(laws: &[ContactLaw]) -> Self {
        let mut layout = Self::default();
        let mut take = |used: bool, n: usize| {
            used.then(|| {
                layout.width += n;
                layout.width - n
            })
        };
        let spring = take(laws.iter().any(|l| l.friction.is_some()), 3);
        let two_coefficients = laws.iter().any(|l| {
            l.friction
                .is_some_and(|f| f.dynamic_coefficient != f.static_coefficient)
        });
        let sliding = take(two_coefficients, 1);
        let rolling = take(laws.iter().any(|l| l.rolling.is_some()), 3);
        let bond = take(laws.iter().any(|l| l.adhesion.is_some()), 1);
        Self {
            spring,
            sliding,
            rolling,
            bond,
            width: layout.width,
        }
    }
}

/// Pair table of contact laws (row-major over materials, like [`crate::Materials`]);
/// present only when some pair uses friction, rolling resistance or adhesion.
#[derive(Resource, Debug, Clone, Default)]
pub struct ContactLaws {
    pub materials: usize,
    pub pairs: Vec<ContactLaw>,
    pub layout: HistoryLayout,
}

impl ContactLaws {
    #[inline(always)]
    pub fn pair(&self, a: u16, b: u16) -> &ContactLaw {
        &self.pairs[a as usize * self.materials + b as usize]
    }
    /// Whether any pair produces torques (friction or rolling resistance).
    pub fn has_torques(&self) -> bool {
        self.layout.spring.is_some() || self.layout.rolling.is_some()
    }
}

/// History of particle-wall contacts, aligned with the entries of [`crate::WallList`]:
/// entry `k` owns `values[k * width..(k + 1) * width]`, in the layout of
/// [`ContactLaws::layout`]. Carried over, keyed by (stable id, wall), when the wall list
/// is rebuilt.
#[derive(Resource, Debug, Clone, Default)]
pub struct WallHistory {
    pub width: usize,
    pub values: Vec<f64>,
    /// The wall list the values are aligned with: stable id of each row, the rows' entry
    /// ranges and walls, and `WallList::built_for` (`None` before the first build).
    pub ids: Vec<u32>,
    pub start: Vec<u32>,
    pub walls: Vec<u16>,
    pub built_for: Option<u64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn friction(static_coefficient: f64, dynamic_coefficient: f64) -> ContactLaw {
        ContactLaw {
            friction: Some(FrictionLaw {
                static_coefficient,
                dynamic_coefficient,
                stiffness: TangentialStiffness::Constant(1.0),
                damping: 0.0,
            }),
            ..Default::default()
        }
    }

    /// The sliding flag only changes a force when mu_d differs from mu_s: it is kept then
    /// (after the spring), and not otherwise; the other models follow in order.
    #[test]
    fn sliding_flag_only_with_two_friction_coefficients() {
        let rolling = ContactLaw {
            rolling: Some(RollingLaw {
                coefficient: 0.1,
                stiffness: None,
                damping: 0.0,
            }),
            ..friction(0.5, 0.5)
        };
        let one = HistoryLayout::for_laws(&[rolling]);
        assert_eq!(
            (one.spring, one.sliding, one.rolling, one.width),
            (Some(0), None, Some(3), 6)
        );
        let two = HistoryLayout::for_laws(&[rolling, friction(0.5, 0.4)]);
        assert_eq!(
            (two.spring, two.sliding, two.rolling, two.width),
            (Some(0), Some(3), Some(4), 7)
        );
    }
}
