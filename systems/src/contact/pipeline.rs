//! The contact pipeline, written once over [`Real`] (lanes of contacts or one contact):
//! the narrow phase gives each contact's [`Geometry`] (a sphere pair in `with_history`, a
//! sphere against a wall in `wall_pass`); [`interact`] applies the laws of its material
//! pair (`laws/`: Hertz with its damping law, JKR adhesion, Coulomb friction, rolling
//! resistance; a law a pair lacks has zero coefficients, and a law no pair has is
//! compiled out by the [`HistoryLayout`]); the passes then accumulate what it
//! [`Exerted`] in a fixed order. A frictionless scene runs the same pipeline with the
//! empty layout: Hertz with damping only, no history.
use grainflow_components::{
    ContactLaw, ContactLaws, HistoryLayout, Materials, TangentialStiffness,
};
use wide::f64x4;

use crate::contact::laws::friction::coulomb_tangential_force;
use crate::contact::laws::hertz::{hertz_normal_force, NormalDamping};
use crate::contact::laws::jkr::{
    jkr_contact_radius, jkr_critical_separation, jkr_equilibrium_radius, jkr_force_at_radius,
};
use crate::contact::laws::rolling::{rolling_resistance_force, rolling_velocity};
use crate::real::{gather, Real, V3};

/// The laws of every material pair of a scene as the passes use them, with the history
/// layout and the time step of the history models.
pub(crate) struct Laws {
    table: Vec<Coefficients<f64>>,
    /// The coefficients in lanes when there is one material.
    one: Option<Coefficients<f64x4>>,
    materials: usize,
    pub layout: HistoryLayout,
    pub dt: f64,
}

impl Laws {
    /// The table for damping law `D`; `laws`: `None` in a frictionless scene.
    pub fn new<D: NormalDamping>(
        materials: &Materials,
        laws: Option<&ContactLaws>,
        dt: f64,
    ) -> Self {
        let m = materials.list.len();
        let table: Vec<Coefficients<f64>> = (0..m * m)
            .map(|k| Coefficients::of_pair::<D>(materials, laws, (k / m) as u16, (k % m) as u16))
            .collect();
        Self {
            one: (m == 1).then(|| Coefficients::splat(&table[0])),
            table,
            materials: m,
            layout: laws.map_or(HistoryLayout::default(), |l| l.layout),
            dt,
        }
    }

    #[inline(always)]
    fn pair(&self, a: u16, b: u16) -> &Coefficients<f64> {
        &self.table[a as usize * self.materials + b as usize]
    }

    /// The coefficients of four contacts in lanes, lane `l` of material pair `pair(l)`;
    /// with one material, the kept lanes (`scratch` is not used).
    #[inline(always)]
    pub fn lanes<'s>(
        &'s self,
        pair: impl Fn(usize) -> (u16, u16),
        scratch: &'s mut Option<Coefficients<f64x4>>,
    ) -> &'s Coefficients<f64x4> {
        match &self.one {
            Some(c) => c,
            None => {
                let refs = [0, 1, 2, 3].map(|l| {
                    let (a, b) = pair(l);
                    self.pair(a, b)
                });
                scratch.insert(Coefficients::gather(&refs, |l| l))
            }
        }
    }

    /// Whether some law needs the spins (friction or rolling resistance).
    #[inline(always)]
    pub fn spins(&self) -> bool {
        self.layout.spring.is_some() || self.layout.rolling.is_some()
    }
}

/// Three columns gathered at the rows `js`, as lanes.
#[inline(always)]
pub(crate) fn gather3(cols: &[&[f64]; 3], js: &[usize; 4]) -> V3<f64x4> {
    V3::new(
        gather(cols[0], js),
        gather(cols[1], js),
        gather(cols[2], js),
    )
}

/// The numbers of one material pair's laws, as the kernel uses them (lanes of pairs, or
/// one pair). A model a pair lacks has zero coefficients: friction and rolling with a
/// zero cap exert nothing, and W = 0 selects Hertz.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Coefficients<T> {
    /// (4/3) E* and the normal damping coefficient of the damping law.
    hertz_factor: T,
    damping: T,
    mu_s: T,
    mu_d: T,
    /// c_s = stiffness_per_radius a + stiffness (Mindlin 8 G* a, or constant).
    tangential_per_radius: T,
    tangential_constant: T,
    tangential_damping: T,
    mu_r: T,
    /// c_r = rolling_per_radius a + rolling_constant (2.25 mu_r^2 2 E* a by default).
    rolling_per_radius: T,
    rolling_constant: T,
    rolling_damping: T,
    work: T,
}

