//! Frictional impacts of the benchmark suite of Chung & Ooi (2011), "Benchmark tests for
//! verifying discrete element modelling codes at particle impact level", Granular Matter
//! 13:643-656, and the Hertz impact of two spheres of different materials. Tests 1-3
//! (elastic and damped normal impacts of equal materials) are in `hertz_impact.rs` and
//! `restitution.rs`. Reference values: `shared/reference/contact-benchmarks.md` (its
//! "Chung & Ooi 2011" section, which takes them from the paper).
//!
//! Rigid-body impulse theory used throughout (a sphere of mass m, radius R, I = 2/5 m R^2,
//! on a rigid plane; J_n = m (1 + e) V_n the normal impulse): while the contact slides
//! the friction impulse is mu J_n, so
//!
//!   V_t' = V_t - mu (1 + e) V_n,   w' = 2.5 mu (1 + e) V_n / R   (w0 = 0),
//!
//! and the contact-point tangential velocity u = V_t - R w changes by
//! 3.5 mu (1 + e) V_n. The contact slides throughout when that change is smaller than
//! |u0|, i.e. chi = 3.5 mu (1 + e) V_n / |u0| < 1 (for test 4: tan(theta) > 3.5 mu (1+e)).
//!
//! - Test 4, oblique impact (R = 2.5 mm, V = 3.9 m/s at theta from the normal,
//!   mu = 0.092, e = 0.98, Al oxide and Al alloy, rigid plane): e_t = V_t'/V_t,
//!   w' and the rebound angle tan(theta_r) = V_t'/(e V_n) within 2 % of the sliding
//!   formulas for theta >= 40 deg (the reference's pass bar); below 32.5 deg the
//!   published curve dips to e_t of about 0.6 near 15-20 deg and |w'| peaks near
//!   600 rad/s around 30 deg (reference file): checked as a dip to 0.6 +- 0.06 located
//!   between 12.5 and 22.5 deg and a peak of 600 +- 10 % located between 25 and 32.5 deg.
//! - Test 6, a spinning sphere (R = 0.1 m, V_n = 0.2 m/s, mu = 0.4, e = 0.5, Al alloy
//!   and nylon): contact-point restitution beta = -u'/u0 = chi - 1 in the sliding range.
//! - Test 7, two equal spheres with opposite spins (+-0.2 m/s, R = 0.1 m, w = 0 to
//!   22 rad/s, mu = 0.4, Al alloy and copper): final tangential centre velocity 0 and
//!   spins equal and opposite, to round-off; and, added here, the same pair with equal
//!   spins, where the contact slides: equal and opposite tangential velocities, equal
//!   spins, and the sliding impulse.
//! - Test 8, the sphere of test 6 against a fixed sphere R2 = 0.5 m: the same beta.
//! - Normal contact of two spheres of different materials (and radii): contact time,
//!   largest overlap and largest force of the Hertz formulas with the mixed E*, R*, m*.
//!
//! Tangential forces produce torques: every frictional impact also checks that the
//! angular momentum about the contact point, m R V_t + I w, is unchanged (Delta w R =
//! -2.5 Delta V_t for the sign conventions here).
mod common;

use common::*;
use std::f64::consts::PI;

#[derive(Debug, Clone, Copy)]
struct Solid {
    name: &'static str,
    e: f64,
    nu: f64,
    rho: f64,
}

// Materials of Chung & Ooi 2011 (reference file table).
const AL_OXIDE: Solid = Solid {
    name: "Al oxide",
    e: 380e9,
    nu: 0.23,
    rho: 4000.0,
};
const AL_ALLOY_T4: Solid = Solid {
    name: "Al alloy",
    e: 70e9,
    nu: 0.33,
    rho: 2700.0,
};
// Tests 6-8 list Al alloy with nu = 0.30, rho = 2699 (as in test 2).
const AL_ALLOY: Solid = Solid {
    name: "Al alloy",
    e: 70e9,
    nu: 0.30,
    rho: 2699.0,
};
const NYLON: Solid = Solid {
    name: "nylon",
    e: 2.5e9,
    nu: 0.40,
    rho: 1000.0,
};
const COPPER: Solid = Solid {
    name: "copper",
    e: 120e9,
    nu: 0.35,
    rho: 8900.0,
};
const GLASS: Solid = Solid {
    name: "glass",
    e: 48e9,
    nu: 0.20,
    rho: 2800.0,
};
const LIMESTONE: Solid = Solid {
    name: "limestone",
    e: 20e9,
    nu: 0.25,
    rho: 2500.0,
};

const INTEGRATORS: [&str; 2] = ["gear", "velocity_verlet"];

