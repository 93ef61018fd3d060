//! Clumps in contact with a plane (members' Hertz, damping and Coulomb friction through
//! the contact pipeline, the loads summed on the rigid body):
//!
//! - resting on two members: each carries half the weight, so its static Hertz overlap is
//!   delta = (M g / (2 c_n))^(2/3), c_n = (4/3) E* sqrt(r) (seed slide "Models for DEM";
//!   Hertz 1896), and the body lies level;
//! - on an incline of angle theta (gravity tilted), a two-sphere clump lying along the
//!   slope cannot roll: it sticks while tan theta < mu and slides with the acceleration
//!   g (sin theta - mu cos theta) above (Coulomb's law);
//! - a tall clump standing on three members with one edge of its support triangle facing
//!   downhill tips when tan theta exceeds (distance of that edge from the centre line) /
//!   (height of the centre of mass above the plane) (the statics of a rigid body on its
//!   support polygon), below the friction angle.
mod common;

use common::*;
use glam::DVec3;
use grainflow::run::Simulation;
use grainflow_components::Clumps;

const R: f64 = 1.0e-3;
const E: f64 = 1.0e7;
const NU: f64 = 0.3;
const RHO: f64 = 2500.0;

fn scene(gravity: [f64; 3], friction: f64, end: f64, clump: &str) -> String {
    format!(
        "[simulation]\ndt = 2.0e-6\nend_time = {end}\nintegrator = \"gear\"\ngravity = {gravity:?}\n\
         output_interval = 0.0\n\
         [[materials]]\nname = \"m\"\ndensity = {RHO}\nyoungs_modulus = {E:e}\npoisson_ratio = {NU}\n\
         restitution = 0.3\nfriction = {friction}\n\
         [[walls]]\ntype = \"plane\"\nname = \"floor\"\nmaterial = \"m\"\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\n\
         {clump}"
    )
}

/// Two spheres of radius R, 1.5 R apart along x, lying on the plane.
fn dumbbell() -> String {
    format!(
        "[[clump_types]]\nname = \"pair\"\nmaterial = \"m\"\n\
         spheres = [{{ offset = [-0.75e-3, 0.0, 0.0], radius = {R:e} }}, {{ offset = [0.75e-3, 0.0, 0.0], radius = {R:e} }}]\n\
         [[clumps]]\ntype = \"pair\"\nposition = [0.0, 0.0, {R:e}]\n"
    )
}

fn body(sim: &Simulation) -> (DVec3, DVec3, DVec3) {
    let c = sim.world.resource::<Clumps>();
    // The scene's x axis of the body in the world.
    let axis = c.orientation[0] * (c.types[0].frame * DVec3::X);
    (c.position[0], c.velocity[0], axis)
}

fn run(sim: &mut Simulation, time: f64) {
    let dt = sim.world.resource::<grainflow_components::SimClock>().dt;
    for _ in 0..(time / dt).round() as usize {
        sim.step();
    }
}

#[test]
fn clump_rests_level_on_two_members_with_the_hertz_overlap() {
    let mut sim = simulation(
        &scene([0.0, 0.0, -9.81], 0.5, 0.2, &dumbbell()),
        "rest.toml",
    );
    run(&mut sim, 0.2);
    let mass = sim.world.resource::<Clumps>().types[0].mass;
    // Against a plane of the same material: 1/E* = 2 (1 - nu^2)/E, R* = R.
    let c_n = 4.0 / 3.0 * e_star(E, NU, E, NU) * R.sqrt();
    let delta = (0.5 * mass * 9.81 / c_n).powf(2.0 / 3.0);
    let (x, v, axis) = body(&sim);
    eprintln!("rest: centre z {:.6e}, expected {:.6e}", x.z, R - delta);
    assert!(
        (R - x.z - delta).abs() < 0.01 * delta,
        "overlap {:e} vs Hertz {delta:e}",
        R - x.z
    );
    assert!(axis.z.abs() < 1e-6, "not level: axis {axis}");
    assert!(v.length() < 1e-6, "still moving at {v}");
}

