//! Fixed solid bodies in the flow (`[[fluid.obstacles]]`, `src/obstacles.rs`): the faces
//! whose centres lie in the solid are held at rest, so no flow crosses the wall.
//!
//! The check is mass conservation inside a pipe: a square duct (0.5 x 0.5, length 1)
//! with a uniform inflow U = 1 at x = 0 and a do-nothing outflow at x = 1, and a pipe
//! along the whole duct (inner radius 0.1, wall 0.05 = 1.6 cells of h = 1/32). The flux
//! through the pipe's bore is then the same at every cross-section, the inflow's through
//! the faces of the bore. Without the pipe the same disc carries more and more of the
//! flow as the duct's profile develops (its centreline speed goes to about twice the
//! mean, Shah & London 1978, Laminar Flow Forced Convection in Ducts, ch. 7), so the
//! negative control moves the disc's flux by far more than the tolerance.
mod common;

use common::*;
use grainflow_systems::fluid::FluidFlow;

const INNER: f64 = 0.1;

/// The duct, with `obstacles` (TOML lines) under `[fluid]`.
fn duct(obstacles: &str) -> String {
    format!(
        r#"
[simulation]
dt = 5.0e-2
end_time = 10.0
gravity = [0.0, 0.0, 0.0]

[fluid]
density = 1.0
viscosity = 0.05
min = [0.0, 0.0, 0.0]
max = [1.0, 0.5, 0.5]
cells = [16, 8, 8]
level = 2
dt = 5.0e-2
scheme = "backward_euler"

[fluid.boundaries]
xmin = {{ type = "inflow", velocity = [1.0, 0.0, 0.0] }}
xmax = {{ type = "outflow" }}
{obstacles}
"#
    )
}

const PIPE: &str = r#"
[[fluid.obstacles]]
type = "pipe"
name = "pipe"
axis = "x"
center = [0.25, 0.25]
inner_radius = 0.1
outer_radius = 0.15
bottom = 0.0
top = 1.0
"#;

/// The volume flux through the x-faces at plane `i` (x = i h) whose centres lie within
/// the bore (distance below [`INNER`] from the axis).
fn bore_flux(flow: &FluidFlow, i: usize) -> f64 {
    let grid = flow.solver.grid();
    let lay = grid.layout();
    let n = grid.n();
    let mut q = 0.0;
    for k in 0..n[2] {
        for j in 0..n[1] {
            let x = grid.face_centre(0, [i, j, k]);
            if (x[1] - 0.25).powi(2) + (x[2] - 0.25).powi(2) < INNER * INNER {
                q += flow.solver.u[0][lay.face(0, [i, j, k])] * grid.face_area(0);
            }
        }
    }
    q
}

/// The bore's flux at x = 0.25, 0.5 and 0.75 against the inflow's, after `steps` fluid
/// steps of 0.05 (two flow-throughs at 40).
fn bore_fluxes(obstacles: &str, steps: u64) -> (f64, [f64; 3]) {
    let mut sim = simulation(&duct(obstacles), "duct.toml");
    run_fluid_steps(&mut sim, steps);
    let flow = sim.world.resource::<FluidFlow>();
    let q_in = bore_flux(flow, 0);
    (q_in, [8, 16, 24].map(|i| bore_flux(flow, i) / q_in - 1.0))
}

/// With the pipe the bore keeps its inflow to 0.1 % at every cross-section (measured
/// -4.9e-5, -9.0e-5, -1.2e-4 at x = 0.25, 0.5, 0.75; -1.5 % before the pressure
/// operator dropped the held faces' couplings); without it the disc's flux changes by
/// more than 10 % (measured +74 %, +92 %, +93 %).
#[test]
fn no_flow_crosses_the_wall_of_a_pipe() {
    let (q_in, with) = bore_fluxes(PIPE, 40);
    let (_, without) = bore_fluxes("", 40);
    println!("inflow through the bore {q_in:.5}; relative change along the pipe at x = 0.25, 0.5, 0.75: with the pipe {with:?}, without {without:?}");
    assert!(q_in > 0.9 * std::f64::consts::PI * INNER * INNER);
    assert!(with.iter().all(|d| d.abs() < 1e-3), "{with:?}");
    assert!(without[2].abs() > 0.1, "{without:?}");
}

/// Obstacle fields are checked with the scene: an `outer_radius` not above the
/// `inner_radius` exits 2 naming the field.
#[test]
fn a_pipe_without_a_wall_is_refused() {
    let text = duct(&PIPE.replace("outer_radius = 0.15", "outer_radius = 0.1"));
    let err = grainflow::scene::parse(&text, std::path::Path::new("duct.toml"), &[])
        .expect_err("a pipe with outer = inner radius");
    let message = err.to_string();
    assert!(
        message.contains("fluid.obstacles[0].outer_radius"),
        "{message}"
    );
}
