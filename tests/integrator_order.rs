//! Convergence order of the time integrators: velocity Verlet (Swope, Andersen, Berens &
//! Wilson 1982) and Gear's five-value predictor-corrector (Gear 1971; Allen & Tildesley,
//! Computer Simulation of Liquids, 1987, Appendix E).
//!
//! Method: the state at a fixed time is computed with dt, dt/2 and dt/4 and compared with
//! a run at dt/64 of the same integrator; the observed order is log2(e(dt) / e(dt/2)) and
//! log2(e(dt/2) / e(dt/4)), for the position and the velocity.
//!
//! 1. Harmonic-like contact: a sphere oscillating on a plane under gravity without ever
//!    leaving it (undamped Hertz contact, started at rest at half its static overlap), so
//!    the force is a smooth function of time.
//!    - Velocity Verlet is second order (Hairer, Lubich & Wanner, Geometric Numerical
//!      Integration, 2006, ch. I, the Stormer-Verlet scheme): band [1.8, 2.3]; measured
//!      2.00.
//!    - Gear's predictor is a Taylor series to dt^4, so the method is at least fourth
//!      order for smooth forces; with alpha_0 = 19/120, Gear's coefficient set for
//!      y'' = f(y) (forces that do not depend on the velocity), we measure 5.0 (x) and
//!      5.4-5.6 (v). Asserted: >= 4, and below 6.5.
//!    - With a velocity-dependent force (constant d_n) Gear uses alpha_0 = 19/90 and
//!      measures 4.0-4.3; asserted >= 3.5. The run starts with the velocity at which the
//!      jerk vanishes, because `gear_start` sets the jerk and snap to zero: from rest in a
//!      damped contact the true jerk is -d_n a/m != 0 and the start alone limits Gear to
//!      order 2 (measured 2.0).
//!    - Velocity Verlet with the same damping stays second order: the damping force is
//!      evaluated with the second-order velocity estimate v(t+dt/2) + a(t) dt/2 (with the
//!      half-step velocity alone it measured 1.0). Its x error reaches the asymptotic
//!      regime later (orders 1.62, 1.85 from t_c-scale dt/1 ... dt/4), so this test starts
//!      one refinement finer (dt/2 ... dt/8 against dt/128: measured 1.85, 1.93 in x and
//!      2.02, 2.01 in v).
//!
//! 2. Elastic impact of two glass spheres (Chung & Ooi 2011, Granular Matter 13:643-656,
//!    test 1: R = 0.01 m, +-10 m/s, E = 48 GPa, nu = 0.2, rho = 2800 kg/m^3), at t_c/50 and
//!    below, compared in mid-contact and after the separation. A Hertz force is not smooth
//!    at the onset and end of a contact: F ~ (t - t0)^(3/2), whose second time derivative
//!    is infinite there, and the one step straddling t0 integrates the impulse with an
//!    error O(dt^(5/2)). Its size depends on where t0 falls inside the step, so the errors
//!    are the root mean square over 16 onset phases spread over one coarse step (a single
//!    phase gives erratic ratios, e.g. 3.3 then 0.9 for the rebound velocity).
//!    - Velocity Verlet: position and in-contact velocity order 2 (band [1.8, 2.3],
//!      measured 2.00-2.01). The rebound velocity converges at 2.5 (band [2.2, 2.9],
//!      measured 2.50-2.54): Verlet is symplectic, its O(dt^2) energy error vanishes once
//!      the force does, and only the dt^(5/2) onset and separation errors remain.
//!    - Gear: order 2.5 everywhere (band [2.2, 2.9], measured 2.49-2.52): its own
//!      O(dt^4) error is far below the dt^(5/2) onset error, which dominates.
//!
//! The dt/64 references are checked against independent results: the impact rebound
//! against an RK4 integration of the relative motion (`common::rk4_normal_impact`),
//! and the oscillation amplitude against energy conservation.
mod common;

use common::*;

// ---------------------------------------------------------------------------------------
// 1. Sphere oscillating on a plane.

const R: f64 = 0.005;
const E: f64 = 2.0e8;
const NU: f64 = 0.3;
const RHO: f64 = 7800.0;
const G: f64 = 9.81;
/// Base step and comparison time: the small-oscillation period is about 2.6 ms, so
/// 5e-5 s is 1/50 of it and 100 steps about two periods.
const OSC_DT: f64 = 5e-5;
const OSC_STEPS: u64 = 100;

/// Contact of the sphere with a plane of the same material.
fn plane_contact() -> Hertz {
    Hertz {
        e_star: e_star(E, NU, E, NU),
        ..Hertz::rigid_wall(E, NU, RHO, R)
    }
}