/// Steps per analytic contact time. The normal impact converges long before (see
/// `hertz_impact.rs`); the tangential spring oscillates about 1.7 times faster than the
/// normal contact (Mindlin c_s / k_n = 4 G*/E* and the contact point's mass 2m/7), and
/// stick-slip switches once per step at most, so 500 steps resolve it with a margin.
const STEPS_PER_TC: f64 = 500.0;

/// State after a frictional impact of one sphere on the rigid plane z = 0.
#[derive(Debug, Clone, Copy)]
struct Rebound {
    velocity: [f64; 3],
    spin: [f64; 3],
}

/// One sphere of `solid`, radius `r`, at velocity (v_t, 0, -v_n) and spin (0, w0, 0) onto
/// the rigid plane z = 0; `lines` are the contact-law lines of the sphere's material
/// (restitution, friction), `wall_lines` those of the wall (the same damping kind).
#[allow(clippy::too_many_arguments)]
fn plane_impact(
    solid: Solid,
    r: f64,
    v_n: f64,
    v_t: f64,
    w0: f64,
    lines: &str,
    wall_lines: &str,
    integrator: &str,
) -> Rebound {
    let h = Hertz::rigid_wall(solid.e, solid.nu, solid.rho, r);
    let dt = h.contact_time(v_n) / STEPS_PER_TC;
    let gap = 20.0 * dt * v_n;
    let text = simulation_toml(dt, integrator, [0.0; 3])
        + &material_toml("ball", solid.rho, solid.e, solid.nu, lines)
        + &rigid_material_toml("rigid", wall_lines)
        + &plane_toml("rigid", [0.0; 3], [0.0, 0.0, 1.0])
        + &sphere_toml(
            "ball",
            r,
            [0.0, 0.0, r + gap],
            [v_t, 0.0, -v_n],
            [0.0, w0, 0.0],
            false,
        );
    let mut sim = simulation(&text, "oblique_impact.toml");
    step_through_contact(
        &mut sim,
        |s| position(s, 0)[2] - r,
        20 * STEPS_PER_TC as u64,
    );
    Rebound {
        velocity: velocity(&sim, 0),
        spin: angular_velocity(&sim, 0),
    }
}

/// Angular momentum about the contact point, per unit mass, of a sphere on the plane:
/// L_y / m = R V_x + (2/5) R^2 w_y. Friction acts at the contact point and the normal
/// force through it, so L is conserved by the impact (to O(delta/R) for the moment arm
/// R - delta of the deformed sphere).
fn contact_point_momentum(r: f64, v: [f64; 3], w: [f64; 3]) -> f64 {
    r * v[0] + 0.4 * r * r * w[1]
}

// ---------------------------------------------------------------------------------------
// Test 4

const T4_RADIUS: f64 = 2.5e-3;
const T4_SPEED: f64 = 3.9;
const T4_MU: f64 = 0.092;
const T4_E: f64 = 0.98;

/// Test 4 rows of the reference file: theta (deg), e_t formula, e_t published (Al oxide),
/// w' formula (rad/s), w' published.
const T4_TABLE: [(f64, f64, f64, f64, f64); 7] = [
    (35.0, 0.740, 0.737, 582.0, 583.0),
    (40.0, 0.783, 0.781, 544.0, 541.0),
    (50.0, 0.847, 0.844, 457.0, 461.0),
    (60.0, 0.895, 0.891, 355.0, 358.0),
    (70.0, 0.934, 0.933, 243.0, 245.0),
    (80.0, 0.968, 0.970, 123.0, 122.0),
    (85.0, 0.984, 0.986, 62.0, 66.0),
];

const T4_ANGLES: [f64; 18] = [
    5.0, 10.0, 15.0, 17.5, 20.0, 22.5, 25.0, 27.5, 30.0, 32.5, 35.0, 40.0, 45.0, 50.0, 60.0, 70.0,
    80.0, 85.0,
];

fn sliding_e_t(theta_deg: f64) -> f64 {
    1.0 - T4_MU * (1.0 + T4_E) / theta_deg.to_radians().tan()
}

fn sliding_spin(theta_deg: f64) -> f64 {
    2.5 * T4_MU * (1.0 + T4_E) * T4_SPEED * theta_deg.to_radians().cos() / T4_RADIUS
}

#[test]
fn test4_sliding_formulas_reproduce_the_published_table() {
    // Threshold of gross sliding: tan(theta) = 3.5 mu (1 + e), theta = 32.5 deg.
    let threshold = (3.5 * T4_MU * (1.0 + T4_E)).atan().to_degrees();
    assert!((threshold - 32.5).abs() < 0.05, "threshold {threshold} deg");
    for (theta, e_t, e_t_pub, w, w_pub) in T4_TABLE {
        // The table rounds e_t to 3 digits and w' to 1 rad/s.
        assert!(
            (sliding_e_t(theta) - e_t).abs() < 6e-4,
            "{theta} deg: e_t formula {} vs table {e_t}",
            sliding_e_t(theta)
        );
        assert!(
            (sliding_spin(theta) - w).abs() < 0.6,
            "{theta} deg: w' formula {} vs table {w}",
            sliding_spin(theta)
        );
        // The published curves agree with the formula (the digitised values, 85 deg
        // w' aside, within 1 %): the formula is the reference.
        assert!(rel(e_t_pub, e_t) < 0.01);
        if theta < 85.0 {
            assert!(rel(w_pub, w) < 0.01);
        }
    }
}

