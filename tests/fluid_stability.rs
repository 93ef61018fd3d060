//! A flow that is no longer physical stops the run (developers' guide, "Numerical
//! stability"): after every fluid step `multigrid_fluid` looks for a non-finite velocity
//! or pressure and for a velocity above `RUNAWAY_FACTOR` (100) times the scene's velocity
//! scale (here the lid speed, 1 m/s), and the run stops with a message naming the step,
//! the fluid step and the face. A healthy cavity never comes near the bound (its largest
//! velocity is the lid's). The failures are provoked by writing into the flow between two
//! fluid steps: a spike of 1e4 m/s (ten thousand times the lid speed), and a NaN.
mod common;

use common::*;
use grainflow_systems::fluid::FluidFlow;

/// Lid-driven cavity, 8 x 8 x 1 coarse cells, level 1, one fluid step per DEM step.
const CAVITY: &str = r#"
[simulation]
dt = 1.0e-2
end_time = 1.0
gravity = [0.0, 0.0, 0.0]

[fluid]
density = 1.0
viscosity = 0.01
min = [0.0, 0.0, 0.0]
max = [1.0, 1.0, 0.125]
cells = [8, 8, 1]
level = 1
dt = 1.0e-2
scheme = "backward_euler"

[fluid.boundaries]
ymax = { type = "wall", velocity = [1.0, 0.0, 0.0] }
zmin = { type = "periodic" }
zmax = { type = "periodic" }
"#;

/// Index of the x-face at the centre of the cavity (x = 0.5, y = 0.5625, z = 0.0625).
fn centre_face(sim: &grainflow::run::Simulation) -> usize {
    let flow = sim.world.resource::<FluidFlow>();
    flow.solver.grid().layout().face(0, [4, 4, 0])
}

/// The largest velocity component of the flow: value, component, centre of its face.
fn fastest(sim: &grainflow::run::Simulation) -> (f64, usize, [f64; 3]) {
    let ns = &sim.world.resource::<FluidFlow>().solver;
    let mut best = (0.0, 0, 0);
    for d in 0..3 {
        for (k, v) in ns.u[d].iter().enumerate() {
            if v.abs() > f64::abs(best.0) {
                best = (*v, d, k);
            }
        }
    }
    let (a, f) = ns.grid().layout().face_of(best.2);
    (best.0, best.1, ns.grid().face_centre(a, f))
}

#[test]
fn a_healthy_cavity_runs_and_a_runaway_flow_stops_the_run_naming_the_face() {
    let mut sim = simulation(CAVITY, "cavity.toml");
    let healthy = sim.run(20);
    assert!(healthy.failure.is_none(), "{:?}", healthy.failure);
    assert_eq!(healthy.steps, 20);
    let largest = sim.world.resource::<FluidFlow>().solver.u[0]
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(largest <= 1.0 + 1e-12, "the lid is the fastest: {largest}");

    let k = centre_face(&sim);
    sim.world.resource_mut::<FluidFlow>().solver.u[0][k] = 1.0e4;
    let report = sim.run(20);
    assert_eq!(report.steps, 1, "the run goes on: {:?}", report.failure);
    let failure = report.failure.expect("a runaway flow stops the run");
    // the step spreads the spike; the message names the fastest face after it
    let (value, d, x) = fastest(&sim);
    assert!(value.abs() > 100.0, "{value}");
    for part in [
        "unstable at step 21",
        "fluid step 21",
        "runaway flow",
        &format!("velocity component {} = {value:.3e}", ["x", "y", "z"][d]),
        &format!("({:.4e}, {:.4e}, {:.4e})", x[0], x[1], x[2]),
        "reduce fluid.dt",
    ] {
        assert!(failure.contains(part), "`{part}` not in: {failure}");
    }
}

#[test]
fn a_non_finite_flow_stops_the_run() {
    let mut sim = simulation(CAVITY, "cavity.toml");
    assert!(sim.run(2).failure.is_none());
    let k = centre_face(&sim);
    sim.world.resource_mut::<FluidFlow>().solver.u[1][k] = f64::NAN;
    let report = sim.run(20);
    assert_eq!(report.steps, 1);
    let failure = report.failure.expect("a NaN in the flow stops the run");
    assert!(
        failure.contains("unstable at step 3") && failure.contains("non-finite velocity"),
        "{failure}"
    );
}

/// `grainflow check` warns where the momentum multigrid slows down (`MULTIGRID_CFL`,
/// U dt/h = 4, src/fluid.rs): the drag case at Re = 150 (U = 6) on level 3 (h = 1/24)
/// at its dt_F of 0.05 (U dt/h = 7.2, where the run goes away in its second fluid step,
/// docs/coupling.md) gets the warning with the step that keeps below it,
/// 4 h / U = 2.778e-2 s; at dt_F = 0.02 (2.88) there is none. Exit 0 in both: the hard
/// bound is the scheme's CFL limit.
#[test]
fn check_warns_above_the_multigrid_cfl_number() {
    let case = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/drag-sphere.toml");
    let mut args: Vec<String> = ["check", case.to_str().unwrap(), "--set", "fluid.level=3"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    for side in ["ymin", "xmin", "xmax", "zmin", "zmax"] {
        args.push("--set".into());
        args.push(format!("fluid.boundaries.{side}.velocity=[0.0,6.0,0.0]"));
    }
    let check = |dt: &str| {
        let mut a = args.clone();
        a.extend(["--set".to_string(), format!("fluid.dt={dt}")]);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        let (code, stdout, stderr) = run_cli(&a);
        assert_eq!(code, 0, "{stderr}");
        stdout
            .lines()
            .find(|l| l.starts_with("warning: U dt/h"))
            .map(str::to_string)
    };
    let warning = check("0.05").expect("a warning at U dt/h = 7.2");
    println!("{warning}");
    assert!(
        warning.starts_with("warning: U dt/h = 7.200") && warning.contains("dt <= 2.778e-2 s"),
        "{warning}"
    );
    assert_eq!(check("0.02"), None);
}