/// Sphere released at half the static overlap; with damping d_n it gets the upward
/// speed at which the jerk of its motion vanishes at t = 0 (see the module notes).
fn oscillation(integrator: &str, d_n: f64, refine: u64) -> (f64, f64) {
    let h = plane_contact();
    let (m, c) = (h.m_star, h.c_n());
    let static_overlap = (m * G / c).powf(2.0 / 3.0);
    let delta = 0.5 * static_overlap;
    // m delta''' = -1.5 c sqrt(delta) delta' - d_n delta'' with
    // m delta'' = m g - c delta^1.5 - d_n delta': zero jerk for this delta'.
    let delta_dot =
        -d_n * (m * G - c * delta.powf(1.5)) / m / (1.5 * c * delta.sqrt() - d_n * d_n / m);
    let dt = OSC_DT / refine as f64;
    let text = format!(
        "[simulation]\ndt = {dt:e}\nend_time = 1.0\nallow_unstable_dt = true\n\
         integrator = \"{integrator}\"\ngravity = [0.0, 0.0, -{G}]\n\n\
         [[materials]]\nname = \"m\"\ndensity = {RHO}\nyoungs_modulus = {E:e}\n\
         poisson_ratio = {NU}\nnormal_damping = {d_n}\n\n\
         [[walls]]\ntype = \"plane\"\nmaterial = \"m\"\npoint = [0.0, 0.0, 0.0]\n\
         normal = [0.0, 0.0, 1.0]\n\n\
         [[spheres]]\nmaterial = \"m\"\nradius = {R}\nposition = [0.0, 0.0, {:e}]\n\
         velocity = [0.0, 0.0, {:e}]\n",
        R - delta,
        -delta_dot
    );
    let mut sim = simulation(&text, "oscillation.toml");
    let report = sim.run(OSC_STEPS * refine);
    assert!(report.failure.is_none(), "{:?}", report.failure);
    assert!(
        position(&sim, 0)[2] < R,
        "the sphere left the plane: the force is no longer smooth"
    );
    (position(&sim, 0)[2], velocity(&sim, 0)[2])
}

/// Observed orders (x then v, each for dt -> dt/2 and dt/2 -> dt/4) from errors against
/// refinement 64.
fn observed_orders(label: &str, state: impl Fn(u64) -> (f64, f64)) -> [[f64; 2]; 2] {
    let (x_ref, v_ref) = state(64);
    let mut e = [[0.0; 3]; 2];
    for (k, refine) in [1, 2, 4].into_iter().enumerate() {
        let (x, v) = state(refine);
        e[0][k] = (x - x_ref).abs();
        e[1][k] = (v - v_ref).abs();
    }
    report(label, e)
}

fn report(label: &str, e: [[f64; 3]; 2]) -> [[f64; 2]; 2] {
    let orders = e.map(|e| [(e[0] / e[1]).log2(), (e[1] / e[2]).log2()]);
    let sci = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x:.3e}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    eprintln!(
        "{label}: x errors [{}] orders {:.2?}; v errors [{}] orders {:.2?}",
        sci(&e[0]),
        orders[0],
        sci(&e[1]),
        orders[1]
    );
    orders
}

fn assert_band(label: &str, what: &str, orders: [f64; 2], lo: f64, hi: f64) {
    for p in orders {
        assert!(
            (lo..=hi).contains(&p),
            "{label}: observed order {p:.2} of {what} outside the expected band [{lo}, {hi}]"
        );
    }
}

#[test]
fn smooth_contact_velocity_verlet_second_order() {
    let label = "oscillation, velocity Verlet";
    let [x, v] = observed_orders(label, |r| oscillation("velocity_verlet", 0.0, r));
    assert_band(label, "x", x, 1.8, 2.3);
    assert_band(label, "v", v, 1.8, 2.3);
}

#[test]
fn smooth_contact_gear_at_least_fourth_order() {
    let label = "oscillation, Gear";
    let [x, v] = observed_orders(label, |r| oscillation("gear", 0.0, r));
    assert_band(label, "x", x, 4.0, 6.5);
    assert_band(label, "v", v, 4.0, 6.5);
}

#[test]
fn smooth_damped_contact_gear_fourth_order() {
    let label = "damped oscillation (d_n = 5 N s/m), Gear";
    let [x, v] = observed_orders(label, |r| oscillation("gear", 5.0, r));
    assert_band(label, "x", x, 3.5, 5.0);
    assert_band(label, "v", v, 3.5, 5.0);
}

#[test]
fn smooth_damped_contact_velocity_verlet_second_order() {
    let label = "damped oscillation (d_n = 5 N s/m), velocity Verlet";
    let [x, v] = observed_orders(label, |r| oscillation("velocity_verlet", 5.0, 2 * r));
    assert_band(label, "x", x, 1.8, 2.3);
    assert_band(label, "v", v, 1.8, 2.3);
}