fn test4(solid: Solid) {
    let lines = format!("restitution = {T4_E}\nfriction = {T4_MU}");
    for integrator in INTEGRATORS {
        let mut rows = Vec::new();
        for theta in T4_ANGLES {
            let th = theta.to_radians();
            let (v_n, v_t) = (T4_SPEED * th.cos(), T4_SPEED * th.sin());
            let out = plane_impact(
                solid,
                T4_RADIUS,
                v_n,
                v_t,
                0.0,
                &lines,
                &format!("restitution = {T4_E}"),
                integrator,
            );
            let e_t = out.velocity[0] / v_t;
            let e_n = out.velocity[2] / v_n;
            let w = out.spin[1];
            let tan_r = out.velocity[0] / out.velocity[2];
            let l0 = contact_point_momentum(T4_RADIUS, [v_t, 0.0, -v_n], [0.0; 3]);
            let l1 = contact_point_momentum(T4_RADIUS, out.velocity, out.spin);
            eprintln!(
                "test 4 {} {integrator}: theta {theta:5.1} e_t {e_t:.4} (sliding {:.4}) \
                 w' {w:7.1} rad/s (sliding {:7.1}) e_n {e_n:.4} tan(theta_r) {tan_r:.4} \
                 (sliding {:.4}) L change {:.1e}",
                solid.name,
                sliding_e_t(theta),
                sliding_spin(theta),
                v_t * sliding_e_t(theta) / (T4_E * v_n),
                (l1 - l0) / l0
            );
            // The moment arm of the implementation may be R or R - delta: delta_max/R is
            // 0.3 % (Al oxide) to 0.8 % (Al alloy) at 3.9 m/s, of the friction impulse,
            // which is at most 0.3 of the tangential momentum.
            assert!(
                rel(l1, l0) < 3e-3,
                "test 4 {} {integrator} {theta} deg: angular momentum about the contact \
                 point {l0:e} before, {l1:e} after",
                solid.name
            );
            assert!(
                theta < 10.0 || w > 0.0,
                "test 4 {} {integrator} {theta} deg: friction spun the sphere backwards \
                 (w' = {w})",
                solid.name
            );
            rows.push((theta, e_t, w, tan_r, v_n, v_t));
        }
        for &(theta, e_t, w, tan_r, v_n, v_t) in &rows {
            if theta >= 40.0 {
                let tan_formula = v_t * sliding_e_t(theta) / (T4_E * v_n);
                for (what, got, want) in [
                    ("e_t", e_t, sliding_e_t(theta)),
                    ("w'", w, sliding_spin(theta)),
                    ("tan(theta_r)", tan_r, tan_formula),
                ] {
                    assert!(
                        rel(got, want) < 0.02,
                        "test 4 {} {integrator} {theta} deg: {what} = {got}, sliding formula \
                         {want} (2 % tolerance)",
                        solid.name
                    );
                }
            }
        }
        // Below 32.5 deg: the dip of e_t and the peak of |w'|.
        let below: Vec<_> = rows.iter().filter(|r| r.0 <= 30.0).collect();
        let dip = below
            .iter()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .expect("angles below 32.5 deg");
        let peak = rows
            .iter()
            .max_by(|a, b| a.2.abs().total_cmp(&b.2.abs()))
            .expect("angles");
        eprintln!(
            "test 4 {} {integrator}: e_t dips to {:.4} at {} deg; |w'| peaks at {:.1} rad/s \
             at {} deg",
            solid.name, dip.1, dip.0, peak.2, peak.0
        );
        assert!(
            (dip.1 - 0.6).abs() <= 0.06 && (12.5..=22.5).contains(&dip.0),
            "test 4 {} {integrator}: e_t dips to {} at {} deg; the published curve dips to \
             about 0.6 near 15-20 deg (accepted: 0.54-0.66 between 12.5 and 22.5 deg)",
            solid.name,
            dip.1,
            dip.0
        );
        assert!(
            rows[0].1 > dip.1 + 0.15,
            "test 4 {} {integrator}: e_t at 5 deg ({}) does not recover from the dip ({})",
            solid.name,
            rows[0].1,
            dip.1
        );
        assert!(
            rel(peak.2.abs(), 600.0) <= 0.10 && (25.0..=32.5).contains(&peak.0),
            "test 4 {} {integrator}: |w'| peaks at {} rad/s at {} deg; the published curve \
             peaks near 600 rad/s around 30 deg (accepted: 540-660 rad/s between 25 and \
             32.5 deg)",
            solid.name,
            peak.2,
            peak.0
        );
    }
}

