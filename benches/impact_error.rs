//! Run time against error for the DEM integrators: a head-on Hertz impact of two glass
//! spheres (Chung & Ooi 2011, Granular Matter 13:643-656, test 1: R = 0.01 m, +-10 m/s,
//! E = 48 GPa, nu = 0.2, rho = 2800 kg/m^3), integrated with Gear and velocity Verlet at
//! dt = t_c / N. Prints, per integrator and N, the relative errors of the contact duration
//! and the maximum overlap (against the Hertz analytic values) and of the coefficient of
//! restitution (restitution law, e = 0.5), and the cost: steps per contact, and wall
//! seconds per simulated second of the 50,000-particle dense hopper at the throughput
//! measured for that integrator (`THROUGHPUT` below, from scripts/bench-vs-lammps.sh).
//!
//!   cargo bench --bench impact_error
use std::path::Path;

use grainflow::run::Simulation;
use grainflow_components::Particles;

/// Dense-hopper throughput on 1 thread, particle-steps/s: `REPS=3 bash
/// scripts/bench-vs-lammps.sh`, 2026-12-03 00:41-00:50 UTC, commit 22eff81, Zen 5
/// (docs/performance.md, "Against LAMMPS, side by side").
const THROUGHPUT: [(&str, f64); 2] = [("gear", 29.18e6), ("velocity_verlet", 30.56e6)];

const R: f64 = 0.01;
const V: f64 = 10.0;

/// Hertz analytic contact time and total maximum overlap of the glass pair:
/// delta_max = (15 m* v^2 / (16 E* sqrt R*))^(2/5) (shared/reference/contact-benchmarks.md)
/// and t_c = 2 (delta_max / v) int_0^1 dx / sqrt(1 - x^(5/2)) (Johnson 1985, sec. 11.4;
/// the integral, 1.4716..., is evaluated here: the rounded 2.868 of the reference file is
/// good to 1e-4 only).
fn hertz() -> (f64, f64) {
    let (e, nu, rho) = (48e9, 0.2, 2800.0);
    let m = rho * 4.0 / 3.0 * std::f64::consts::PI * R.powi(3);
    let (m_eff, r_eff) = (m / 2.0, R / 2.0);
    let e_star = e / (2.0 * (1.0 - nu * nu));
    let v_rel = 2.0 * V;
    let d_max = (15.0 * m_eff * v_rel * v_rel / (16.0 * e_star * r_eff.sqrt())).powf(0.4);
    // x = 1 - u^2 removes the end-point singularity; Simpson's rule on the smooth rest.
    let f = |u: f64| {
        if u == 0.0 {
            2.0 / 2.5f64.sqrt()
        } else {
            2.0 * u / (1.0 - (1.0 - u * u).powf(2.5)).sqrt()
        }
    };
    let n = 20_000;
    let h = 1.0 / n as f64;
    let integral = (0..=n)
        .map(|k| {
            let w = if k == 0 || k == n {
                1.0
            } else if k % 2 == 1 {
                4.0
            } else {
                2.0
            };
            w * f(k as f64 * h)
        })
        .sum::<f64>()
        * h
        / 3.0;
    (2.0 * d_max / v_rel * integral, d_max)
}

struct Impact {
    duration: f64,
    max_overlap: f64,
    restitution: f64,
}

fn impact(integrator: &str, damping: &str, dt: f64, t_c: f64) -> Impact {
    let gap0 = 0.25 * t_c * 2.0 * V;
    let scene = format!(
        r#"
[simulation]
dt = {dt:e}
end_time = 1.0
integrator = "{integrator}"
allow_unstable_dt = true
gravity = [0.0, 0.0, 0.0]
[[materials]]
name = "glass"
density = 2800.0
youngs_modulus = 4.8e10
poisson_ratio = 0.2
{damping}
[[spheres]]
material = "glass"
radius = {R}
position = [{x0:e}, 0.0, 0.0]
velocity = [{V}, 0.0, 0.0]
[[spheres]]
material = "glass"
radius = {R}
position = [{x1:e}, 0.0, 0.0]
velocity = [-{V}, 0.0, 0.0]
"#,
        x0 = -(R + gap0 / 2.0),
        x1 = R + gap0 / 2.0
    );
    let path = Path::new("impact.toml");
    let mut sim = Simulation::new(
        grainflow::scene::parse(&scene, path, &[]).unwrap(),
        path,
        None,
    )
    .unwrap();
    let state = |sim: &Simulation| {
        let p = sim.world.resource::<Particles>();
        let (a, b) = if p.id[0] == 0 { (0, 1) } else { (1, 0) };
        (
            p.position[0][b] - p.position[0][a] - 2.0 * R,
            p.velocity[0][b] - p.velocity[0][a],
        )
    };
    sim.start();
    let (mut t, mut prev) = (0.0, state(&sim).0);
    let (mut start, mut end) = (None, None);
    let mut gaps = vec![prev];
    while end.is_none() {
        sim.step();
        t += dt;
        let gap = state(&sim).0;
        gaps.push(gap);
        // Linear interpolation of the gap's zero crossings.
        if start.is_none() && prev > 0.0 && gap <= 0.0 {
            start = Some(t - dt * gap / (gap - prev));
        }
        if start.is_some() && prev <= 0.0 && gap > 0.0 {
            end = Some(t - dt * gap / (gap - prev));
        }
        prev = gap;
    }
    // Gear's higher derivatives still carry the contact for a few steps after separation.
    for _ in 0..20 {
        sim.step();
    }
    // Deepest overlap by a parabola through the three samples around the minimum gap.
    let k = (1..gaps.len() - 1)
        .min_by(|&a, &b| gaps[a].total_cmp(&gaps[b]))
        .unwrap();
    let (g0, g1, g2) = (gaps[k - 1], gaps[k], gaps[k + 1]);
    let curvature = g0 - 2.0 * g1 + g2;
    let g_min = g1 - (g2 - g0).powi(2) / (8.0 * curvature);
    Impact {
        duration: end.unwrap() - start.unwrap(),
        max_overlap: -g_min,
        restitution: state(&sim).1 / (2.0 * V),
    }
}

fn main() {
    let (t_c, d_max) = hertz();
    println!(
        "Head-on glass impact (Chung & Ooi 2011 test 1): t_c = {:.4e} s, delta_max = {:.4e} m",
        t_c, d_max
    );
    println!("| integrator | t_c/dt | err t_c | err delta_max | err e (e = 0.5) | hopper wall s per simulated s |");
    println!("|---|---|---|---|---|---|");
    for (integrator, rate) in THROUGHPUT {
        for n in [10.0, 20.0, 40.0, 80.0, 160.0, 320.0, 640.0, 1280.0] {
            let dt = t_c / n;
            let elastic = impact(integrator, "normal_damping = 0.0", dt, t_c);
            let damped = impact(integrator, "restitution = 0.5", dt, t_c);
            // The hopper bed's contacts last t_c(hopper); at the same t_c/dt its cost per
            // simulated second is 50,000 / (dt_hopper * rate), dt_hopper = t_c,h / n.
            let t_c_hopper = 3.4e-4;
            let hopper = 50_000.0 / (t_c_hopper / n * rate);
            println!(
                "| {integrator} | {n:.0} | {:.2e} | {:.2e} | {:.2e} | {hopper:.0} |",
                (elastic.duration / t_c - 1.0).abs(),
                (elastic.max_overlap / d_max - 1.0).abs(),
                (damped.restitution / 0.5 - 1.0).abs(),
            );
        }
    }
}