#[test]
fn oscillation_reference_conserves_energy() {
    // Undamped, from rest at delta_0: (1/2) m v^2 - m g (delta - delta_0)
    // + (2/5) c (delta^(5/2) - delta_0^(5/2)) = 0 at all times. The dt/64 references must
    // keep it within 1e-6 of the largest kinetic energy.
    let h = plane_contact();
    let (m, c) = (h.m_star, h.c_n());
    let d0 = 0.5 * (m * G / c).powf(2.0 / 3.0);
    // Largest speed at the static overlap d_s: (1/2) m v^2 = m g (d_s - d0) - (2/5) c
    // (d_s^2.5 - d0^2.5).
    let ds = (m * G / c).powf(2.0 / 3.0);
    let v_max = (2.0 * (G * (ds - d0) - 0.4 * c / m * (ds.powf(2.5) - d0.powf(2.5)))).sqrt();
    for integrator in ["gear", "velocity_verlet"] {
        let (z, v) = oscillation(integrator, 0.0, 64);
        let delta = R - z;
        let energy =
            0.5 * m * v * v - m * G * (delta - d0) + 0.4 * c * (delta.powf(2.5) - d0.powf(2.5));
        let scale = 0.5 * m * v_max * v_max;
        assert!(
            energy.abs() < 1e-6 * scale,
            "{integrator} at dt/64: energy drift {energy:e} J against {scale:e} J"
        );
    }
}

// ---------------------------------------------------------------------------------------
// 2. Elastic impact of two spheres.

/// Base step t_c/50, comparison in mid-contact after 40 base steps and after the
/// separation at 120 (the contact starts near 15 base steps and lasts 50).
const IMPACT_STEPS_PER_TC: f64 = 50.0;
const MID_CONTACT: u64 = 40;
const AFTER: u64 = 120;
const PHASES: usize = 16;

fn glass() -> ImpactScene {
    glass_pair("normal_damping = 0.0".into())
}

/// (x, v) of sphere 0 in mid-contact and after the impact, at dt = base / `refine`, the
/// contact starting `phase` coarse steps after step 15.
fn impact(integrator: &str, refine: u64, phase: f64) -> [(f64, f64); 2] {
    let scene = glass();
    let tc = scene.hertz().contact_time(scene.approach_speed());
    let base = tc / IMPACT_STEPS_PER_TC;
    let gap = (15.0 + phase) * base * scene.approach_speed();
    let text = scene
        .toml(integrator, base / refine as f64, gap)
        .replace("end_time = 1.0", "end_time = 1.0\nallow_unstable_dt = true");
    let mut sim = simulation(&text, "impact.toml");
    let mut out = [(0.0, 0.0); 2];
    for (k, steps) in [MID_CONTACT, AFTER - MID_CONTACT].into_iter().enumerate() {
        let report = sim.run(steps * refine);
        assert!(report.failure.is_none(), "{:?}", report.failure);
        out[k] = (position(&sim, 0)[0], velocity(&sim, 0)[0]);
    }
    out
}

/// RMS errors over the onset phases: [mid-contact, after] x [x, v] x [dt, dt/2, dt/4].
fn impact_errors(integrator: &str) -> [[[f64; 3]; 2]; 2] {
    let mut sum = [[[0.0; 3]; 2]; 2];
    for k in 0..PHASES {
        let phase = (k as f64 + 0.5) / PHASES as f64;
        let reference = impact(integrator, 64, phase);
        for (n, refine) in [1, 2, 4].into_iter().enumerate() {
            let run = impact(integrator, refine, phase);
            for t in 0..2 {
                sum[t][0][n] += (run[t].0 - reference[t].0).powi(2);
                sum[t][1][n] += (run[t].1 - reference[t].1).powi(2);
            }
        }
    }
    sum.map(|a| a.map(|b| b.map(|s| (s / PHASES as f64).sqrt())))
}

#[test]
fn impact_velocity_verlet() {
    let [mid, after] = impact_errors("velocity_verlet");
    let label = "impact, velocity Verlet";
    let [x, v] = report(&format!("{label}, mid-contact"), mid);
    assert_band(label, "x in contact", x, 1.8, 2.3);
    assert_band(label, "v in contact", v, 1.8, 2.3);
    let [x, v] = report(&format!("{label}, after"), after);
    assert_band(label, "x after the impact", x, 1.8, 2.3);
    assert_band(label, "rebound velocity", v, 2.2, 2.9);
}

#[test]
fn impact_gear() {
    let [mid, after] = impact_errors("gear");
    let label = "impact, Gear";
    let [x, v] = report(&format!("{label}, mid-contact"), mid);
    assert_band(label, "x in contact", x, 2.2, 2.9);
    assert_band(label, "v in contact", v, 2.2, 2.9);
    let [x, v] = report(&format!("{label}, after"), after);
    assert_band(label, "x after the impact", x, 2.2, 2.9);
    assert_band(label, "rebound velocity", v, 2.2, 2.9);
}

#[test]
fn impact_reference_agrees_with_rk4() {
    let scene = glass();
    let (e, _) = rk4_normal_impact(
        &scene.hertz(),
        Damping::Constant(0.0),
        scene.approach_speed(),
        1e5,
    );
    assert!((e - 1.0).abs() < 1e-9, "RK4 elastic restitution {e}");
    for integrator in ["gear", "velocity_verlet"] {
        let [_, (_, v)] = impact(integrator, 64, 0.5);
        assert!(
            rel(-v, e * scene.speed) < 1e-7,
            "{integrator} at dt/64: rebound speed {} m/s, RK4 {} m/s",
            -v,
            e * scene.speed
        );
    }
}