#[test]
fn test4_oblique_impact_al_oxide() {
    test4(AL_OXIDE);
}

#[test]
fn test4_oblique_impact_al_alloy() {
    test4(AL_ALLOY_T4);
}

// ---------------------------------------------------------------------------------------
// Tests 6 and 8: contact-point restitution of a spinning sphere.

const T6_RADIUS: f64 = 0.1;
const T6_VN: f64 = 0.2;
const T6_MU: f64 = 0.4;
const T6_E: f64 = 0.5;
/// Initial spins, rad/s: chi = 3.5 mu (1+e) V_n / (R w0) = 0.84 ... 0.105, all sliding.
const T6_SPINS: [f64; 6] = [5.0, 6.0, 8.0, 12.0, 20.0, 40.0];

/// Ratio of the impulse of the positive part of the normal force to m (1 + e) v for the
/// restitution law (the law is self-similar: the ratio depends on e only), by RK4 of
/// m x'' = -c_n x^(3/2) - F_d with the force not clipped (as `common::rk4_normal_impact`).
///
/// The restitution law ends the contact with a small attractive damping force; the
/// integral of the whole normal force is exactly m (1 + e) v, that of the elastic part
/// too (the damping force 2 sqrt(5/6) |beta| sqrt(S_n m*) x' is a time derivative of a
/// function of x that vanishes at both ends), but a Coulomb limit mu max(F_n, 0) sees
/// the positive part only, whose impulse is larger.
fn positive_impulse_ratio(e: f64) -> f64 {
    let l = e.ln();
    let beta = l / (l * l + PI * PI).sqrt();
    // m = 1, c_n = 1, v = 1: E* sqrt(R*) = 3/4, S_n = 2 E* sqrt(R* x) = 1.5 sqrt(x).
    let force = |x: f64, xd: f64| -> f64 {
        let x = x.max(0.0);
        x.powf(1.5) - 2.0 * (5.0f64 / 6.0).sqrt() * beta * (1.5 * x.sqrt()).sqrt() * xd
    };
    let dt = 1e-5;
    let (mut x, mut xd, mut positive) = (0.0f64, 1.0f64, 0.0f64);
    loop {
        positive += force(x, xd).max(0.0) * dt;
        let acc = |x: f64, xd: f64| -force(x, xd);
        let (k1x, k1v) = (xd, acc(x, xd));
        let (k2x, k2v) = (
            xd + 0.5 * dt * k1v,
            acc(x + 0.5 * dt * k1x, xd + 0.5 * dt * k1v),
        );
        let (k3x, k3v) = (
            xd + 0.5 * dt * k2v,
            acc(x + 0.5 * dt * k2x, xd + 0.5 * dt * k2v),
        );
        let (k4x, k4v) = (xd + dt * k3v, acc(x + dt * k3x, xd + dt * k3v));
        x += dt / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
        xd += dt / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
        if x <= 0.0 {
            return positive / (1.0 + e);
        }
    }
}

/// Checks one spinning impact: contact-point restitution against chi - 1, and the
/// angular momentum about the contact point. `e_n` is the measured normal restitution
/// (chi is formed with it, so that the check is on friction alone).
fn check_beta(what: &str, w0: f64, r: f64, v_n: f64, out: Rebound, e_n: f64, clip: f64) {
    let u0 = -r * w0;
    let u1 = out.velocity[0] - r * out.spin[1];
    let beta = -u1 / u0;
    let chi = 3.5 * T6_MU * (1.0 + e_n) * v_n / u0.abs();
    // Friction impulse between mu J_n (Coulomb load = the whole, or the elastic, normal
    // force) and (1 + clip) mu J_n (load = positive part of the damped normal force).
    let (lo, hi) = (chi - 1.0, chi * (1.0 + clip) - 1.0);
    eprintln!(
        "{what}: w0 {w0:5.1} rad/s chi {chi:.4} beta {beta:+.5} (chi - 1 = {lo:+.5}, with \
         the clipped load {hi:+.5}) e_n {e_n:.4}"
    );
    // 0.005: the discretisation (500 steps per contact; the friction impulse is then
    // mu J_n to 0.1 %, times chi <= 0.84, plus the first-order damping error of e).
    assert!(
        beta >= lo - 0.005 && beta <= hi + 0.005,
        "{what}, w0 = {w0} rad/s: contact-point restitution {beta}, expected chi - 1 = {lo} \
         (up to {hi} with a Coulomb load clipped at 0), chi = {chi}"
    );
    let dv = out.velocity[0];
    let dw = out.spin[1] - w0;
    // Tangential impulse J gives m dv = J and I dw = -R J: dw R = -2.5 dv, to O(delta/R)
    // (delta_max/R < 2e-3 here).
    assert!(
        (dw * r + 2.5 * dv).abs() < 5e-3 * (2.5 * dv).abs(),
        "{what}, w0 = {w0}: spin change {dw} rad/s and velocity change {dv} m/s are not \
         related by dw R = -2.5 dv (the torque of the friction force)"
    );
}

