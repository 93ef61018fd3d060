//! Rolling resistance (Iwashita & Oda 1998; seed slide "Rolling resistance"), as the
//! spring-dashpot model capped at M_r,crit = mu_r R* F_n, model type C of Ai, Chen,
//! Rotter & Ooi (2011), "Assessment of rolling resistance models in discrete element
//! simulations", Powder Technol. 206:269-282, against the reference file
//! (`shared/reference/contact-benchmarks.md`, "Rolling resistance"):
//!
//! (a) A sphere rolling on a plane (v0, w0 = v0/R, mu_s large enough never to slip)
//!     decelerates at (5/7) mu_r g and stops after s = 7 v0^2 / (10 mu_r g). Rolling at
//!     the cap: m a = -F, I dw/dt = F R - mu_r R m g, a = R dw/dt give
//!     a (1 + I/(m R^2)) = -mu_r g. Tolerances: deceleration 1 %, stopping distance 2 %
//!     (the rolling spring's deflection at the cap, mu_r m g / c_r = delta/(3.375 mu_r)
//!     with the default c_r = 2.25 mu_r^2 k_n, is 0.2 % of s here; the loading of the
//!     spring at the start takes 0.1 % of the time).
//! (b) A sphere on a slope: at rest the friction carries m g sin(theta) and its moment
//!     R m g sin(theta) must be taken by the rolling torque, so it stays at rest for
//!     tan(theta) <= mu_r (if mu_s >= tan(theta)) - without creep, and without the torque
//!     chatter of a constant-torque model: its angular velocity stays far below the
//!     2.5 mu_r g cos(theta) dt / R that one step of a flipping torque M_r,crit gives.
//!     Above, it rolls at a = (5/7) g (sin(theta) - mu_r cos(theta)) (2 %).
mod common;

use common::*;

const G: f64 = 9.81;
const INTEGRATORS: [&str; 2] = ["gear", "velocity_verlet"];
const STEPS_PER_PERIOD: f64 = 100.0;

/// The 5 mm softened bead of `friction.rs` with friction mu_s = 1 (no slip here) and
/// rolling resistance mu_r; tangential damping at half critical for the contact point's
/// oscillation, and rolling damping `rolling_damping` times critical for the rolling
/// spring's (torque stiffness c_r R^2 against the inertia about the contact point,
/// 7/5 m R^2; c_r = 2.25 mu_r^2 k_n at rest).
fn ball(mu_r: f64, rolling_damping: f64, g_n: f64) -> Ball {
    let mut b = Ball {
        radius: 5e-3,
        density: 2500.0,
        youngs_modulus: 1e7,
        poisson_ratio: 0.25,
        lines: String::new(),
        wall_lines: "restitution = 0.5".into(),
    };
    let d_s = 0.5 * b.critical_tangential_damping(g_n);
    let c_r = 2.25 * mu_r * mu_r * b.normal_stiffness(g_n);
    let d_r = rolling_damping * 2.0 * (1.4 * b.mass() * c_r).sqrt();
    b.lines = format!(
        "restitution = 0.5\nfriction = 1.0\ntangential_damping = {d_s:e}\n\
         rolling_friction = {mu_r}\n{}",
        if d_r > 0.0 {
            format!("rolling_damping = {d_r:e}")
        } else {
            String::new()
        }
    );
    b
}

#[test]
fn rolling_sphere_stops_after_seven_tenths_v0_squared_over_mu_r_g() {
    let mu_r = 0.1;
    let v0 = 0.1;
    // No rolling damping: Ai et al.'s type C at its cap does not need it.
    let b = ball(mu_r, 0.0, G);
    let r = b.radius;
    let dt = b.shortest_period(G) / STEPS_PER_PERIOD;
    let decel = 5.0 / 7.0 * mu_r * G;
    let t_stop = v0 / decel;
    let s = 7.0 * v0 * v0 / (10.0 * mu_r * G);
    for integrator in INTEGRATORS {
        let mut sim = b.scene(
            dt,
            integrator,
            [0.0, 0.0, -G],
            G,
            [v0, 0.0, 0.0],
            [0.0, v0 / r, 0.0],
        );
        let (t1, t2) = (0.1 * t_stop, 0.8 * t_stop);
        let (mut s1, mut s2, mut stop) = (None, None, None);
        let mut worst_slip = 0.0f64;
        let mut previous = (0.0, 0.0, v0);
        while stop.is_none() {
            step_ok(&mut sim);
            let t = sim_time(&sim);
            let (x, v, w) = (
                position(&sim, 0)[0],
                velocity(&sim, 0)[0],
                angular_velocity(&sim, 0)[1],
            );
            if previous.0 < t1 && t >= t1 {
                s1 = Some((t, v));
            }
            if previous.0 < t2 && t >= t2 {
                s2 = Some((t, v));
            }
            if t > 0.05 * t_stop && t < 0.95 * t_stop {
                worst_slip = worst_slip.max((v - r * w).abs());
            }
            if v <= 0.0 {
                // Interpolate the stop between the last two steps.
                let f = previous.2 / (previous.2 - v);
                stop = Some((
                    previous.0 + f * (t - previous.0),
                    previous.1 + f * (x - previous.1),
                ));
            }
            previous = (t, x, v);
            assert!(t < 2.0 * t_stop, "{integrator}: still rolling at {t} s");
        }
        let ((ta, va), (tb, vb)) = (s1.unwrap(), s2.unwrap());
        let a = (va - vb) / (tb - ta);
        let (t_end, x_end) = stop.unwrap();
        eprintln!(
            "(a) {integrator}: deceleration {a:.6} (5/7 mu_r g = {decel:.6}), stops at \
             {t_end:.5} s ({t_stop:.5}) after {x_end:.6e} m (7 v0^2/(10 mu_r g) = {s:.6e}), \
             largest slip while rolling {worst_slip:.2e} m/s"
        );
        assert!(
            rel(a, decel) < 0.01,
            "{integrator}: deceleration {a}, {decel} (1 %)"
        );
        assert!(
            rel(x_end, s) < 0.02,
            "{integrator}: stopped after {x_end} m, 7 v0^2/(10 mu_r g) = {s} m (2 %)"
        );
        // It rolls: the contact point stays at rest (mu_s = 1 is never reached).
        assert!(
            worst_slip < 1e-3 * v0,
            "{integrator}: slip {worst_slip} m/s"
        );
    }
}

