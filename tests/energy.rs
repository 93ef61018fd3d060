//! The energy monitor (`systems/src/energy.rs`): the particles' mechanical energy
//! E = Σ ½ m v² + Σ ⅕ m r² ω² − Σ m g·x + Σ ⅖ c_n δ^{5/2} against its start and what
//! inflows bring. References: energy conservation of an elastic Hertz impact (Johnson
//! 1985, Contact Mechanics, §11.4: no loss for e = 1), the loss (1 − e²) ½ m v² of an
//! impact with restitution e (the definition of e), free fall conserving ½ m v² + m g z.
mod common;

use common::*;
use grainflow_components::EnergyBalance;
use grainflow_systems::energy::ENERGY_CHECK_INTERVAL;

/// `cases/sphere-on-plane.toml`: a steel sphere (r = 5 mm) from 50 mm onto a plane; its
/// stable time-step limit is 4.2e-5 s (`grainflow check`).
const SPHERE_ON_PLANE: &str = include_str!("../cases/sphere-on-plane.toml");

fn balance(sim: &grainflow::run::Simulation) -> &EnergyBalance {
    sim.world.resource::<EnergyBalance>()
}

/// The sphere at rest before the impact: the balance's parts against the state computed
/// here, after one bounce with e = 1 (energy conserved to 1e-4 of m g h at dt = 2e-6 s,
/// a twentieth of the limit) and with e = 0.5 (the loss is (1 − e²) of the impact energy).
#[test]
fn an_impact_conserves_or_loses_the_energy_its_restitution_says() {
    for e in [1.0, 0.5] {
        let text = SPHERE_ON_PLANE.replace("restitution = 0.5", &format!("restitution = {e}"));
        let mut sim = simulation(&text, "sphere-on-plane.toml");
        // 0.15 s: past the first impact (0.096 s), before the second (about 0.19 s at
        // e = 0.5); a multiple of the check interval.
        let steps = (75_000 / ENERGY_CHECK_INTERVAL + 1) * ENERGY_CHECK_INTERVAL;
        sim.run(steps);
        assert!(sim.failure().is_none(), "e = {e}: {:?}", sim.failure());
        let b = balance(&sim);
        assert!(b.enforced, "a dry frictionless scene enforces the balance");
        assert_eq!(b.checked_step, steps, "the last check is the last step");
        let m = sphere_mass(7800.0, 0.005);
        let [_, _, z] = position(&sim, 0);
        let potential = m * 9.81 * z;
        assert!(
            rel(b.potential, potential) < 1e-12 && rel(b.kinetic, kinetic_energy(&sim)) < 1e-12,
            "e = {e}: potential {} against {potential}, kinetic {} against {}",
            b.potential,
            b.kinetic,
            kinetic_energy(&sim)
        );
        assert_eq!(b.elastic, 0.0, "e = {e}: in flight, no contact");
        let fall = m * 9.81 * (0.05 - 0.005);
        assert!(
            rel(b.initial, m * 9.81 * 0.05) < 1e-12,
            "initial {}",
            b.initial
        );
        let expected_loss = (1.0 - e * e) * fall;
        let loss = b.dissipated();
        println!("e = {e}: dissipated {loss:.6e} J, expected {expected_loss:.6e} J, largest growth {:.3e}", b.largest_growth);
        assert!(
            (loss - expected_loss).abs() < 0.01 * fall,
            "e = {e}: dissipated {loss:e} J, expected (1 - e^2) m g h = {expected_loss:e} J (1 % of m g h)"
        );
        assert!(
            b.largest_growth < 1e-3,
            "e = {e}: energy grew by {} of its scale at a stable step",
            b.largest_growth
        );
    }
}

/// Ten times the stable step with `allow_unstable_dt`: the overlap stays below its limit
/// (6 %) but the rebound gains energy; the run stops at a check, naming the step and the
/// particle, before it completes.
#[test]
fn a_rebound_that_gains_energy_stops_the_run_naming_step_and_particle() {
    let text = SPHERE_ON_PLANE
        .replace("dt = 2.0e-6", "dt = 5.0e-4\nallow_unstable_dt = true")
        .replace(
            "position = [0.0, 0.0, 0.05]",
            "position = [0.0, 0.0, 0.05]\nvelocity = [0.0, 0.0, -0.9]",
        );
    let mut sim = simulation(&text, "sphere-on-plane.toml");
    let report = sim.run(600);
    let failure = sim.failure().expect("an energy growth stops the run");
    assert!(report.steps < 600, "stopped early ({} steps)", report.steps);
    assert!(
        failure.contains("energy grew") && failure.contains("particle 0"),
        "{failure}"
    );
    let step = sim.world.resource::<grainflow_components::SimClock>().step;
    assert!(
        failure.contains(&format!("step {step} ")) && step.is_multiple_of(ENERGY_CHECK_INTERVAL),
        "the message names the check's step {step}: {failure}"
    );
    assert!(balance(&sim).largest_growth > 0.1);
    assert!(
        health(&sim).run_max_overlap_ratio < 0.2,
        "the overlap limit did not catch it"
    );
}

/// Particles inserted by an inflow bring their energy: falling from the inflow region with
/// e = 1 (elastic brushes with the side walls and each other), the balance stays within
/// 1e-4 of its scale before they land, while what they brought is several times the scale.
#[test]
fn inflow_particles_bring_their_energy() {
    let text = r#"
[simulation]
dt = 1.0e-5
end_time = 1.0
[[materials]]
name = "sand"
density = 2650.0
youngs_modulus = 1.0e7
poisson_ratio = 0.25
restitution = 1.0
[[walls]]
type = "box"
material = "sand"
min = [0.0, 0.0, 0.0]
max = [0.05, 0.05, 0.4]
[[inflows]]
material = "sand"
rate = 20000.0
total = 200
interval = 0.002
radii = [0.001]
fractions = [1.0]
velocity = [0.0, 0.0, -0.5]
velocity_jitter = 0.05
region = { type = "box", min = [0.0, 0.0, 0.3], max = [0.05, 0.05, 0.39] }
"#;
    let mut sim = simulation(text, "inflow.toml");
    // 0.1 s: the first particles have fallen about 0.1 m of the 0.3 m to the floor.
    sim.run(10_048);
    assert!(sim.failure().is_none(), "{:?}", sim.failure());
    let b = balance(&sim);
    assert!(b.inserted > 2.0 * b.scale && b.counted_ids == 200, "{b:?}");
    let growth = (b.total() - b.initial - b.inserted) / b.scale;
    assert!(
        growth.abs() < 1e-4,
        "free fall: balance off by {growth:e} of its scale, {b:?}"
    );
}

/// Where the balance does not hold (adhesion's surface energy, a flow doing work, fixed
/// particles on a path), it is reported but does not stop the run.
#[test]
fn adhesive_scenes_report_the_balance_without_enforcing_it() {
    let text = SPHERE_ON_PLANE.replace(
        "restitution = 0.5",
        "restitution = 0.5\nwork_of_adhesion = 0.05",
    );
    let sim = simulation(&text, "adhesive.toml");
    assert!(!balance(&sim).enforced);
}