#[test]
fn rk4_positive_impulse_ratio() {
    // e = 1: no damping, nothing clipped.
    assert!((positive_impulse_ratio(1.0) - 1.0).abs() < 1e-4);
    let clip = positive_impulse_ratio(T6_E) - 1.0;
    eprintln!("e = 0.5: positive part of the normal impulse exceeds m (1+e) v by {clip:.4}");
    assert!(clip > 0.0 && clip < 0.05, "clip {clip}");
}

fn test6(solid: Solid) {
    let clip = positive_impulse_ratio(T6_E) - 1.0;
    let lines = format!("restitution = {T6_E}\nfriction = {T6_MU}");
    for integrator in INTEGRATORS {
        for w0 in T6_SPINS {
            let out = plane_impact(
                solid,
                T6_RADIUS,
                T6_VN,
                0.0,
                w0,
                &lines,
                &format!("restitution = {T6_E}"),
                integrator,
            );
            let e_n = out.velocity[2] / T6_VN;
            assert!(
                (e_n - T6_E).abs() < 0.01 * T6_E,
                "test 6 {} {integrator}: normal restitution {e_n}",
                solid.name
            );
            check_beta(
                &format!("test 6 {} {integrator}", solid.name),
                w0,
                T6_RADIUS,
                T6_VN,
                out,
                e_n,
                clip,
            );
        }
    }
}

#[test]
fn test6_spinning_sphere_al_alloy() {
    test6(AL_ALLOY);
}

#[test]
fn test6_spinning_sphere_nylon() {
    test6(NYLON);
}

/// Test 8: the test 6 sphere (R1 = 0.1 m) onto a fixed sphere R2 = 0.5 m of the same
/// material, below it. A fixed (kinematic) R2 is the limit m2 -> infinity of the paper,
/// in which the rigid-body result is that of test 6: beta = chi - 1 while sliding.
fn test8(solid: Solid) {
    let (r1, r2) = (T6_RADIUS, 0.5);
    let clip = positive_impulse_ratio(T6_E) - 1.0;
    let h = Hertz {
        e_star: e_star(solid.e, solid.nu, solid.e, solid.nu),
        r_star: r1 * r2 / (r1 + r2),
        m_star: sphere_mass(solid.rho, r1),
    };
    let dt = h.contact_time(T6_VN) / STEPS_PER_TC;
    let gap = 20.0 * dt * T6_VN;
    let lines = format!("restitution = {T6_E}\nfriction = {T6_MU}");
    for integrator in INTEGRATORS {
        for w0 in T6_SPINS {
            let text = simulation_toml(dt, integrator, [0.0; 3])
                + &material_toml("m", solid.rho, solid.e, solid.nu, &lines)
                + &sphere_toml("m", r2, [0.0; 3], [0.0; 3], [0.0; 3], true)
                + &sphere_toml(
                    "m",
                    r1,
                    [0.0, 0.0, r1 + r2 + gap],
                    [0.0, 0.0, -T6_VN],
                    [0.0, w0, 0.0],
                    false,
                );
            let mut sim = simulation(&text, "test8.toml");
            step_through_contact(
                &mut sim,
                |s| distance(position(s, 0), position(s, 1)) - r1 - r2,
                20 * STEPS_PER_TC as u64,
            );
            assert_eq!(velocity(&sim, 0), [0.0; 3], "the fixed sphere moved");
            assert_eq!(
                angular_velocity(&sim, 0),
                [0.0; 3],
                "the fixed sphere rotated"
            );
            let out = Rebound {
                velocity: velocity(&sim, 1),
                spin: angular_velocity(&sim, 1),
            };
            let e_n = out.velocity[2] / T6_VN;
            // The restitution law takes m* = m1 m2/(m1 + m2) with the fixed sphere's own
            // mass (125 m1), while it moves as an infinite mass: e shifts by a few 1e-3.
            assert!(
                (e_n - T6_E).abs() < 0.02 * T6_E,
                "test 8 {} {integrator}: normal restitution {e_n}",
                solid.name
            );
            check_beta(
                &format!("test 8 {} {integrator}", solid.name),
                w0,
                r1,
                T6_VN,
                out,
                e_n,
                clip,
            );
        }
    }
}

#[test]
fn test8_sphere_on_fixed_large_sphere_al_alloy() {
    test8(AL_ALLOY);
}

#[test]
fn test8_sphere_on_fixed_large_sphere_nylon() {
    test8(NYLON);
}

