//! Particle sinks in a coupled scene (`[[sinks]]` with a `radius`: the half-infinite
//! cylinder of a suction pipe's upper part, `grainflow_components::Sink::passed`): five
//! sand grains (r = 0.1, rho = 2.65, units cm, g, s) settle in water in a 1 x 1 x 2 box
//! onto its floor, two of them through a sink region (below z = 0.8 within 0.15 of the
//! box's vertical axis), three beside it (0.5 from the axis), two of those in contact (friction history).
//! The two are removed exactly once, with their mass; the others stay, their ids
//! unchanged; no id comes back. A sink that no particle reaches leaves the run bitwise
//! identical to the same run without it (positions, velocities, spins and the flow).
mod common;

use common::*;
use grainflow_components::Particles;
use grainflow_systems::fluid::FluidFlow;

fn scene(sink: &str) -> String {
    format!(
        r#"
[simulation]
dt = 5.0e-5
end_time = 0.25
gravity = [0.0, 0.0, -981.0]
output_interval = 0.05

[fluid]
density = 1.0
viscosity = 0.01
min = [0.0, 0.0, 0.0]
max = [1.0, 1.0, 2.0]
cells = [2, 2, 4]
level = 3
dt = 2.0e-3

[[materials]]
name = "sand"
density = 2.65
youngs_modulus = 1.0e7
poisson_ratio = 0.3
restitution = 0.3
friction = 0.3

[[walls]]
type = "box"
material = "sand"
min = [0.0, 0.0, 0.0]
max = [1.0, 1.0, 2.0]

# ids 0 and 1: through the sink region
[[spheres]]
material = "sand"
radius = 0.1
position = [0.5, 0.5, 1.5]
[[spheres]]
material = "sand"
radius = 0.1
position = [0.55, 0.45, 1.2]
# ids 2, 3, 4: beside it; 3 lands on 4
[[spheres]]
material = "sand"
radius = 0.1
position = [0.15, 0.15, 1.5]
[[spheres]]
material = "sand"
radius = 0.1
position = [0.16, 0.85, 0.45]
[[spheres]]
material = "sand"
radius = 0.1
position = [0.15, 0.85, 0.2]
{sink}
"#
    )
}

const REGION: &str = r#"
[[sinks]]
name = "pipe"
point = [0.5, 0.5, 0.8]
normal = [0.0, 0.0, 1.0]
radius = 0.15
"#;

#[test]
fn particles_entering_a_sink_region_are_removed_exactly_once() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = write_scene(dir.path(), "region.toml", &scene(REGION));
    let out = dir.path().join("out");
    let (code, stdout, stderr) = run_cli(&[
        "run",
        path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stdout}\n{stderr}");
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let sink = &s["sinks"][0];
    assert_eq!(sink["removed"].as_u64(), Some(2), "{sink}");
    let m = sphere_mass(2.65, 0.1);
    let mass = sink["removed_mass"].as_f64().unwrap();
    assert!((mass - 2.0 * m).abs() < 1e-12 * m, "{mass} for 2 x {m}");
    assert_eq!(s["particles"].as_u64(), Some(3));

    // Frames: ids unique; 0 and 1 once gone never back; 2, 3, 4 in every frame.
    let file = hdf5::File::open(out.join("particles.h5")).unwrap();
    let mut names = file.member_names().unwrap();
    names.sort();
    let mut gone = [false; 2];
    for name in &names {
        let mut ids = file
            .group(name)
            .unwrap()
            .dataset("id")
            .unwrap()
            .read_raw::<u32>()
            .unwrap();
        ids.sort();
        let n = ids.len();
        ids.dedup();
        assert_eq!(ids.len(), n, "{name}: ids repeated");
        for k in 2..5 {
            assert!(ids.contains(&k), "{name}: particle {k} lost");
        }
        for (k, g) in gone.iter_mut().enumerate() {
            let here = ids.contains(&(k as u32));
            assert!(!(*g && here), "{name}: particle {k} came back");
            *g |= !here;
        }
    }
    assert_eq!(
        gone,
        [true, true],
        "the two were not removed by the last frame"
    );
}

/// The state of every particle (by id) and of the flow, as bits.
fn state_bits(text: &str, steps: u64) -> (Vec<u64>, Vec<u64>) {
    let mut sim = simulation(text, "far.toml");
    sim.run(steps);
    let p = sim.world.resource::<Particles>();
    let mut order: Vec<usize> = (0..p.len()).collect();
    order.sort_by_key(|&i| p.id[i]);
    let mut bits = Vec::new();
    for &i in &order {
        for cols in [&p.position, &p.velocity, &p.angular_velocity] {
            bits.extend(cols.iter().map(|c| c[i].to_bits()));
        }
    }
    let flow = sim.world.resource::<FluidFlow>();
    let fluid = flow.solver.u[0]
        .iter()
        .chain(&flow.solver.u[1])
        .chain(&flow.solver.u[2])
        .map(|v| v.to_bits())
        .collect();
    (bits, fluid)
}

#[test]
fn a_sink_no_particle_reaches_leaves_the_run_bitwise_unchanged() {
    // The same region, moved to where nothing goes (above the grains, off the axis).
    let far = REGION
        .replace("[0.5, 0.5, 0.8]", "[0.8, 0.2, 1.9]")
        .replace("radius = 0.15", "radius = 0.05");
    let steps = 3000;
    let with = state_bits(&scene(&far), steps);
    let without = state_bits(&scene(""), steps);
    assert_eq!(with.0.len(), 5 * 9);
    assert!(
        with.0 == without.0,
        "particles differ with a sink nobody reaches"
    );
    assert!(
        with.1 == without.1,
        "the flow differs with a sink nobody reaches"
    );
}
