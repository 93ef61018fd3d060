//! Lebedev-Laikov quadrature on the unit sphere: the force points of the hydrodynamic
//! force (seed, "Translational forces [Lebedev & Laikov, 1999]").
//!
//! `1/(4 pi) int f dOmega ~ sum_i w_i f(n_i)` with weights summing to 1, exact for all
//! polynomials (hence all spherical harmonics) up to the rule's algebraic degree
//! (V. I. Lebedev and D. N. Laikov, "A quadrature formula for the sphere of the 131st
//! algebraic order of accuracy", Doklady Mathematics 59 (1999) 477-481). The tables come
//! from the `lebedev_laikov` crate; [`rule_degree`] is the degree table of the paper, and
//! `tests/lebedev.rs` checks every rule against it.
use grainflow_components::SphereRule;

/// The point counts with a rule, and the algebraic degree of each (Lebedev & Laikov 1999,
/// table 1: degrees 3, 5, ..., 31, then 35, 41, ..., 131 in steps of 6).
pub const RULES: [(usize, u32); 32] = [
    (6, 3),
    (14, 5),
    (26, 7),
    (38, 9),
    (50, 11),
    (74, 13),
    (86, 15),
    (110, 17),
    (146, 19),
    (170, 21),
    (194, 23),
    (230, 25),
    (266, 27),
    (302, 29),
    (350, 31),
    (434, 35),
    (590, 41),
    (770, 47),
    (974, 53),
    (1202, 59),
    (1454, 65),
    (1730, 71),
    (2030, 77),
    (2354, 83),
    (2702, 89),
    (3074, 95),
    (3470, 101),
    (3890, 107),
    (4334, 113),
    (4802, 119),
    (5294, 125),
    (5810, 131),
];

/// Algebraic degree of the rule with `points` points, `None` if there is no such rule.
pub fn rule_degree(points: usize) -> Option<u32> {
    RULES.iter().find(|r| r.0 == points).map(|r| r.1)
}

/// The Lebedev-Laikov rule with `points` points, `None` if there is no such rule.
pub fn lebedev_rule(points: usize) -> Option<SphereRule> {
    rule_degree(points)?;
    let (x, y, z, w) = lebedev_laikov::ld_vecs(points);
    Some(SphereRule {
        direction: (0..points).map(|i| [x[i], y[i], z[i]]).collect(),
        weight: w,
    })
}