// ---------------------------------------------------------------------------------------
// Test 7: two equal spheres, head-on, with spins.

const T7_RADIUS: f64 = 0.1;
const T7_SPEED: f64 = 0.2;
const T7_MU: f64 = 0.4;
const T7_SPINS: [f64; 4] = [0.0, 5.5, 11.0, 22.0];

/// Sphere 0 at -x moving +x with spin (0, 0, w0), sphere 1 at +x moving -x with spin
/// (0, 0, w1); elastic normal contact (the paper gives no e for this test, and the
/// symmetry checks do not depend on it). Returns the simulation after the contact.
fn spinning_pair(solid: Solid, w0: f64, w1: f64, integrator: &str) -> grainflow::run::Simulation {
    let r = T7_RADIUS;
    let h = Hertz::pair(solid.e, solid.nu, solid.rho, r);
    let dt = h.contact_time(2.0 * T7_SPEED) / STEPS_PER_TC;
    let gap = 20.0 * dt * 2.0 * T7_SPEED;
    let text = simulation_toml(dt, integrator, [0.0; 3])
        + &material_toml(
            "m",
            solid.rho,
            solid.e,
            solid.nu,
            &format!("normal_damping = 0.0\nfriction = {T7_MU}"),
        )
        + &sphere_toml(
            "m",
            r,
            [-(r + 0.5 * gap), 0.0, 0.0],
            [T7_SPEED, 0.0, 0.0],
            [0.0, 0.0, w0],
            false,
        )
        + &sphere_toml(
            "m",
            r,
            [r + 0.5 * gap, 0.0, 0.0],
            [-T7_SPEED, 0.0, 0.0],
            [0.0, 0.0, w1],
            false,
        );
    let mut sim = simulation(&text, "test7.toml");
    step_through_contact(
        &mut sim,
        |s| distance(position(s, 0), position(s, 1)) - 2.0 * r,
        20 * STEPS_PER_TC as u64,
    );
    sim
}

fn test7(solid: Solid) {
    for integrator in INTEGRATORS {
        for w in T7_SPINS {
            // Opposite spins: the surfaces move together at the contact (R w on both
            // sides), so by the mirror symmetry x -> -x the tangential velocities are
            // equal, by momentum opposite: both 0, and the spins stay +w and -w.
            let sim = spinning_pair(solid, w, -w, integrator);
            let (va, vb) = (velocity(&sim, 0), velocity(&sim, 1));
            let (wa, wb) = (angular_velocity(&sim, 0), angular_velocity(&sim, 1));
            eprintln!(
                "test 7 {} {integrator}: w {w:4.1}: v_y {:+.2e} {:+.2e} m/s, w_z {:+.12} \
                 {:+.12} rad/s",
                solid.name, va[1], vb[1], wa[2], wb[2]
            );
            let round_off = 1e-12 * (T7_SPEED + T7_RADIUS * w);
            for v in [va, vb] {
                assert!(
                    v[1].abs() <= round_off && v[2].abs() <= round_off,
                    "test 7 {} {integrator} w = {w}: tangential centre velocity {v:?}",
                    solid.name
                );
            }
            assert!(
                (wa[2] + wb[2]).abs() <= 1e-12 * w.max(1.0)
                    && (wa[2] - w).abs() <= 1e-12 * w.max(1.0),
                "test 7 {} {integrator} w = {w}: spins {wa:?} and {wb:?}, expected +-{w}",
                solid.name
            );
            // The normal impact itself is elastic.
            assert!(rel(-va[0], T7_SPEED) < 1e-3 && rel(vb[0], T7_SPEED) < 1e-3);
        }
        for w in [11.0, 22.0] {
            // Companion case, equal spins (0, 0, w): the surfaces slide at 2 R w. By the
            // rotation by pi about z through the contact and by momentum: v_y opposite,
            // spins equal. The slip 2 R w exceeds the change a sliding contact can make,
            // 7 mu (1 + e) V = 1.12 m/s (e = 1), so the friction impulse is mu J_n with
            // J_n = m* 2V (1 + e) = 2 m V: |Delta v_y| = 2 mu V, and the torque gives
            // Delta w_z = 2.5 Delta v_y / R for sphere 0.
            let sim = spinning_pair(solid, w, w, integrator);
            let (va, vb) = (velocity(&sim, 0), velocity(&sim, 1));
            let (wa, wb) = (angular_velocity(&sim, 0), angular_velocity(&sim, 1));
            let sliding = 2.0 * T7_MU * T7_SPEED;
            eprintln!(
                "test 7 equal spins {} {integrator}: w {w}: v_y {:+.6} {:+.6} m/s \
                 (sliding {sliding}), w_z {:.6} {:.6}",
                solid.name, va[1], vb[1], wa[2], wb[2]
            );
            assert!(
                (va[1] + vb[1]).abs() <= 1e-12 * sliding,
                "momentum: v_y {} and {}",
                va[1],
                vb[1]
            );
            assert!(
                rel(wa[2], wb[2]) < 1e-9,
                "equal spins: {} and {}",
                wa[2],
                wb[2]
            );
            assert!(
                rel(-va[1], sliding) < 0.01,
                "test 7 equal spins {} {integrator} w = {w}: v_y = {}, sliding impulse \
                 gives {} (1 %)",
                solid.name,
                va[1],
                -sliding
            );
            assert!(
                rel((wa[2] - w) * T7_RADIUS, 2.5 * va[1]) < 5e-3,
                "torque: Delta w R = {} vs 2.5 Delta v = {}",
                (wa[2] - w) * T7_RADIUS,
                2.5 * va[1]
            );
        }
    }
}

