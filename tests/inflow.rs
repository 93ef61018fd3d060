//! Continuous inflow: particles arrive at the scene's rate (count = rate x (t - start +
//! interval), capped by the total), inside the region, clear of the walls, never
//! overlapping what is already there; radii follow the size table.
use grainflow_components::{Particles, RunHealth};

mod common;

const SCENE: &str = r#"
[simulation]
dt = 1.0e-5
end_time = 1.0
gravity = [0.0, 0.0, -9.81]
[[materials]]
name = "sand"
density = 2650.0
youngs_modulus = 1.0e7
poisson_ratio = 0.25
restitution = 0.5
[[walls]]
type = "box"
material = "sand"
min = [0.0, 0.0, 0.0]
max = [0.05, 0.05, 0.2]
[[inflows]]
material = "sand"
rate = 20000.0
total = 900
interval = 0.005
radii = [0.001, 0.0015]
fractions = [0.5, 0.5]
velocity = [0.0, 0.0, -0.5]
velocity_jitter = 0.05
region = { type = "box", min = [0.0, 0.0, 0.15], max = [0.05, 0.05, 0.19] }
"#;

#[test]
fn inflow_follows_its_rate_and_places_without_overlap() {
    let mut sim = common::simulation(SCENE, "inflow.toml");
    sim.start();
    let mut checked = 0;
    for step in 1..=6000u64 {
        let before = sim.world.resource::<Particles>().len();
        sim.step();
        assert!(sim.failure().is_none(), "{:?}", sim.failure());
        let after = sim.world.resource::<Particles>().len();
        if after > before {
            // A batch arrived at the start of this step (time (step - 1) dt).
            let t = (step - 1) as f64 * 1.0e-5;
            let expected = ((20000.0 * (t + 0.005)).round() as usize).min(900);
            assert_eq!(after, expected, "particles after the batch at t = {t}");
            // New particles do not overlap anything (a batch adds no contact deeper than
            // what the bed already had).
            let ratio = sim.world.resource::<RunHealth>().max_overlap_ratio;
            assert!(ratio < 0.05, "overlap after insertion: {ratio}");
            checked += 1;
        }
    }
    assert!(checked >= 8, "several batches arrive ({checked})");
    let p = sim.world.resource::<Particles>();
    assert_eq!(p.len(), 900, "the inflow stops at its total");
    let small = p.radius.iter().filter(|&&r| r == 0.001).count();
    let large = p.radius.iter().filter(|&&r| r == 0.0015).count();
    assert_eq!(small + large, 900, "radii come from the table");
    // Binomial(900, 0.5): 5 standard deviations = 75.
    assert!(
        (small as f64 - 450.0).abs() < 75.0,
        "number fractions 50/50: {small} small, {large} large"
    );
    for i in 0..p.len() {
        for d in 0..3 {
            let x = p.position[d][i];
            let hi = [0.05, 0.05, 0.2][d];
            assert!(
                x > p.radius[i] * 0.8 && x < hi - p.radius[i] * 0.8,
                "particle {} inside the box",
                p.id[i]
            );
        }
    }
}