impl Coefficients<f64> {
    /// Pair (a, b): its Hertz and damping numbers, and those of its laws (`None`: a
    /// frictionless scene, Hertz with damping only).
    fn of_pair<D: NormalDamping>(
        materials: &Materials,
        laws: Option<&ContactLaws>,
        a: u16,
        b: u16,
    ) -> Self {
        let p = materials.pair(a, b);
        let law = laws.map_or(ContactLaw::default(), |l| *l.pair(a, b));
        let e_star = 0.75 * p.hertz_factor;
        let (mu_s, mu_d, kt_a, kt_c, d_s) = law.friction.map_or((0.0, 0.0, 0.0, 0.0, 0.0), |f| {
            let (per_a, constant) = match f.stiffness {
                TangentialStiffness::Mindlin(eight_g) => (eight_g, 0.0),
                TangentialStiffness::Constant(c) => (0.0, c),
            };
            (
                f.static_coefficient,
                f.dynamic_coefficient,
                per_a,
                constant,
                f.damping,
            )
        });
        let (mu_r, kr_a, kr_c, d_r) = law.rolling.map_or((0.0, 0.0, 0.0, 0.0), |r| {
            let (per_a, constant) = match r.stiffness {
                Some(c) => (0.0, c),
                None => (2.25 * r.coefficient * r.coefficient * 2.0 * e_star, 0.0),
            };
            (r.coefficient, per_a, constant, r.damping)
        });
        Self {
            hertz_factor: p.hertz_factor,
            damping: D::coefficient(p),
            mu_s,
            mu_d,
            tangential_per_radius: kt_a,
            tangential_constant: kt_c,
            tangential_damping: d_s,
            mu_r,
            rolling_per_radius: kr_a,
            rolling_constant: kr_c,
            rolling_damping: d_r,
            work: law.adhesion.map_or(0.0, |a| a.work),
        }
    }
}

impl<T: Real> Coefficients<T> {
    fn splat(c: &Coefficients<f64>) -> Self {
        Self::gather(&[c], |_| 0)
    }
    /// Lane `l` from `table[index(l)]`.
    #[inline(always)]
    fn gather(table: &[&Coefficients<f64>], index: impl Fn(usize) -> usize) -> Self {
        let lane = |f: fn(&Coefficients<f64>) -> f64| T::from_lanes(|l| f(table[index(l)]));
        Self {
            hertz_factor: lane(|c| c.hertz_factor),
            damping: lane(|c| c.damping),
            mu_s: lane(|c| c.mu_s),
            mu_d: lane(|c| c.mu_d),
            tangential_per_radius: lane(|c| c.tangential_per_radius),
            tangential_constant: lane(|c| c.tangential_constant),
            tangential_damping: lane(|c| c.tangential_damping),
            mu_r: lane(|c| c.mu_r),
            rolling_per_radius: lane(|c| c.rolling_per_radius),
            rolling_constant: lane(|c| c.rolling_constant),
            rolling_damping: lane(|c| c.rolling_damping),
            work: lane(|c| c.work),
        }
    }
}

/// Contacts seen from particle i: unit normal `n` from j (or the wall) to i, overlap,
/// R*, (R_j - R_i)/(R_i + R_j), 1/m*, velocity of i relative to j, the surface term
/// R_i n x w_i + R_j n x w_j of the relative contact velocity, and w_i - w_j.
pub(crate) struct Geometry<T> {
    pub n: V3<T>,
    pub delta: T,
    pub r_eff: T,
    pub radius_ratio: T,
    pub inv_mass_sum: T,
    pub velocity: V3<T>,
    pub surface: V3<T>,
    pub spin: V3<T>,
}

/// Per-contact history in lanes: tangential spring and sliding flag, rolling
/// displacement, JKR flag.
#[derive(Clone, Copy)]
pub(crate) struct History<T> {
    spring: V3<T>,
    sliding: T,
    pub rolling: V3<T>,
    pub bond: T,
}

/// What contacts exert, zero in lanes out of contact: force on i, tangential force F_t,
/// rolling resistance f_r (the torque on i is -R_i n x F_t + R* f_r x n).
pub(crate) struct Exerted<T: Real> {
    pub touching: T::Mask,
    pub force: V3<T>,
    pub tangential: V3<T>,
    pub rolling: V3<T>,
}