#[test]
fn test7_opposite_spins_al_alloy() {
    test7(AL_ALLOY);
}

#[test]
fn test7_opposite_spins_copper() {
    test7(COPPER);
}

// ---------------------------------------------------------------------------------------
// Normal contact of different materials.

/// Two spheres of different materials and radii, head-on at +-10 m/s (approach speed
/// 20 m/s), undamped: duration t_c = 2.868 (m*^2/(R* E*^2 v))^(1/5), largest overlap
/// delta_max = (15 m* v^2/(16 E* sqrt R*))^(2/5), largest force (4/3) E* sqrt(R*)
/// delta_max^(3/2) with 1/E* = (1-nu1^2)/E1 + (1-nu2^2)/E2, 1/R* = 1/R1 + 1/R2,
/// m* = m1 m2/(m1 + m2) (reference file, "Hertz impact formulas"); 1 % as in
/// `hertz_impact.rs`. Also: the force pair is equal and opposite, momentum is conserved.
fn mixed_pair(a: Solid, ra: f64, b: Solid, rb: f64) {
    let (ma, mb) = (sphere_mass(a.rho, ra), sphere_mass(b.rho, rb));
    let h = Hertz {
        e_star: e_star(a.e, a.nu, b.e, b.nu),
        r_star: ra * rb / (ra + rb),
        m_star: ma * mb / (ma + mb),
    };
    let v = 20.0;
    let (tc, dm, fm) = (h.contact_time(v), h.max_overlap(v), h.max_force(v));
    for integrator in INTEGRATORS {
        let dt = tc / STEPS_PER_TC;
        let gap = 20.0 * dt * v;
        let text = simulation_toml(dt, integrator, [0.0; 3])
            + &material_toml("a", a.rho, a.e, a.nu, "normal_damping = 0.0")
            + &material_toml("b", b.rho, b.e, b.nu, "normal_damping = 0.0")
            + &sphere_toml(
                "a",
                ra,
                [-(ra + 0.5 * gap), 0.0, 0.0],
                [10.0, 0.0, 0.0],
                [0.0; 3],
                false,
            )
            + &sphere_toml(
                "b",
                rb,
                [rb + 0.5 * gap, 0.0, 0.0],
                [-10.0, 0.0, 0.0],
                [0.0; 3],
                false,
            );
        let mut sim = simulation(&text, "mixed_pair.toml");
        let gap_of =
            |s: &grainflow::run::Simulation| distance(position(s, 0), position(s, 1)) - ra - rb;
        let p0 = ma * velocity(&sim, 0)[0] + mb * velocity(&sim, 1)[0];
        let (mut start, mut end, mut f_max, mut d_max) = (None, None, 0.0f64, 0.0f64);
        let mut previous = gap_of(&sim);
        for k in 1..=(20 * STEPS_PER_TC as u64) {
            step_ok(&mut sim);
            let g = gap_of(&sim);
            let (fa, fb) = (contact_force(&sim, 0), contact_force(&sim, 1));
            assert!(
                (0..3).all(|d| (fa[d] + fb[d]).abs() <= 1e-12 * norm(fa)),
                "forces {fa:?} and {fb:?} are not equal and opposite"
            );
            f_max = f_max.max(norm(fa));
            d_max = d_max.max(-g);
            let t = (k - 1) as f64 * dt + dt * previous / (previous - g);
            if start.is_none() && previous > 0.0 && g <= 0.0 {
                start = Some(t);
            } else if start.is_some() && end.is_none() && previous <= 0.0 && g > 0.0 {
                end = Some(t);
                break;
            }
            previous = g;
        }
        let duration = end.expect("contact ended") - start.expect("contact began");
        let p1 = ma * velocity(&sim, 0)[0] + mb * velocity(&sim, 1)[0];
        eprintln!(
            "{} R {ra} / {} R {rb} {integrator}: t_c {duration:.5e} (analytic {tc:.5e}), \
             delta_max {d_max:.5e} ({dm:.5e}), F_max {f_max:.5e} ({fm:.5e}), momentum \
             {p0:.3e} -> {p1:.3e}",
            a.name, b.name
        );
        for (what, got, want) in [
            ("contact time", duration, tc),
            ("largest overlap", d_max, dm),
            ("largest force", f_max, fm),
        ] {
            assert!(
                rel(got, want) < 0.01,
                "{} / {} {integrator}: {what} {got:e}, Hertz with mixed E* {want:e} (1 %)",
                a.name,
                b.name
            );
        }
        assert!((p1 - p0).abs() <= 1e-9 * ma * 10.0, "momentum {p0} -> {p1}");
    }
}

