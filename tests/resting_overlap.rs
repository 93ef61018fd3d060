//! A sphere resting on a plane: the static Hertz overlap.
//!
//! At rest the contact force balances the weight, c_n delta^(3/2) = m g, so
//! delta = (m g / c_n)^(2/3) with c_n = (4/3) E* sqrt(R) (seed slide "Models for DEM":
//! c_n = 4 / (3 pi (k_i + k_j)) sqrt(R), k_l = (1 - nu_l^2) / (pi E_l), which is
//! (4/3) E* sqrt(R) with 1/E* = (1-nu_i^2)/E_i + (1-nu_j^2)/E_j; against a plane R = R_i).
//! In a fluid the seed's Newton-Euler translation equation (slide "Fluid-solid particle
//! system") has the buoyant weight (rho - rho_f) V g instead of m g.
//!
//! The sphere starts touching the plane at rest and settles under the restitution damping
//! (e = 0.5); the overlap must then be within 1 % of the formula, for Gear and velocity
//! Verlet, with the same and with different sphere and plane materials, and in a fluid.
mod common;

use common::*;

const RADIUS: f64 = 0.005;
const G: f64 = 9.81;
/// Time step: 1/500 of the period of small oscillations at rest (about 2.6 ms for the
/// softest case here), far below the stable limit; statics do not depend on it.
const DT: f64 = 5e-6;
/// Settling time. The restitution damping of e = 0.5 decays the oscillation by a factor
/// e about every period; 0.1 s is some 40 periods, leaving far less than the 1 % bar.
const SETTLE: f64 = 0.1;

struct Case {
    sphere: (f64, f64, f64),
    /// Young's modulus and Poisson's ratio of the plane.
    plane: (f64, f64),
    fluid_density: Option<f64>,
}

fn scene(case: &Case, integrator: &str) -> String {
    let (rho, e, nu) = case.sphere;
    let (e_w, nu_w) = case.plane;
    let fluid = case
        .fluid_density
        .map_or(String::new(), |d| format!("[fluid]\ndensity = {d}\n"));
    format!(
        "[simulation]\ndt = {DT:e}\nend_time = {SETTLE}\nintegrator = \"{integrator}\"\n\
         gravity = [0.0, 0.0, -{G}]\n\n{fluid}\n\
         [[materials]]\nname = \"sphere\"\ndensity = {rho}\nyoungs_modulus = {e:e}\n\
         poisson_ratio = {nu}\nrestitution = 0.5\n\n\
         [[materials]]\nname = \"plane\"\ndensity = 7800.0\nyoungs_modulus = {e_w:e}\n\
         poisson_ratio = {nu_w}\nrestitution = 0.5\n\n\
         [[walls]]\ntype = \"plane\"\nmaterial = \"plane\"\n\
         point = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\n\n\
         [[spheres]]\nmaterial = \"sphere\"\nradius = {RADIUS}\n\
         position = [0.0, 0.0, {RADIUS}]\n"
    )
}

fn check(case: &Case) {
    let (rho, e, nu) = case.sphere;
    let (e_w, nu_w) = case.plane;
    let c_n = 4.0 / 3.0 * e_star(e, nu, e_w, nu_w) * RADIUS.sqrt();
    let rho_f = case.fluid_density.unwrap_or(0.0);
    let volume = 4.0 / 3.0 * std::f64::consts::PI * RADIUS.powi(3);
    let weight = (rho - rho_f) * volume * G;
    let expected = (weight / c_n).powf(2.0 / 3.0);
    for integrator in ["gear", "velocity_verlet"] {
        let mut sim = simulation(&scene(case, integrator), "resting.toml");
        let report = sim.run((SETTLE / DT).round() as u64);
        assert!(report.failure.is_none(), "{:?}", report.failure);
        let overlap = RADIUS - position(&sim, 0)[2];
        let speed = velocity(&sim, 0)[2].abs();
        eprintln!(
            "sphere {:?} plane {:?} rho_f {rho_f} {integrator}: overlap {overlap:.6e} m, \
             expected {expected:.6e} m ({:+.2e}), residual speed {speed:.1e} m/s",
            case.sphere,
            case.plane,
            overlap / expected - 1.0
        );
        assert!(
            rel(overlap, expected) < 0.01,
            "{integrator}: resting overlap {overlap:e} m, expected (m g / c_n)^(2/3) = \
             {expected:e} m (1 % tolerance)"
        );
    }
}

#[test]
fn steel_sphere_on_steel_plane() {
    // The material of cases/sphere-on-plane.toml (a soft "steel", E = 2e8 Pa).
    check(&Case {
        sphere: (7800.0, 2.0e8, 0.3),
        plane: (2.0e8, 0.3),
        fluid_density: None,
    });
}

#[test]
fn sphere_on_plane_of_another_material() {
    // E* combines both materials: a glass-like sphere on a plane four times stiffer.
    check(&Case {
        sphere: (2500.0, 5.0e8, 0.2),
        plane: (2.0e9, 0.35),
        fluid_density: None,
    });
}

#[test]
fn buoyant_sphere_in_fluid() {
    // Sediment grain in water: the buoyant weight (rho - rho_f) V g loads the contact.
    check(&Case {
        sphere: (2650.0, 2.0e8, 0.25),
        plane: (2.0e8, 0.25),
        fluid_density: Some(1000.0),
    });
}
