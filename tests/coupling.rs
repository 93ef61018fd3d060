//! Fluid-particle coupling (seed, "Coupling of the phases"): fictitious boundary with
//! rigid-body faces, hydrodynamic force and torque from surface force points (Lebedev
//! quadrature) and from the volume integral, subcycling. Small grids so the suite stays
//! fast; the tolerances are stated with the resolution they allow.
mod common;

use std::f64::consts::PI;

use common::{run_fluid_steps, simulation, unit_box_scene, PERIODIC_YZ};
use grainflow_components::{Coupling, HydroForces, Particles};
use grainflow_systems::coupling::subcycles;
use grainflow_systems::fluid::FluidFlow;

fn hydro(sim: &grainflow::run::Simulation) -> ([f64; 3], [f64; 3]) {
    let h = sim.world.resource::<HydroForces>();
    (
        [h.force[0][0], h.force[1][0], h.force[2][0]],
        [h.torque[0][0], h.torque[1][0], h.torque[2][0]],
    )
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// A sphere carried by a uniform flow at the flow's velocity disturbs nothing: the rigid
/// faces carry the flow's velocity, the stress vanishes, and so do force and torque (to
/// round-off), for both force methods; the sphere keeps its velocity.
#[test]
fn sphere_moving_with_a_uniform_flow_feels_no_force() {
    for method in ["surface_points", "volume_integral"] {
        let mut text = unit_box_scene(
            4,
            2,
            0.1,
            0.01,
            &format!(
                "xmin = {{ type = \"inflow\", velocity = [1.0, 0.0, 0.0] }}\nxmax = {{ type = \"outflow\" }}\n{PERIODIC_YZ}"
            ),
            "radius = 0.2\nposition = [0.35, 0.5, 0.5]\nvelocity = [1.0, 0.0, 0.0]",
        );
        text.push_str(&format!("\n[coupling]\nforce = \"{method}\"\n"));
        let mut sim = simulation(&text, "uniform.toml");
        sim.world.resource_mut::<FluidFlow>().solver.u[0].fill(1.0);
        run_fluid_steps(&mut sim, 6);
        let (f, t) = hydro(&sim);
        let stokes = 6.0 * PI * 0.1 * 0.2 * 1.0;
        assert!(norm(f) < 1e-10 * stokes, "{method}: force {f:?}");
        assert!(norm(t) < 1e-10 * stokes * 0.2, "{method}: torque {t:?}");
        let p = sim.world.resource::<Particles>();
        assert!(
            (p.velocity[0][0] - 1.0).abs() < 1e-12,
            "{method}: {}",
            p.velocity[0][0]
        );
        let moved = p.position[0][0] - 0.35;
        let t = sim.world.resource::<grainflow_components::SimClock>().time;
        assert!(
            (moved - t).abs() < 1e-12,
            "{method}: moved {moved} in {t} at U = 1"
        );
        let flow = sim.world.resource::<FluidFlow>();
        let dev = flow.solver.u[0]
            .iter()
            .fold(0.0f64, |m, u| m.max((u - 1.0).abs()));
        assert!(dev < 1e-10, "{method}: flow disturbed by {dev:e}");
    }
}

/// Stokes drag in a periodic cubic array of spheres against Hasimoto's factor
/// ([`common::hasimoto_factor`]): a fixed sphere a = L/8 in a periodic box driven by a
/// body force; grid 32^3 (4 cells per radius); 90 backward-Euler steps of 0.25, the drag
/// steady to 0.6 % ([`common::periodic_array_drag`]; after the 30 steps this test once
/// took the flow carried only 81 % of the body force, and K read -7.4 %). Tolerances, with
/// the face-centre rule: the fictitious boundary is resolved to a face spacing (a face is
/// inside or outside), an O(h/a) uncertainty of the sphere's effective radius at 4 cells
/// per radius; measured -6.1 % for the default volume-integral force (bar 10 %; -6.5 % with
/// `fluid.pressure_force = "normal"`). The
/// seed's surface force points sample the stress in the cells the surface cuts, where
/// the mean gradient is an O(1) estimate of the wall shear (corrected by the fluid
/// fraction of the cell): measured +40.8 % (+33.5 % with the normal force), bar 45 %; that is why the volume integral is
/// the default. The distance penalty: tests/distance_penalty.rs.
#[test]
fn periodic_array_drag_matches_hasimoto() {
    let k_ref = common::hasimoto_factor(4.0 / 3.0 * PI * 0.125f64.powi(3));
    let mut failures = Vec::new();
    for (method, tol) in [("volume_integral", 0.10), ("surface_points", 0.45)] {
        let drag =
            common::periodic_array_drag(8, 3, [0.5; 3], &format!("force = \"{method}\""), "", 90);
        println!(
            "{method}: K = {:.4} (Hasimoto {k_ref:.4}, {:+.2} %), drag / body force on the fluid = {:.4}",
            drag.k,
            100.0 * (drag.k / k_ref - 1.0),
            drag.balance
        );
        if (drag.k / k_ref - 1.0).abs() >= tol {
            failures.push(format!("{method}: K = {} vs {k_ref}", drag.k));
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// Translation invariance across the periodic sides: in a fully periodic box (16^3
/// cells, 2 cells per radius) a fixed sphere straddling the three periodic sides (centre
/// at the corner (0, 0, 0), its marked cells on both sides of each) feels the same force
/// as the same sphere at the box centre (0.5, 0.5, 0.5), half a box (a whole number of
/// coarse cells) away, in the same oblique uniform stream U = (1, 0.5, 0.25); the flows
/// are the same field shifted by half a box. Both force methods: the volume integral
/// (faces inside the sphere, wrapped) and the surface force points (sampled in the cells
/// holding their images). After 5 backward-Euler steps, measured: force differences
/// 8.8e-17 (volume integral) and 8.4e-17 (surface points) relative, flow differences
/// 6.7e-16; bar 1e-10. Without the wrapping (indices clamped at the sides) the
/// straddling sphere would be marked and sampled in the corner octant only.
#[test]
fn sphere_straddling_periodic_sides_feels_the_force_at_the_box_centre() {
    let periodic = format!(
        "xmin = {{ type = \"periodic\" }}\nxmax = {{ type = \"periodic\" }}\n{PERIODIC_YZ}"
    );
    let stream = [1.0, 0.5, 0.25];
    for method in ["volume_integral", "surface_points"] {
        let runs: Vec<_> = ["0.0, 0.0, 0.0", "0.5, 0.5, 0.5"]
            .into_iter()
            .map(|centre| {
                let mut text = unit_box_scene(
                    4,
                    3,
                    0.1,
                    0.01,
                    &periodic,
                    &format!("radius = 0.125\nposition = [{centre}]\nfixed = true"),
                );
                text.push_str(&format!("\n[coupling]\nforce = \"{method}\"\n"));
                let mut sim = simulation(&text, "straddling.toml");
                for (u, v) in sim
                    .world
                    .resource_mut::<FluidFlow>()
                    .solver
                    .u
                    .iter_mut()
                    .zip(stream)
                {
                    u.fill(v);
                }
                run_fluid_steps(&mut sim, 5);
                let (f, _) = hydro(&sim);
                (f, sim.world.resource::<FluidFlow>().solver.u.clone(), sim)
            })
            .collect();
        let ((f0, u0, sim), (f1, u1, _)) = (&runs[0], &runs[1]);
        let df = norm([0, 1, 2].map(|d| f0[d] - f1[d])) / norm(*f1);
        // the flow of the corner sphere, shifted by half a box, is the centre sphere's
        let lay = sim.world.resource::<FluidFlow>().solver.grid().layout();
        let mut du = 0.0f64;
        for a in 0..3 {
            for k in 0..lay.off[a + 1] - lay.off[a] {
                let f = lay.face_coords(a, k);
                let shifted = [0, 1, 2].map(|d| (f[d] + lay.n[d] / 2) % lay.n[d]);
                for d in 0..3 {
                    du = du.max((u0[d][lay.off[a] + k] - u1[d][lay.face(a, shifted)]).abs());
                }
            }
        }
        println!(
            "{method}: corner {f0:?}, centre {f1:?}: force difference {df:.3e} relative, flow {du:.3e}"
        );
        assert!(norm(*f1) > 0.1, "{method}: no drag {f1:?}");
        assert!(df < 1e-10, "{method}: force {f0:?} vs {f1:?}");
        assert!(du < 1e-10, "{method}: flows differ by {du:e}");
    }
}

/// Torque on a sphere rotating at the centre of a closed box at rest. The Stokes torque
/// `T = -8 pi mu a^3 w` (Lamb 1932, art. 334) with the wall factor of a concentric
/// spherical container of radius b, `1 / (1 - (a/b)^3)` (Happel & Brenner 1965, sec.
/// 4-17): for the cube of side 1 and a = 1/8 it lies between the inscribed (b = 1/2,
/// 1.016) and the circumscribed sphere (b = sqrt(3)/2, 1.003). The sphere is very dense,
/// so it keeps its spin over the test. Grid 32^3, 4 cells per radius; the torque goes
/// with a^3, so the h/2 resolution of the fictitious boundary allows several 10 %:
/// volume integral measured -10 % (bar 15 %, and no stray force beyond round-off), the
/// seed's surface points +66 % (bar 70 %, stray force 0.7 % of T/a from the cut cells
/// they sample). The sphere is free, so the scene shares the pressure force
/// (`fluid.pressure_force`): with it measured -11 % and +72 %, stray force 2.1 % of T/a
/// (bar 3 %).
#[test]
fn rotating_sphere_torque_matches_stokes() {
    let (a, nu, w): (f64, f64, f64) = (0.125, 1.0, 0.2);
    let mut failures = Vec::new();
    for (method, tol, stray) in [
        ("volume_integral", 0.15, 1e-6),
        ("surface_points", 0.75, 0.03),
    ] {
        let mut text = unit_box_scene(
            8,
            3,
            nu,
            0.05,
            r#"xmin = { type = "wall" }"#,
            &format!(
                "radius = {a}\nposition = [0.5, 0.5, 0.5]\nangular_velocity = [0.0, 0.0, {w}]"
            ),
        );
        text = text.replace("density = 1.0\nyoungs", "density = 1.0e12\nyoungs");
        text.push_str(&format!("\n[coupling]\nforce = \"{method}\"\n"));
        let mut sim = simulation(&text, "rotation.toml");
        run_fluid_steps(&mut sim, 8);
        let (force, torque) = hydro(&sim);
        let stokes = -8.0 * PI * nu * a.powi(3) * w;
        let ratio = torque[2] / stokes;
        println!(
            "{method}: T / T_Stokes = {ratio:.4} (container factor 1.003-1.016), force {force:?}"
        );
        if !(ratio > 1.003 * (1.0 - tol) && ratio < 1.016 * (1.0 + tol)) {
            failures.push(format!("{method}: T / T_Stokes = {ratio}"));
        }
        assert!(
            norm(force) < stray * stokes.abs() / a,
            "{method}: force {force:?}"
        );
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// The seed's subcycling formula (after Feng & Owen 2007): n_s = int(dt_F / dt_D) + 1,
/// dt_D' = dt_F / n_s, and the world runs with dt_D'.
#[test]
fn subcycling_follows_the_seeds_formula() {
    assert_eq!(subcycles(1e-4, 1e-5), 11);
    assert_eq!(subcycles(1e-4, 3e-5), 4);
    assert_eq!(subcycles(1e-4, 2e-4), 1);
    let text = unit_box_scene(
        4,
        1,
        0.1,
        1e-2,
        "",
        "radius = 0.1\nposition = [0.5, 0.5, 0.5]",
    )
    .replace("[simulation]\ndt = 0.01", "[simulation]\ndt = 1.5e-3");
    let mut sim = simulation(&text, "subcycles.toml");
    assert_eq!(sim.world.resource::<Coupling>().subcycles, 7);
    assert_eq!(sim.coupled_step.substeps, 7);
    let dt = sim.world.resource::<grainflow_components::SimClock>().dt;
    assert!((dt - 1e-2 / 7.0).abs() < 1e-18, "dt_D' = {dt}");
    // the fluid step runs in the first of every 7 DEM steps
    for step in 0..30u64 {
        sim.step();
        let fluid_steps = sim.world.resource::<FluidFlow>().stats.steps;
        assert_eq!(fluid_steps, step / 7 + 1, "after DEM step {step}");
    }
}

/// A scene gets the coupling's systems only when it couples a flow to particles: a DEM
/// scene builds no fluid step and no coupling system (nor their resources), a flow
/// without particles only the flow step, and the velocity blending only a scene that sets
/// `coupling.alpha`.
#[test]
fn only_coupled_scenes_build_the_coupling() {
    const COUPLING: [&str; 7] = [
        "cell_markers",
        "velocity_blending",
        "hydrodynamic_sampling",
        "held_hydrodynamic_force",
        "sync_rows<HydroForces>",
        "permute_rows<HydroForces>",
        "multigrid_fluid",
    ];
    let names = |sim: &grainflow::run::Simulation| -> Vec<&'static str> {
        sim.coupled_step.systems.iter().map(|(_, n)| *n).collect()
    };
    let coupled = unit_box_scene(
        4,
        1,
        0.1,
        1e-2,
        "",
        "radius = 0.1\nposition = [0.5, 0.5, 0.5]",
    );
    let sim = simulation(&coupled, "coupled.toml");
    assert_eq!(
        names(&sim).iter().filter(|n| COUPLING.contains(n)).count(),
        6,
        "{:?}",
        names(&sim)
    );
    assert!(!names(&sim).contains(&"velocity_blending"));
    let blended = coupled.replace("[[materials]]", "[coupling]\nalpha = 0.1\n\n[[materials]]");
    let sim = simulation(&blended, "blended.toml");
    assert!(
        names(&sim).contains(&"velocity_blending"),
        "{:?}",
        names(&sim)
    );

    let flow_only = coupled[..coupled.find("[[materials]]").expect("materials")].to_string();
    let sim = simulation(&flow_only, "flow.toml");
    let flow_names = names(&sim);
    assert_eq!(
        flow_names
            .iter()
            .filter(|n| COUPLING.contains(n))
            .collect::<Vec<_>>(),
        [&"multigrid_fluid"]
    );
    assert!(!sim.world.contains_resource::<Coupling>());

    let dry = coupled.replace(
        &coupled[coupled.find("[fluid]").expect("fluid")
            ..coupled.find("[[materials]]").expect("materials")],
        "",
    );
    let sim = simulation(&dry, "dry.toml");
    let dry_names = names(&sim);
    assert!(
        dry_names.iter().all(|n| !COUPLING.contains(n)),
        "{dry_names:?}"
    );
    assert!(
        sim.coupled_step
            .systems
            .iter()
            .all(|(set, _)| !grainflow_systems::schedule::FLUID_STEP.contains(set)),
        "{dry_names:?}"
    );
    assert_eq!(sim.coupled_step.substeps, 1);
    assert!(!sim.world.contains_resource::<FluidFlow>());
    assert!(!sim.world.contains_resource::<Coupling>());
    assert!(!sim.world.contains_resource::<HydroForces>());
    assert!(!sim
        .world
        .contains_resource::<grainflow_components::CellMarkers>());
}

/// Terminal velocity of a sphere settling in a closed box (rho / rho_f = 2, Re_p ~ 0.02;
/// dt_F = 1e-3 against the particle's response time
/// tau = (m + rho_f V / 2) / (6 pi mu r) = 2.2e-2 that `grainflow check` reports: the
/// explicit coupling ran away at dt_F = 1e-2, measured)
/// with one DEM step per fluid step (n_s = 1) and with the seed's ratio
/// dt_F / dt_D = 10 (n_s = 11): the hydrodynamic force is held over the subcycles, so
/// both reach the same terminal velocity; bar 1 % (the issue's).
#[test]
fn settling_sphere_terminal_velocity_is_independent_of_subcycles() {
    let mut terminal = Vec::new();
    for (dt_d, n_s) in [(0.002, 1), (0.0001, 11)] {
        let text = unit_box_scene(
            4,
            2,
            1.0,
            0.001,
            "",
            "radius = 0.2\nposition = [0.5, 0.5, 0.7]",
        )
        .replace(
            "[simulation]\ndt = 0.001",
            &format!("[simulation]\ndt = {dt_d}"),
        )
        .replace("gravity = [0.0, 0.0, 0.0]", "gravity = [0.0, 0.0, -10.0]")
        .replace("density = 1.0\nyoungs", "density = 2.0\nyoungs");
        let mut sim = simulation(&text, "settling.toml");
        assert_eq!(sim.world.resource::<Coupling>().subcycles, n_s);
        run_fluid_steps(&mut sim, 100);
        let v = sim.world.resource::<Particles>().velocity[2][0];
        run_fluid_steps(&mut sim, 120);
        let v2 = sim.world.resource::<Particles>().velocity[2][0];
        println!("n_s = {n_s}: w = {v:.6e} after 100 fluid steps, {v2:.6e} after 120");
        assert!(
            v2 < 0.0 && ((v2 - v) / v2).abs() < 2e-3,
            "not terminal: {v} -> {v2}"
        );
        terminal.push(v2);
    }
    let diff = (terminal[0] / terminal[1] - 1.0).abs();
    assert!(
        diff < 0.01,
        "terminal velocities {terminal:?} differ by {diff}"
    );
}

/// The seed's drag case (`cases/drag-sphere.toml`: sphere d = 0.25, inflow at y = 0, side
/// walls moving with the inflow, Re = U d / nu = 50 at U = 2) reduced to a 1 x 2.5 x 1
/// channel around the sphere at (0.5, 0.75, 0.5), 6 x 15 x 6 coarse cells so that level L
/// has the cell size of level L of the seed's 12 x 36 x 12 grid (h = 1/12 at level 2).
/// Upwind scale 0.1 (less numerical diffusion than the default 1: C_D -7 % at levels 2-3).
/// Runs `until` seconds of backward-Euler steps of `dt_f`; returns the drag coefficient
/// at the end and at `until - 0.25`, and the run's observables.
fn reduced_drag(
    level: u32,
    dt_f: f64,
    until: f64,
    extra: &[&str],
) -> (f64, f64, serde_json::Value) {
    let (mut sim, scene) = reduced_drag_simulation(level, dt_f, extra);
    let area_q = 0.5 * 1.0 * 2.0 * 2.0 * PI * 0.125 * 0.125;
    let steps = |t: f64| (t / dt_f).round() as u64;
    run_fluid_steps(&mut sim, steps(until - 0.25));
    let before = hydro(&sim).0[1] / area_q;
    run_fluid_steps(&mut sim, steps(until));
    let observed = grainflow::observables::observables(&sim.world, &scene);
    (hydro(&sim).0[1] / area_q, before, observed)
}

/// The simulation and scene of [`reduced_drag`].
fn reduced_drag_simulation(
    level: u32,
    dt_f: f64,
    extra: &[&str],
) -> (grainflow::run::Simulation, grainflow::scene::Scene) {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/cases/drag-sphere.toml"
    ))
    .expect("cases/drag-sphere.toml");
    let mut overrides: Vec<String> = [
        "fluid.max=[1.0, 2.5, 1.0]",
        "fluid.cells=[6, 15, 6]",
        "spheres.0.position=[0.5, 0.75, 0.5]",
        "fluid.upwind=0.1",
        "simulation.output_interval=0.0",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    overrides.push(format!("fluid.level={level}"));
    overrides.push(format!("fluid.dt={dt_f}"));
    overrides.push(format!("simulation.dt={dt_f}"));
    overrides.push("simulation.allow_unstable_dt=true".into());
    overrides.extend(extra.iter().map(|s| s.to_string()));
    let path = std::path::Path::new("drag-reduced.toml");
    let scene = grainflow::scene::parse(&text, path, &overrides).expect("drag scene");
    let sim =
        grainflow::run::Simulation::new(scene.clone(), path, None).expect("drag scene builds");
    (sim, scene)
}

/// Deferred upwind correction (`fluid.solve_upwind`) on the reduced drag case at Re = 150
/// (U = 6), level 2, dt_F = 0.05: upwind scale 0.03 solved directly runs away within
/// its first fluid steps (the run stops with "runaway flow"); solved with the operator of
/// scale 0.1 it settles, with less drag than scale 0.1 itself (less numerical
/// diffusion; measured 0.794 against 0.944 with the scene's shared pressure force,
/// 0.788 against 0.894 with the normal one; on the seed's 2 x 2 channel at level 2
/// 0.749 against 0.851, at level 3 1.141 against 1.206, docs/coupling.md).
#[test]
fn deferred_upwind_correction_solves_a_less_diffusive_scale() {
    let re150: Vec<String> = ["ymin", "xmin", "xmax", "zmin", "zmax"]
        .iter()
        .map(|side| format!("fluid.boundaries.{side}.velocity=[0.0, 6.0, 0.0]"))
        .collect();
    let with = |more: &[&str]| -> Vec<String> {
        re150
            .iter()
            .cloned()
            .chain(more.iter().map(|s| s.to_string()))
            .collect()
    };
    // (the case file itself solves with 0.1)
    let direct = with(&["fluid.upwind=0.03", "fluid.solve_upwind=0.03"]);
    let direct: Vec<&str> = direct.iter().map(String::as_str).collect();
    let (mut sim, _) = reduced_drag_simulation(2, 0.05, &direct);
    while sim.failure().is_none() && sim.world.resource::<FluidFlow>().stats.steps < 10 {
        sim.step();
    }
    let failure = format!("{:?}", sim.failure());
    println!("upwind 0.03 solved directly: {failure}");
    assert!(failure.contains("runaway flow"), "{failure}");
    // `reduced_drag` scales by the dynamic pressure of U = 2
    let scale = (2.0f64 / 6.0).powi(2);
    let cd: Vec<(f64, f64)> = [
        &["fluid.upwind=0.03", "fluid.solve_upwind=0.1"][..],
        &["fluid.upwind=0.1", "fluid.solve_upwind=0.1"][..],
    ]
    .iter()
    .map(|more| {
        let args = with(more);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (c, c0, _) = reduced_drag(2, 0.05, 2.0, &args);
        (scale * c, scale * c0)
    })
    .collect();
    println!(
        "C_D at Re 150 (now, 0.25 s before): upwind 0.03 solved with 0.1 {:?}, upwind 0.1 {:?}",
        cd[0], cd[1]
    );
    let (deferred, plain) = (cd[0].0, cd[1].0);
    // steady to 1 % (measured 0.6 % over the last 0.25 s), far below the 12 % compared
    assert!(
        (deferred / cd[0].1 - 1.0).abs() < 1e-2,
        "not steady: {cd:?}"
    );
    assert!(deferred < 0.97 * plain, "C_D {deferred} against {plain}");
}

/// Schiller & Naumann (1933) drag correlation, `C_D = 24/Re (1 + 0.15 Re^0.687)`
/// (Clift, Grace & Weber 1978, Bubbles, Drops and Particles, table 5.2), 1.538 at Re 50.
fn schiller_naumann(re: f64) -> f64 {
    24.0 / re * (1.0 + 0.15 * re.powf(0.687))
}

/// Without velocity blending the steady drag is a property of the steady flow, not of
/// the time step: dt_F = 0.02 and 0.05 agree to 0.5 % (measured 1.33595 and 1.33551 with the shared pressure force; 1.31153 and 1.31149 with
/// the normal one;
/// the seed's full grid at level 2: 1.247). The negative control: the seed's blending
/// u = (1 - phi) u + phi U with alpha = 0.1, a relaxation applied once per fluid step,
/// moves the steady drag with dt_F by more than 5 % (measured 1.840 at 0.02 and 1.497 at
/// 0.05).
#[test]
fn steady_drag_does_not_depend_on_the_fluid_time_step() {
    let mut cd = Vec::new();
    for extra in [&[][..], &["coupling.alpha=0.1"][..]] {
        let (a, a0, _) = reduced_drag(2, 0.02, 2.5, extra);
        let (b, b0, _) = reduced_drag(2, 0.05, 2.5, extra);
        println!(
            "{extra:?}: C_D = {a:.5} (dt_F 0.02; {a0:.5} at t - 0.25), {b:.5} (dt_F 0.05; {b0:.5})"
        );
        assert!(
            (a / a0 - 1.0).abs() < 2e-3 && (b / b0 - 1.0).abs() < 2e-3,
            "not steady"
        );
        cd.push((a / b - 1.0).abs());
    }
    assert!(
        cd[0] < 5e-3,
        "C_D moves with dt_F by {:.3} %",
        100.0 * cd[0]
    );
    assert!(
        cd[1] > 0.05,
        "blending: C_D moves with dt_F by only {:.3} %",
        100.0 * cd[1]
    );
}

/// Force convergence (the issue's check): on the reduced drag case at Re = 50 the drag
/// coefficient changes less between levels 3 and 4 than between levels 2 and 3 (d = 3, 6
/// and 12 cells). Steady state by backward-Euler steps of dt_F = 0.05 (U dt / h = 4.8 at
/// level 4; 0.1 oscillates at level 2) to t = 2.5 (two flow-throughs); steadiness
/// checked to 0.5 % (level 4 still drifts by 0.3 %), well below the changes compared.
/// Measured with the scene's shared pressure force: 1.336, 1.661, 1.674 (differences
/// 0.325 and 0.014; with the normal force 1.312, 1.794, 1.726). The narrow channel
/// (sphere diameter a quarter of the width) raises C_D by ~9 % over the seed's 2 x 2
/// channel: there, level 4 gives 1.539 (+0.06 % from Schiller-Naumann's 1.538) with the
/// case's defaults (shared force, upwind 0.03 solved with 0.1), 1.572 (+2.2 %) with the
/// normal force (7-15 min runs, so not tests; figures in docs/coupling.md).
#[test]
fn drag_coefficient_converges_with_the_grid_level() {
    let cd: Vec<f64> = (2..=4)
        .map(|level| {
            let (c, c0, observed) = reduced_drag(level, 0.05, 2.5, &[]);
            println!(
                "level {level}: C_D = {c:.4} ({c0:.4} 0.25 s before; Schiller-Naumann {:.4}), observables {observed}",
                schiller_naumann(50.0)
            );
            assert!((c / c0 - 1.0).abs() < 5e-3, "level {level} not steady");
            c
        })
        .collect();
    let (d23, d34) = ((cd[1] - cd[0]).abs(), (cd[2] - cd[1]).abs());
    assert!(
        d34 < d23,
        "C_D {cd:?}: |C3 - C2| = {d23:.4}, |C4 - C3| = {d34:.4}"
    );
}

/// Particles the fluid grid cannot represent are refused, never silently uncoupled:
/// * at the start, a sphere whose centre lies outside the fluid box through a
///   non-periodic side, or whose marked cells (sphere plus half a cell diagonal, here
///   0.4 + 0.108) reach half way round a periodic direction (they would meet their own
///   image), is a scene error naming `spheres[0]` and the side or direction;
/// * a sphere that leaves the box during the run (here through the outflow side at
///   x = 1, moving at 2 in a flow of 1) stops the run before the next fluid step, naming
///   the particle and the side; it crossed at t = 0.325, so the run stops at the fluid
///   step after it (steps of 0.01);
/// * a sphere reaching past a non-periodic side with its centre inside is accepted (the
///   side's condition holds on its faces), and so is one straddling a periodic side, or
///   with its centre past it (its marked cells wrap; it sees the flow at its image).
#[test]
fn particles_outside_the_fluid_grid_are_refused() {
    let boundaries = format!(
        "xmin = {{ type = \"inflow\", velocity = [1.0, 0.0, 0.0] }}\nxmax = {{ type = \"outflow\" }}\n{PERIODIC_YZ}"
    );
    let build = |sphere: &str| {
        let text = unit_box_scene(4, 2, 0.1, 0.01, &boundaries, sphere);
        let path = std::path::Path::new("outside.toml");
        let scene = grainflow::scene::parse(&text, path, &[]).expect("parses");
        grainflow::run::Simulation::new(scene, path, None).map(|_| ())
    };
    for (sphere, side, what) in [
        (
            "radius = 0.1\nposition = [1.05, 0.5, 0.5]",
            "side xmax",
            "left the fluid box",
        ),
        (
            "radius = 0.4\nposition = [0.5, 0.5, 0.5]",
            "periodic direction y",
            "their own periodic image",
        ),
    ] {
        let err = build(sphere).expect_err(sphere).to_string();
        println!("{err}");
        assert!(
            err.contains("spheres[0]") && err.contains(side) && err.contains(what),
            "{err}"
        );
    }
    // centre inside, sphere past the outflow side: accepted
    build("radius = 0.1\nposition = [0.95, 0.5, 0.5]").expect("centre inside the box");
    // straddling a periodic side, or centre past it: accepted
    build("radius = 0.1\nposition = [0.5, 0.05, 0.5]").expect("straddling ymin");
    build("radius = 0.1\nposition = [0.5, 0.5, 1.02]").expect("centre past zmax");
    // leaving during the run
    let text = unit_box_scene(
        4,
        2,
        0.1,
        0.01,
        &boundaries,
        "radius = 0.1\nposition = [0.35, 0.5, 0.5]\nvelocity = [2.0, 0.0, 0.0]\nfixed = true",
    );
    let mut sim = simulation(&text, "leaving.toml");
    while sim.failure().is_none() && sim.world.resource::<FluidFlow>().stats.steps < 100 {
        sim.step();
    }
    let failure = sim.failure().expect("the run stops").to_string();
    println!("{failure}");
    assert!(
        failure.contains("particle 0")
            && failure.contains("side xmax")
            && failure.contains("left the fluid box")
            && failure.contains("before fluid step 34"),
        "{failure}"
    );
}

/// `grainflow check` shows the coupled step of the seed's sedimentation case: one fluid
/// step with its coupling, then n_s = 11 DEM substeps; the fluid step and its coupling
/// between the two halves of the first substep.
#[test]
fn check_shows_the_coupled_step() {
    let case =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/sedimentation-single.toml");
    let (code, stdout, stderr) = common::run_cli(&["check", case.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    let lines: Vec<&str> = stdout
        .lines()
        .skip_while(|l| !l.starts_with("schedule"))
        .take_while(|l| l.starts_with("schedule") || l.starts_with("  "))
        .collect();
    assert!(lines[0].contains("n_s = 11 DEM substeps"), "{stdout}");
    let at = |text: &str| {
        lines
            .iter()
            .position(|l| l.trim() == text)
            .unwrap_or_else(|| panic!("no `{text}` in\n{stdout}"))
    };
    let order = [
        at("[every DEM substep, first half]"),
        at("hertz_contact"),
        at("[fluid step and its coupling, in the first DEM substep of each fluid step]"),
        at("cell_markers"),
        at("multigrid_fluid"),
        at("hydrodynamic_sampling"),
        at("[every DEM substep, second half]"),
        at("held_hydrodynamic_force"),
        at("gear_correct"),
    ];
    assert!(order.windows(2).all(|w| w[0] < w[1]), "{order:?}\n{stdout}");
}