#[test]
fn normal_contact_glass_on_limestone() {
    mixed_pair(GLASS, 0.010, LIMESTONE, 0.010);
}

#[test]
fn normal_contact_glass_on_larger_limestone() {
    mixed_pair(GLASS, 0.010, LIMESTONE, 0.020);
}

/// Test 4 against a rigid sphere 1000 times larger instead of the plane: the
/// sphere-sphere contact (R* = 0.999 R, same E*, G* and m*) must give the rebound of the
/// plane, in the sticking range as in the sliding one: e_t within 0.01, w' within 1 %.
/// The large sphere is fixed, or free (10^9 times the mass) and listed before or after
/// the small one (the pair's history is stored for one orientation of the pair).
#[test]
fn test4_on_a_large_sphere_matches_the_plane() {
    let solid = AL_OXIDE;
    let r = T4_RADIUS;
    let r2 = 1000.0 * r;
    let lines = format!("restitution = {T4_E}\nfriction = {T4_MU}");
    let wall = format!("restitution = {T4_E}");
    for (big_fixed, big_first) in [(true, true), (false, true), (false, false)] {
        for integrator in INTEGRATORS {
            for theta in [5.0f64, 10.0, 15.0, 25.0, 40.0, 60.0] {
                let th = theta.to_radians();
                let (v_n, v_t) = (T4_SPEED * th.cos(), T4_SPEED * th.sin());
                let plane = plane_impact(solid, r, v_n, v_t, 0.0, &lines, &wall, integrator);
                let h = Hertz::rigid_wall(solid.e, solid.nu, solid.rho, r);
                let dt = h.contact_time(v_n) / STEPS_PER_TC;
                let gap = 20.0 * dt * v_n;
                let big = sphere_toml("rigid", r2, [0.0, 0.0, -r2], [0.0; 3], [0.0; 3], big_fixed);
                let small = sphere_toml(
                    "ball",
                    r,
                    [0.0, 0.0, r + gap],
                    [v_t, 0.0, -v_n],
                    [0.0; 3],
                    false,
                );
                let (first, second) = if big_first {
                    (big, small)
                } else {
                    (small, big)
                };
                let text = simulation_toml(dt, integrator, [0.0; 3])
                    + &material_toml("ball", solid.rho, solid.e, solid.nu, &lines)
                    + &material_toml("rigid", 1e3 * solid.rho, 1e25, 0.0, &wall)
                    + &first
                    + &second;
                // The stability estimate counts the Rayleigh step of the rigid sphere, whose
                // deformation is nil: it is not a constraint here.
                let text =
                    text.replace("[simulation]\n", "[simulation]\nallow_unstable_dt = true\n");
                let mut sim = simulation(&text, "test4_sphere.toml");
                let (small_id, big_id) = if big_first { (1, 0) } else { (0, 1) };
                step_through_contact(
                    &mut sim,
                    |s| distance(position(s, 0), position(s, 1)) - r - r2,
                    20 * STEPS_PER_TC as u64,
                );
                let (v, w) = (velocity(&sim, small_id), angular_velocity(&sim, small_id));
                let (e_t, e_t_plane) = (v[0] / v_t, plane.velocity[0] / v_t);
                eprintln!(
                    "test 4 on a sphere (fixed {big_fixed}, first {big_first}) {integrator}: \
                     theta {theta}: e_t {e_t:.4} (plane {e_t_plane:.4}), w' {:.1} (plane \
                     {:.1}), large sphere moved at {:.1e} m/s",
                    w[1],
                    plane.spin[1],
                    norm(velocity(&sim, big_id))
                );
                assert!(
                    (e_t - e_t_plane).abs() < 0.01,
                    "{integrator} {theta} deg (large sphere fixed {big_fixed}, first \
                     {big_first}): e_t {e_t} on the sphere, {e_t_plane} on the plane"
                );
                assert!(
                    rel(w[1], plane.spin[1]) < 0.01,
                    "{integrator} {theta} deg (large sphere fixed {big_fixed}, first \
                     {big_first}): w' {} on the sphere, {} on the plane",
                    w[1],
                    plane.spin[1]
                );
            }
        }
    }
}