/// The models of a contact (lanes of contacts), seen from particle i (the row owner of a
/// pair, or the particle of a wall contact): `hist` is updated in place, its tangential
/// spring directed from i (the contact store keeps it so, see `ContactHistory`); lanes out
/// of contact get zero history.
#[inline(always)]
pub(crate) fn interact<T: Real, D: NormalDamping>(
    c: &Coefficients<T>,
    layout: &HistoryLayout,
    hist: &mut History<T>,
    g: &Geometry<T>,
    dt: T,
) -> Exerted<T> {
    let zero = T::splat(0.0);
    let mut touching = zero.lt(g.delta);
    let delta_dot = -g.velocity.dot(g.n);
    // Hertz: c_n delta^(3/2) + damping, with the contact radius a = sqrt(R* delta).
    let mut a = (g.r_eff * g.delta.max(zero)).sqrt();
    let mut f_n = hertz_normal_force::<T, D>(
        c.hertz_factor,
        c.damping,
        a,
        g.inv_mass_sum,
        g.delta,
        delta_dot,
    );
    let mut load_offset = zero;
    let mut bonded = touching;
    if layout.bond.is_some() {
        let adhesive = zero.lt(c.work);
        // Lanes without adhesion get a dummy W (their result is not selected).
        let work = T::select(adhesive, c.work, T::splat(1.0));
        let e_star = T::splat(0.75) * c.hertz_factor;
        let a0 = jkr_equilibrium_radius(e_star, g.r_eff, work);
        let delta_s = jkr_critical_separation(a0, g.r_eff);
        let holds = zero.le(g.delta) | (zero.lt(hist.bond) & (-delta_s).lt(g.delta));
        bonded = adhesive & holds;
        touching = touching | bonded;
        // JKR: the JKR force at its contact radius plus the same damping.
        let a_jkr = jkr_contact_radius(a0, delta_s, g.delta);
        let pull_off = T::splat(1.5 * std::f64::consts::PI) * work * g.r_eff;
        let f_jkr = jkr_force_at_radius(a0, pull_off, a_jkr)
            + D::damping(c.damping, c.hertz_factor, a_jkr, g.inv_mass_sum, delta_dot);
        a = T::select(adhesive, a_jkr, a);
        f_n = T::select(adhesive, f_jkr, f_n);
        // Thornton & Yin (1991): the Coulomb limit of an adhesive contact is
        // mu (F_n + 2 F_s).
        load_offset = T::select(adhesive, T::splat(2.0) * pull_off, zero);
    }
    let load = (f_n + load_offset).max(zero);
    let relative = g.velocity + g.surface;
    let u_t = relative - g.n.scale(relative.dot(g.n));
    let mut tangential = V3::zero();
    if layout.spring.is_some() {
        let mut spring = hist.spring;
        let c_s = c.tangential_per_radius * a + c.tangential_constant;
        let mut sliding = hist.sliding;
        tangential = coulomb_tangential_force(
            &mut spring,
            &mut sliding,
            g.n,
            u_t,
            load,
            [c.mu_s, c.mu_d],
            c_s,
            c.tangential_damping,
            dt,
        );
        hist.spring = V3::select(touching, spring, V3::zero());
        hist.sliding = T::select(touching, sliding, zero);
    }
    let mut rolling = V3::zero();
    if layout.rolling.is_some() {
        let mut xi = hist.rolling;
        let u_r = rolling_velocity(g.r_eff, g.spin, g.n, g.radius_ratio, u_t);
        let c_r = c.rolling_per_radius * a + c.rolling_constant;
        rolling =
            rolling_resistance_force(&mut xi, g.n, u_r, load, c.mu_r, c_r, c.rolling_damping, dt);
        hist.rolling = V3::select(touching, xi, V3::zero());
    }
    hist.bond = T::select(bonded, T::splat(1.0), zero);
    // Without friction nothing is added to the normal force (not even a zero).
    let normal = g.n.scale(f_n);
    let normal = if layout.spring.is_some() {
        normal + tangential
    } else {
        normal
    };
    Exerted {
        touching,
        force: V3::select(touching, normal, V3::zero()),
        tangential: V3::select(touching, tangential, V3::zero()),
        rolling: V3::select(touching, rolling, V3::zero()),
    }
}

impl<T: Real> History<T> {
    /// The history from `value(c)`, the lanes of its component `c` in the layout.
    #[inline(always)]
    pub(crate) fn load(layout: &HistoryLayout, value: impl Fn(usize) -> T) -> Self {
        let v3 = |o: Option<usize>| {
            o.map_or(V3::zero(), |o| {
                V3::new(value(o), value(o + 1), value(o + 2))
            })
        };
        Self {
            spring: v3(layout.spring),
            sliding: layout.sliding.map_or(T::splat(0.0), &value),
            rolling: v3(layout.rolling),
            bond: layout.bond.map_or(T::splat(0.0), &value),
        }
    }

    /// Hand every component `c` of the layout to `put(c, lanes)`.
    #[inline(always)]
    pub(crate) fn store(&self, layout: &HistoryLayout, mut put: impl FnMut(usize, T)) {
        for (o, v) in [(layout.spring, self.spring), (layout.rolling, self.rolling)] {
            if let Some(o) = o {
                put(o, v.x);
                put(o + 1, v.y);
                put(o + 2, v.z);
            }
        }
        if let Some(o) = layout.sliding {
            put(o, self.sliding);
        }
        if let Some(o) = layout.bond {
            put(o, self.bond);
        }
    }
}