#[test]
fn dumbbell_on_an_incline_sticks_below_and_slides_above_the_friction_angle() {
    let mu = 0.5;
    let g = 9.81;
    for tan in [0.4, 0.7] {
        let theta = f64::atan(tan);
        let gravity = [g * theta.sin(), 0.0, -g * theta.cos()];
        let mut sim = simulation(&scene(gravity, mu, 0.15, &dumbbell()), "incline.toml");
        // Settle into the contact, then measure over 0.1 s.
        run(&mut sim, 0.05);
        let (x0, v0, _) = body(&sim);
        run(&mut sim, 0.1);
        let (x1, v1, axis) = body(&sim);
        assert!(
            axis.z.abs() < 1e-3,
            "tan {tan}: the dumbbell tipped ({axis})"
        );
        if tan < mu {
            assert!(
                (x1.x - x0.x).abs() < 1e-3 * R,
                "tan {tan} < mu: slid {:e} m",
                x1.x - x0.x
            );
        } else {
            let a = (v1.x - v0.x) / 0.1;
            let expected = g * (theta.sin() - mu * theta.cos());
            eprintln!("incline tan {tan}: a = {a:.5} m/s^2, expected {expected:.5}");
            assert!(rel(a, expected) < 0.01, "a = {a} vs {expected}");
        }
    }
}

#[test]
fn tall_clump_tips_at_the_angle_of_its_support() {
    // Three base members at circumradius s = R in the plane z = 0 of the body frame (an
    // edge, between the members at +-60 degrees, at x = s/2 facing downhill), a column of
    // two above.
    let s = R;
    let base: Vec<[f64; 3]> = [60.0f64, 180.0, 300.0]
        .iter()
        .map(|a| [s * a.to_radians().cos(), s * a.to_radians().sin(), 0.0])
        .collect();
    let mut spheres: Vec<String> = base
        .iter()
        .map(|c| format!("{{ offset = {c:?}, radius = {R:e} }}"))
        .collect();
    spheres.push(format!(
        "{{ offset = [0.0, 0.0, {:e}], radius = {R:e} }}",
        1.5 * R
    ));
    spheres.push(format!(
        "{{ offset = [0.0, 0.0, {:e}], radius = {R:e} }}",
        3.0 * R
    ));
    let types = format!(
        "[[clump_types]]\nname = \"tower\"\nmaterial = \"m\"\nspheres = [{}]\n",
        spheres.join(", ")
    );
    // The centre of mass of the union, from the mass properties (tests/clump_mass.rs).
    let probe = simulation(
        &scene(
            [0.0, 0.0, -9.81],
            0.8,
            0.01,
            &format!("{types}[[clumps]]\ntype = \"tower\"\nposition = [0.0, 0.0, 0.01]\n"),
        ),
        "probe.toml",
    );
    let centre = probe.world.resource::<Clumps>().types[0].centre;
    let height = R + centre.z;
    let tan_tip = (0.5 * s - centre.x) / height;
    eprintln!("tower: centre {centre}, tan of the tipping angle {tan_tip:.4}");
    for (factor, tips) in [(0.9, false), (1.1, true)] {
        let theta = f64::atan(factor * tan_tip);
        let gravity = [9.81 * theta.sin(), 0.0, -9.81 * theta.cos()];
        let clumps = format!(
            "{types}[[clumps]]\ntype = \"tower\"\nposition = [{:e}, 0.0, {height:e}]\n",
            centre.x
        );
        let mut sim = simulation(&scene(gravity, 0.8, 0.3, &clumps), "tower.toml");
        run(&mut sim, 0.3);
        let c = sim.world.resource::<Clumps>();
        let up = c.orientation[0] * (c.types[0].frame * DVec3::Z);
        let tilt = up.z.clamp(-1.0, 1.0).acos().to_degrees();
        eprintln!("tower at {factor} x the tipping angle: tilt {tilt:.2} degrees");
        if tips {
            assert!(tilt > 20.0, "did not tip: tilt {tilt} degrees");
        } else {
            assert!(tilt < 2.0, "tipped below the angle: tilt {tilt} degrees");
        }
    }
}
