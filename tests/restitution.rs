//! Damped normal impact.
//!
//! 1. The restitution law (`restitution = e` on the material): damping force
//!    -2 sqrt(5/6) beta sqrt(S_n m*) v_n, S_n = 2 E* sqrt(R* delta),
//!    beta = ln e / sqrt(ln^2 e + pi^2) (the Tsuji-type form used by LIGGGHTS and EDEM;
//!    `shared/reference/contact-benchmarks.md`, "Damping against restitution"). The
//!    reference file states that it reproduces e exactly when the attractive force at the
//!    end of the contact is kept, and its test is "e_out against e_in for e_in = 0.1 ... 0.9
//!    must lie on the identity line". The scene is Chung & Ooi (2011), Granular Matter
//!    13:643-656, test 3: a sphere R = 2.5 mm onto a rigid plane at 3.9 m/s with
//!    e = 0 ... 1, aluminium oxide (E = 380 GPa, nu = 0.23, rho = 4000 kg/m^3), expected
//!    e_out = e_in; and the same law between two spheres (Chung & Ooi test 1 geometry,
//!    glass), which checks that the reduced mass m* = m/2 enters the damping. Tolerance:
//!    |e_out - e_in| < 1 % of e_in. The exactness claim itself is checked first on an
//!    independent RK4 integration of the contact equation (to 1e-4).
//!
//! 2. The constant damping law of the seed (slide "Models for DEM":
//!    F = c_n delta^(3/2) + d_n delta_dot, c_n = (4/3) E* sqrt(R*)). It has no closed-form
//!    restitution; the reference is an RK4 integration of m* x'' = -c_n x^(3/2) - d_n x'
//!    written here (`common::rk4_normal_impact`, 100 000 steps per contact time).
//!    Tolerance: 0.5 % on e. With a constant d_n the restitution is not a material
//!    constant: it falls as the impact speed falls (the effective damping ratio grows as
//!    v^(-1/5)), which is checked on the simulated values too.
mod common;

use common::*;

/// Steps per analytic (undamped) contact time. With damping both integrators are only
/// first order in e (velocity Verlet evaluates the damping force with the half-step
/// velocity; Gear's corrector with alpha_0 = 19/90 behaves alike): measured largest
/// deviations 2e-3 at 1000 steps, 1.1e-3 at 2000 (restitution law, e = 0.1, Verlet;
/// constant law, d_n = 60, v = 0.39 m/s). 2000 keeps them a factor 4 to 9 inside the
/// tolerances at about 2200 steps per impact.
const STEPS_PER_TC: f64 = 2000.0;
const INTEGRATORS: [&str; 2] = ["gear", "velocity_verlet"];

/// Coefficient of restitution of one simulated impact: normal separation speed after
/// over approach speed before.
fn simulated_restitution(scene: &ImpactScene, integrator: &str) -> f64 {
    let dt = scene.hertz().contact_time(scene.approach_speed()) / STEPS_PER_TC;
    let gap = 20.0 * dt * scene.approach_speed();
    let mut sim = simulation(&scene.toml(integrator, dt, gap), "restitution.toml");
    let before = scene.approach_velocity(&sim);
    step_through_contact(&mut sim, |s| scene.gap(s), 20 * STEPS_PER_TC as u64);
    -scene.approach_velocity(&sim) / before
}

fn aluminium_oxide_on_plane(damping: String, speed: f64) -> ImpactScene {
    ImpactScene {
        youngs_modulus: 380e9,
        poisson_ratio: 0.23,
        density: 4000.0,
        radius: 2.5e-3,
        speed,
        wall: true,
        damping,
    }
}

const E_IN: [f64; 9] = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9];

#[test]
fn restitution_law_is_exact_for_the_unclipped_force_rk4() {
    // The claim of the reference file, on the contact equation alone.
    let h = aluminium_oxide_on_plane(String::new(), 3.9).hertz();
    for e in E_IN {
        let (e_out, _) = rk4_normal_impact(&h, Damping::Restitution(e), 3.9, 1e5);
        assert!(
            (e_out - e).abs() < 1e-4 * e,
            "RK4: e_in {e} gives e_out {e_out}"
        );
    }
}

fn identity_line(make: fn(String) -> ImpactScene, what: &str) {
    for integrator in INTEGRATORS {
        for e_in in E_IN {
            let e_out = simulated_restitution(&make(format!("restitution = {e_in}")), integrator);
            eprintln!(
                "{what} {integrator}: e_in {e_in:.1} e_out {e_out:.6} ({:+.2e})",
                e_out / e_in - 1.0
            );
            assert!(
                (e_out - e_in).abs() < 0.01 * e_in,
                "{what} {integrator}: e_in = {e_in} gives e_out = {e_out} (1 % tolerance)"
            );
        }
    }
}

#[test]
fn restitution_law_sphere_on_plane_chung_ooi_test3() {
    identity_line(
        |d| aluminium_oxide_on_plane(d, 3.9),
        "Al oxide on rigid plane",
    );
}

#[test]
fn restitution_law_sphere_pair_uses_reduced_mass() {
    identity_line(glass_pair, "glass pair");
}

#[test]
fn restitution_law_is_independent_of_impact_speed() {
    // Chung & Ooi test 3 geometry at a tenth and ten times the speed: still e.
    for speed in [0.39, 39.0] {
        let scene = aluminium_oxide_on_plane("restitution = 0.5".into(), speed);
        for integrator in INTEGRATORS {
            let e_out = simulated_restitution(&scene, integrator);
            assert!(
                (e_out - 0.5).abs() < 0.005,
                "{integrator} at {speed} m/s: e_out = {e_out}, expected 0.5 (1 %)"
            );
        }
    }
}

#[test]
fn constant_damping_matches_rk4_reference() {
    // d_n in N s/m; sqrt(k m) of this contact at 3.9 m/s is about 140 N s/m, so these
    // span light to heavy damping.
    for d_n in [5.0, 20.0, 60.0] {
        for integrator in INTEGRATORS {
            let mut previous: Option<(f64, f64)> = None;
            for speed in [0.39, 3.9, 39.0] {
                let scene = aluminium_oxide_on_plane(format!("normal_damping = {d_n}"), speed);
                let (e_ref, _) =
                    rk4_normal_impact(&scene.hertz(), Damping::Constant(d_n), speed, 1e5);
                let e = simulated_restitution(&scene, integrator);
                eprintln!(
                    "d_n {d_n} N s/m, v {speed} m/s, {integrator}: e {e:.6}, RK4 {e_ref:.6} \
                     ({:+.2e})",
                    e / e_ref - 1.0
                );
                assert!(
                    rel(e, e_ref) < 5e-3,
                    "d_n = {d_n}, v = {speed} m/s, {integrator}: e = {e}, RK4 reference \
                     {e_ref} (0.5 % tolerance)"
                );
                if let Some((v0, e0)) = previous {
                    assert!(
                        e > e0,
                        "constant d_n = {d_n}, {integrator}: e = {e} at {speed} m/s is not \
                         above e = {e0} at {v0} m/s"
                    );
                }
                previous = Some((speed, e));
            }
        }
    }
}