/// (t, x, v_x, w_y) of one step.
type Sample = (f64, f64, f64, f64);

/// Tilt the gravity vector slowly from vertical to `theta` (over 50 ms after 10 ms at
/// rest, smoothly: theta (1 - cos(pi s))/2, s = 0..1) and hold it 60 ms. Returns the
/// samples (t, x, v_x, w_y) of the last 30 ms of the hold (the first 30 ms let the lag of
/// the ramp decay: the slowest mode, the rolling spring's, by a factor 1e3 or more).
fn slope(mu_r: f64, theta: f64, integrator: &str) -> (Ball, f64, Vec<Sample>) {
    let b = ball(mu_r, 0.5, G);
    let dt = b.shortest_period(G) / STEPS_PER_PERIOD;
    let mut sim = b.scene(dt, integrator, [0.0, 0.0, -G], G, [0.0; 3], [0.0; 3]);
    let (settle, ramp, hold) = (0.01, 0.05, 0.06);
    let mut samples = Vec::new();
    let steps = ((settle + ramp + hold) / dt).ceil() as usize;
    for _ in 0..steps {
        let t = sim_time(&sim) + dt;
        let s = ((t - settle) / ramp).clamp(0.0, 1.0);
        let th = theta * 0.5 * (1.0 - (std::f64::consts::PI * s).cos());
        set_gravity(&mut sim, [G * th.sin(), 0.0, -G * th.cos()]);
        step_ok(&mut sim);
        if t > settle + ramp + hold - 0.03 {
            samples.push((
                sim_time(&sim),
                position(&sim, 0)[0],
                velocity(&sim, 0)[0],
                angular_velocity(&sim, 0)[1],
            ));
        }
    }
    (b, dt, samples)
}

#[test]
fn sphere_on_a_slope_rests_below_mu_r_and_rolls_above() {
    let mu_r: f64 = 0.3;
    for integrator in INTEGRATORS {
        // Below: tan(theta) = 0.5 mu_r.
        let theta = (0.5 * mu_r).atan();
        let (b, dt, samples) = slope(mu_r, theta, integrator);
        let m = b.mass();
        let g_n = G * theta.cos();
        // Elastic deflection of the resting sphere: the tangential spring carries
        // F = m g sin(theta), F/c_s, and the rolling spring the moment R F, F/c_r.
        let f = m * G * theta.sin();
        let c_r = 2.25 * mu_r * mu_r * b.normal_stiffness(g_n);
        let deflection = f / b.tangential_stiffness(g_n) + f / c_r;
        let (x0, x1) = (samples[0].1, samples[samples.len() - 1].1);

        let spin = samples.iter().map(|s| s.3.abs()).fold(0.0, f64::max);
        let chatter = 2.5 * mu_r * g_n * dt / b.radius;
        eprintln!(
            "(b) below {integrator}: tan {:.3}: at x {x1:.4e} m (elastic deflection \
             {deflection:.4e}), moved {:.2e} m in the last 30 ms, largest |w| {spin:.2e} rad/s \
             (one step of a flipping M_r,crit: {chatter:.2e})",
            theta.tan(),
            x1 - x0
        );
        // No creep: 1 % of the elastic deflection over the last 30 ms.
        assert!(
            (x1 - x0).abs() < 0.01 * deflection,
            "{integrator}: the sphere crept {} m during the hold",
            x1 - x0
        );
        assert!(x1 > 0.0 && x1 < 2.0 * deflection, "{integrator}: x = {x1}");
        // No chatter: |w| below 1 % of one step of a flipping capped torque.
        assert!(
            spin < 0.01 * chatter,
            "{integrator}: angular velocity {spin} rad/s at rest (chatter scale {chatter})"
        );

        // Above: tan(theta) = 2 mu_r: rolls with a = 5/7 g (sin - mu_r cos), measured over
        // the last 20 ms of the hold.
        let theta = (2.0 * mu_r).atan();
        let (b, dt, samples) = slope(mu_r, theta, integrator);
        let n = samples.len();
        let (ta, _, va, _) = samples[n - 1 - (0.02 / dt) as usize];
        let (tb, _, vb, wb) = samples[n - 1];
        let a = (vb - va) / (tb - ta);
        let want = 5.0 / 7.0 * G * (theta.sin() - mu_r * theta.cos());
        eprintln!(
            "(b) above {integrator}: tan {:.3}: a {a:.5} (5/7 g (sin - mu_r cos) = \
             {want:.5}), v {vb:.4} m/s, R w {:.4}",
            theta.tan(),
            b.radius * wb
        );
        assert!(
            rel(a, want) < 0.02,
            "{integrator}: rolling acceleration {a}, {want} (2 %)"
        );
        assert!(
            (vb - b.radius * wb).abs() < 1e-3 * vb,
            "{integrator}: slipping"
        );
    }
}
