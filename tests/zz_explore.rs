mod common;
use common::*;
fn glass() -> ImpactScene {
    ImpactScene { youngs_modulus: 48e9, poisson_ratio: 0.20, density: 2800.0, radius: 0.010, speed: 10.0, wall: false, damping: "normal_damping = 0.0".into() }
}
fn state(integrator: &str, refine: u64, phase: f64, steps: u64) -> (f64, f64) {
    let scene = glass();
    let tc = scene.hertz().contact_time(scene.approach_speed());
    let base = tc / 50.0;
    let gap = (0.3 * tc + phase * base) * scene.approach_speed();
    let dt = base / refine as f64;
    let text = scene.toml(integrator, dt, gap).replace("end_time = 1.0", "end_time = 1.0\nallow_unstable_dt = true");
    let mut sim = simulation(&text, "order.toml");
    sim.run(steps * refine);
    (position(&sim, 0)[0], velocity(&sim, 0)[0])
}
#[test]
fn explore() {
    for integrator in ["velocity_verlet", "gear"] {
        for steps in [120u64, 200] {
            let mut line = format!("{integrator} T={steps}: ");
            for r in [1u64, 2, 4, 8, 16, 32, 64, 256] {
                let (_x, v) = state(integrator, r, 0.0, steps);
                line += &format!(" {:.12}", v);
            }
            eprintln!("{line}");
        }
    }
}
