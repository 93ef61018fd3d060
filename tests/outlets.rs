//! Outlets (`[[fluid.outlets]]`, `src/outlets.rs`): a disc of a box side held at a
//! prescribed outward speed. A closed unit box (no-slip walls) with a do-nothing top
//! (z = 1) and an outlet of radius 0.15 at the top's centre drawing v = 1: the outlet's
//! flux is v times the disc's area (its 76 faces of h = 1/32 cover 5 % more than
//! pi r^2 / h^2 = 72.4, so they carry v / 1.05), and the flow it draws
//! enters through the rest of the top, so the net flux through the six sides vanishes
//! (volume conserved) once the pressure increments have settled.
mod common;

use common::*;
use grainflow_systems::fluid::FluidFlow;

const BOX: &str = r#"
[simulation]
dt = 5.0e-2
end_time = 10.0
gravity = [0.0, 0.0, 0.0]

[fluid]
density = 1.0
viscosity = 0.05
min = [0.0, 0.0, 0.0]
max = [1.0, 1.0, 1.0]
cells = [8, 8, 8]
level = 3
dt = 5.0e-2
scheme = "backward_euler"

[fluid.boundaries]
zmax = { type = "outflow" }

[[fluid.outlets]]
name = "suction"
side = "zmax"
center = [0.5, 0.5]
radius = 0.15
velocity = 1.0
"#;

/// The outward volume fluxes of the six sides, the outlet's part of the top, and the
/// outlet's face count.
fn side_fluxes(flow: &FluidFlow) -> ([f64; 6], f64, usize) {
    let grid = flow.solver.grid();
    let lay = grid.layout();
    let n = grid.n();
    let mut out = [0.0; 6];
    let (mut outlet, mut faces) = (0.0, 0);
    for d in 0..3 {
        let (s, t) = [(1, 2), (0, 2), (0, 1)][d];
        for side in 0..2 {
            for j in 0..n[t] {
                for i in 0..n[s] {
                    let mut f = [0; 3];
                    f[d] = side * n[d];
                    f[s] = i;
                    f[t] = j;
                    let sign = if side == 1 { 1.0 } else { -1.0 };
                    let q = sign * flow.solver.u[d][lay.face(d, f)] * grid.face_area(d);
                    out[2 * d + side] += q;
                    let x = grid.face_centre(d, f);
                    if d == 2 && side == 1 && (x[0] - 0.5).powi(2) + (x[1] - 0.5).powi(2) <= 0.0225
                    {
                        outlet += q;
                        faces += 1;
                    }
                }
            }
        }
    }
    (out, outlet, faces)
}

#[test]
fn an_outlet_draws_its_flux_and_the_volume_is_conserved() {
    let mut sim = simulation(BOX, "suction-box.toml");
    run_fluid_steps(&mut sim, 20);
    let flow = sim.world.resource::<FluidFlow>();
    let (sides, outlet, faces) = side_fluxes(flow);
    let h = 1.0 / 32.0;
    let disc = std::f64::consts::PI * 0.15 * 0.15;
    let net: f64 = sides.iter().sum();
    println!(
        "outlet: {faces} faces, flux {outlet:.6} (v x faces' area {:.6}, v x disc {disc:.6}); side fluxes {sides:?}; net {net:.3e}; max divergence {:.3e}",
        faces as f64 * h * h,
        flow.solver.max_divergence()
    );
    // v times the disc's area, whatever the staircase of its faces
    assert!((outlet - disc).abs() < 1e-12, "{outlet} vs {disc}");
    assert!(
        faces > 0 && (faces as f64 * h * h / disc - 1.0).abs() < 0.1,
        "{faces} faces"
    );
    // no flow through the walls, and the top takes in what the outlet draws
    assert!(sides[..5].iter().all(|q| q.abs() < 1e-12), "{sides:?}");
    assert!(net.abs() < 1e-3 * outlet, "net flux {net} against {outlet}");
}

/// Outlet fields are checked with the scene: a box without an `outflow` side to draw
/// from, and an outlet on a periodic side, exit 2 naming the field.
#[test]
fn an_outlet_needs_a_side_to_draw_from() {
    let parse = |text: &str| {
        grainflow::scene::parse(text, std::path::Path::new("suction-box.toml"), &[])
            .expect_err("refused")
            .to_string()
    };
    let closed = parse(&BOX.replace(r#"zmax = { type = "outflow" }"#, ""));
    assert!(closed.contains("fluid.outlets"), "{closed}");
    let periodic = parse(&BOX.replace(
        r#"zmax = { type = "outflow" }"#,
        "xmin = { type = \"outflow\" }\nzmin = { type = \"periodic\" }\nzmax = { type = \"periodic\" }",
    ));
    assert!(periodic.contains("fluid.outlets[0].side"), "{periodic}");
}
