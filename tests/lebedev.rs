//! Lebedev-Laikov rules (Lebedev & Laikov 1999, Doklady Mathematics 59:477) integrate
//! every polynomial on the unit sphere up to their algebraic degree exactly, hence every
//! spherical harmonic up to that degree. Checked on the zonal harmonics `P_l(n . v)`
//! (mean 0 for `l >= 1`) of every degree up to the rule's, and on the monomials
//! `x^a y^b z^c` of low degree against the exact sphere mean
//! `<x^a y^b z^c> = (a-1)!! (b-1)!! (c-1)!! / (a+b+c+1)!!` for even `a, b, c` and 0
//! otherwise (Folland 2001, "How to integrate a polynomial over a sphere", Amer. Math.
//! Monthly 108:446, theorem for `int x^a y^b z^c dsigma`), and shown to fail one degree
//! higher (so the check can fail).
use grainflow_systems::coupling::lebedev::{lebedev_rule, rule_degree, RULES};

fn double_factorial(n: i64) -> f64 {
    if n <= 0 {
        1.0
    } else {
        (n as f64) * double_factorial(n - 2)
    }
}

/// Exact mean of `x^a y^b z^c` over the unit sphere.
fn sphere_mean(a: u32, b: u32, c: u32) -> f64 {
    if a % 2 == 1 || b % 2 == 1 || c % 2 == 1 {
        return 0.0;
    }
    double_factorial(a as i64 - 1) * double_factorial(b as i64 - 1) * double_factorial(c as i64 - 1)
        / double_factorial((a + b + c) as i64 + 1)
}

/// Largest error of the rule over all monomials of total degree `deg`.
fn worst_error(points: usize, deg: u32) -> f64 {
    let rule = lebedev_rule(points).expect("rule");
    let mut worst = 0.0f64;
    for a in 0..=deg {
        for b in 0..=deg - a {
            let c = deg - a - b;
            let q: f64 = rule
                .direction
                .iter()
                .zip(&rule.weight)
                .map(|(n, w)| w * n[0].powi(a as i32) * n[1].powi(b as i32) * n[2].powi(c as i32))
                .sum();
            worst = worst.max((q - sphere_mean(a, b, c)).abs());
        }
    }
    worst
}

/// Legendre polynomial P_l(t) by the three-term recurrence.
fn legendre(l: u32, t: f64) -> f64 {
    let (mut p0, mut p1) = (1.0, t);
    if l == 0 {
        return p0;
    }
    for k in 1..l {
        let k = k as f64;
        (p0, p1) = (p1, ((2.0 * k + 1.0) * t * p1 - k * p0) / (k + 1.0));
    }
    p1
}

/// Largest |rule mean| of the zonal harmonics P_l(n . v) of degree `l` over `2 l + 1`
/// axes v of a golden-angle spiral (their span is every spherical harmonic of degree l;
/// the exact mean of each is 0 for l >= 1).
fn worst_harmonic(points: usize, l: u32) -> f64 {
    let rule = lebedev_rule(points).expect("rule");
    let axes = 2 * l + 1;
    let mut worst = 0.0f64;
    for k in 0..axes {
        let z = 1.0 - (2.0 * k as f64 + 1.0) / axes as f64;
        let phi = k as f64 * 2.399_963_229_728_653;
        let s = (1.0 - z * z).sqrt();
        let v = [s * phi.cos(), s * phi.sin(), z];
        let q: f64 = rule
            .direction
            .iter()
            .zip(&rule.weight)
            .map(|(n, w)| w * legendre(l, n[0] * v[0] + n[1] * v[1] + n[2] * v[2]))
            .sum();
        worst = worst.max(q.abs());
    }
    worst
}

#[test]
fn rules_are_exact_up_to_their_degree_and_not_beyond() {
    // every rule up to 974 points (degree 53); the larger ones are the same construction
    for &(points, degree) in RULES.iter().filter(|r| r.0 <= 974) {
        let rule = lebedev_rule(points).unwrap();
        assert_eq!(rule.direction.len(), points);
        for n in &rule.direction {
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            assert!((len - 1.0).abs() < 1e-14, "{points}: |n| = {len}");
        }
        // monomials up to degree 12 (all rules from 50 points up are exact there)
        for deg in 0..=degree.min(12) {
            let e = worst_error(points, deg);
            assert!(
                e < 1e-14,
                "{points} points, monomials of degree {deg}: error {e:e}"
            );
        }
        for l in 1..=degree {
            let e = worst_harmonic(points, l);
            assert!(
                e < 1e-13,
                "{points} points, harmonics of degree {l}: error {e:e}"
            );
        }
        // one degree more (even, as odd harmonics vanish by the rules' symmetry) is not
        // integrated exactly
        let e = worst_harmonic(points, degree + 1);
        assert!(
            e > 1e-4,
            "{points} points: degree {} exact too ({e:e})",
            degree + 1
        );
    }
}

#[test]
fn unknown_point_counts_have_no_rule() {
    assert_eq!(rule_degree(110), Some(17));
    assert!(lebedev_rule(100).is_none());
    assert!(rule_degree(7).is_none());
}
