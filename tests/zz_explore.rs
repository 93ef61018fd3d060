mod common;
use common::*;
fn glass() -> ImpactScene {
    ImpactScene {
        youngs_modulus: 48e9,
        poisson_ratio: 0.20,
        density: 2800.0,
        radius: 0.010,
        speed: 10.0,
        wall: false,
        damping: "normal_damping = 0.0".into(),
    }
}
fn state(integrator: &str, refine: u64, phase: f64, steps: u64) -> (f64, f64) {
    let scene = glass();
    let tc = scene.hertz().contact_time(scene.approach_speed());
    let base = tc / 50.0;
    let gap = (0.3 * tc + phase * base) * scene.approach_speed();
    let dt = base / refine as f64;
    let text = scene
        .toml(integrator, dt, gap)
        .replace("end_time = 1.0", "end_time = 1.0\nallow_unstable_dt = true");
    let mut sim = simulation(&text, "order.toml");
    sim.run(steps * refine);
    (position(&sim, 0)[0], velocity(&sim, 0)[0])
}
#[test]
fn explore() {
    for integrator in ["velocity_verlet", "gear"] {
        for steps in [40u64, 120] {
            let mut sx = [0.0; 4];
            let mut sv = [0.0; 4];
            let m = 16;
            for k in 0..m {
                let phase = (k as f64 + 0.5) / m as f64;
                let (xr, vr) = state(integrator, 64, phase, steps);
                for (n, r) in [1u64, 2, 4, 8].into_iter().enumerate() {
                    let (x, v) = state(integrator, r, phase, steps);
                    sx[n] += (x - xr).powi(2);
                    sv[n] += (v - vr).powi(2);
                }
            }
            let ex: Vec<f64> = sx.iter().map(|s| (s / m as f64).sqrt()).collect();
            let ev: Vec<f64> = sv.iter().map(|s| (s / m as f64).sqrt()).collect();
            let o = |e: &Vec<f64>| (0..3).map(|k| (e[k] / e[k + 1]).log2()).collect::<Vec<_>>();
            eprintln!(
                "{integrator} T={steps}: x {:.3e?} orders {:.2?}; v {:.3e?} orders {:.2?}",
                ex,
                o(&ex),
                ev,
                o(&ev)
            );
        }
    }
}
