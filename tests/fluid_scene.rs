//! The fluid part of scene files (`[fluid]`, docs/scene-format.md) through the command
//! line: `grainflow check` on the seed's sedimentation box lists the degrees of freedom of
//! levels 1 to 5 exactly as the seed's "MG-Level" table (5 x 5 x 25 coarse cells: 7,075 /
//! 53,300 / 413,200 / 3,252,800 / 25,811,200; 3 x faces + cells of the Q1~/Q0 pair), and
//! bad fluid input exits 2 naming the field.
mod common;

use std::path::Path;

use common::*;

fn channel() -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/channel-10x2x2.toml"))
        .expect("channel case")
}

#[test]
fn check_lists_the_seeds_dof_table() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = write_scene(dir.path(), "channel.toml", &channel());
    let (code, stdout, stderr) = run_cli(&["check", scene.to_str().unwrap()]);
    assert_eq!(code, 0, "stdout:\n{stdout}\nstderr:\n{stderr}");
    // Seed, "A single sedimenting sphere": cells, cell faces and DOFs of levels 1-5.
    let table = [
        (1, 625, 2_150, 7_075),
        (2, 5_000, 16_100, 53_300),
        (3, 40_000, 124_400, 413_200),
        (4, 320_000, 977_600, 3_252_800),
        (5, 2_560_000, 7_750_400, 25_811_200),
    ];
    for (level, cells, faces, dofs) in table {
        let line = stdout
            .lines()
            .find(|l| l.split_whitespace().next() == Some(&level.to_string()))
            .unwrap_or_else(|| panic!("no line for level {level}:\n{stdout}"));
        let words: Vec<&str> = line.split_whitespace().collect();
        assert!(
            words.contains(&format!("{cells}").as_str())
                && words.contains(&format!("{faces}").as_str())
                && words.contains(&format!("{dofs}").as_str()),
            "level {level}: expected {cells} cells, {faces} faces, {dofs} DOFs in `{line}`"
        );
    }
    // --set fluid.level moves the run's level; a fluid-only scene runs no DEM system.
    let (code, stdout, _) = run_cli(&["check", scene.to_str().unwrap(), "--set", "fluid.level=4"]);
    assert_eq!(code, 0);
    let marked = stdout
        .lines()
        .find(|l| l.contains("<- this run"))
        .expect("marked level");
    assert!(marked.contains("3252800"), "{marked}");
    for dem in ["verlet_list", "hertz_contact", "gear_predict"] {
        assert!(
            !stdout.contains(dem),
            "a fluid-only scene runs {dem}:\n{stdout}"
        );
    }
}

#[test]
fn bad_fluid_input_exits_2_naming_the_field() {
    let dir = tempfile::tempdir().expect("temp dir");
    let base = channel();
    let edit = |from: &str, to: &str| {
        assert!(base.contains(from), "`{from}` not in the channel case");
        base.replacen(from, to, 1)
    };
    let cases = [
        (
            "zero_viscosity.toml",
            edit("viscosity = 0.01", "viscosity = 0.0"),
            "fluid.viscosity",
        ),
        (
            // 0.3 does not divide the box sides 10 and 2.
            "undivided.toml",
            edit("cells = [25, 5, 5]", "cell_size = 0.3"),
            "fluid.cell_size",
        ),
        (
            "level_zero.toml",
            edit("level = 2", "level = 0"),
            "fluid.level",
        ),
        (
            "negative_dt.toml",
            edit("dt = 1.0e-3\nscheme", "dt = -1.0e-3\nscheme"),
            "fluid.dt",
        ),
        (
            "half_periodic.toml",
            edit(
                "xmax = { type = \"outflow\" }",
                "xmax = { type = \"periodic\" }",
            ),
            "fluid.boundaries.xmin",
        ),
        (
            "misspelt.toml",
            edit("viscosity = 0.01", "viscosty = 0.01"),
            "fluid.viscosty",
        ),
        (
            "grid_without_viscosity.toml",
            edit("viscosity = 0.01\n", ""),
            "fluid.viscosity",
        ),
        (
            "unknown_viscous_form.toml",
            edit("scheme = ", "viscous = \"stress\"\nscheme = "),
            "fluid.viscous",
        ),
        (
            "zero_upwind.toml",
            edit("scheme = ", "upwind = 0.0\nscheme = "),
            "fluid.upwind",
        ),
        (
            "negative_solve_upwind.toml",
            edit("scheme = ", "solve_upwind = -0.1\nscheme = "),
            "fluid.solve_upwind",
        ),
        (
            "nan_body_force.toml",
            edit("scheme = ", "body_force = [1.0, nan, 0.0]\nscheme = "),
            "fluid.body_force",
        ),
        (
            // U dt / h = 1 x 2.0 / 0.2 = 10 > 8, the fractional-step limit
            "cfl_too_large.toml",
            edit("dt = 1.0e-3\nscheme", "dt = 2.0\nscheme"),
            "fluid.dt",
        ),
    ];
    check_rejects(dir.path(), &cases);
}

/// A run of the channel (level 1, 10 fluid steps) reports its solver in `summary.json`:
/// level, DOFs, steps, and a pressure multigrid reducing the residual by at most 0.1 per
/// V-cycle (the bar for the pressure Poisson problem); the discrete divergence
/// after each step stays at the solver tolerance.
#[test]
fn fluid_run_reports_its_solver() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = write_scene(dir.path(), "channel.toml", &channel());
    let out = dir.path().join("out");
    let (code, stdout, stderr) = run_cli(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--steps",
        "10",
        "--set",
        "fluid.level=1",
    ]);
    assert_eq!(code, 0, "stdout:\n{stdout}\nstderr:\n{stderr}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let fluid = &summary["fluid"];
    assert_eq!(fluid["level"], 1, "{fluid}");
    assert_eq!(fluid["dofs"], 7075, "{fluid}");
    assert_eq!(fluid["steps"], 10, "{fluid}");
    // the median of ten steps is at most twice their mean (five steps are at least as
    // long), the first step at most their sum
    let seconds = |k: &str| fluid[k].as_f64().unwrap_or_else(|| panic!("{k}: {fluid}"));
    let (mean, median, first) = (
        seconds("mean_step_s"),
        seconds("median_step_s"),
        seconds("first_step_s"),
    );
    assert!(median > 0.0 && first > 0.0, "{fluid}");
    assert!(median <= 2.0 * mean && first <= 10.0 * mean, "{fluid}");
    let rate = fluid["pressure"]["mean_reduction_per_cycle"]
        .as_f64()
        .unwrap();
    assert!(
        rate > 0.0 && rate <= 0.1,
        "pressure multigrid: {rate} per cycle"
    );
    let divergence = fluid["max_divergence"].as_f64().unwrap();
    assert!(divergence < 1e-6, "divergence after a step: {divergence}");
    // fluid.h5: the first and last frames, cell-centred velocity and pressure on the
    // 25 x 5 x 5 cells of level 1, the inflow moving the fluid along +x; fluid.xdmf beside.
    let file = hdf5::File::open(out.join("fluid.h5")).expect("fluid.h5");
    let frames = file.member_names().expect("frames");
    assert_eq!(frames, ["step_00000000", "step_00000010"], "{frames:?}");
    let last = file.group("step_00000010").expect("last frame");
    let velocity: Vec<f64> = last.dataset("velocity").unwrap().read_raw().unwrap();
    let pressure: Vec<f64> = last.dataset("pressure").unwrap().read_raw().unwrap();
    assert_eq!((velocity.len(), pressure.len()), (3 * 625, 625));
    let mean_u: f64 = velocity.chunks(3).map(|v| v[0]).sum::<f64>() / 625.0;
    assert!(
        mean_u > 0.05,
        "the inflow does not move the fluid: mean u_x {mean_u}"
    );
    let xdmf = std::fs::read_to_string(out.join("fluid.xdmf")).expect("fluid.xdmf");
    assert!(xdmf.contains("3DCoRectMesh") && xdmf.contains("fluid.h5:/step_00000010/pressure"));
}

/// `fluid.viscous` selects the viscous term ("laplacian", the default, or "deformation",
/// the seed's stress tensor), `fluid.upwind` the upwind scale and `fluid.solve_upwind`
/// that of the solved operator (deferred correction); `grainflow check` names them and
/// reports the CFL number with
/// its limit for the scheme and the viscous number; the CFL limit is enforced per scheme
/// (dt = 1.0 on level 2 of the channel is U dt / h = 5: refused for Crank-Nicolson, limit
/// 2, accepted for fractional-step theta, limit 8); a deformation-form run of the channel
/// (level 1, 3 steps) succeeds.
#[test]
fn viscous_form_and_time_step_limits() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = write_scene(dir.path(), "channel.toml", &channel());
    let s = scene.to_str().unwrap();
    let (code, stdout, stderr) = run_cli(&["check", s]);
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stdout.contains("viscous term Laplacian, pressure force Normal, upwind scale 1,"),
        "{stdout}"
    );
    let (code, stdout, stderr) = run_cli(&["check", s, "--set", "fluid.upwind=0.1"]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("upwind scale 0.1,"), "{stdout}");
    assert!(stdout.contains("CFL U dt/h = 0.005"), "{stdout}");
    assert!(stdout.contains("limit 8 for FractionalStep"), "{stdout}");
    assert!(!stdout.contains("deferred upwind correction"), "{stdout}");
    let (code, stdout, stderr) = run_cli(&[
        "check",
        s,
        "--set",
        "fluid.upwind=0.03",
        "--set",
        "fluid.solve_upwind=0.1",
    ]);
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stdout.contains(
            "deferred upwind correction: the momentum multigrid solves with upwind scale 0.1"
        ),
        "{stdout}"
    );
    let (code, stdout, stderr) = run_cli(&["check", s, "--set", "fluid.viscous=deformation"]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("viscous term Deformation"), "{stdout}");
    // level 2: h = 0.2, U = 1 (inflow peak): dt = 1.0 gives U dt / h = 5
    let (code, _, stderr) = run_cli(&["check", s, "--set", "fluid.dt=1.0"]);
    assert_eq!(code, 0, "fractional step at CFL 5: {stderr}");
    let (code, _, stderr) = run_cli(&[
        "check",
        s,
        "--set",
        "fluid.dt=1.0",
        "--set",
        "fluid.scheme=crank_nicolson",
    ]);
    assert_eq!(code, 2, "Crank-Nicolson at CFL 5: {stderr}");
    assert!(stderr.contains("`fluid.dt`"), "{stderr}");
    let out = dir.path().join("out");
    let (code, stdout, stderr) = run_cli(&[
        "run",
        s,
        "--out",
        out.to_str().unwrap(),
        "--steps",
        "3",
        "--set",
        "fluid.level=1",
        "--set",
        "fluid.viscous=deformation",
    ]);
    assert_eq!(code, 0, "stdout:\n{stdout}\nstderr:\n{stderr}");
}

/// Bad `[coupling]` input (docs/scene-format.md, `[coupling]`): exit 2 naming the field.
#[test]
fn bad_coupling_input_exits_2_naming_the_field() {
    let dir = tempfile::tempdir().expect("temp dir");
    let base = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/sedimentation-single.toml"),
    )
    .expect("sedimentation case");
    let edit = |from: &str, to: &str| {
        assert!(
            base.contains(from),
            "`{from}` not in the sedimentation case"
        );
        base.replacen(from, to, 1)
    };
    let coupling = "force = \"volume_integral\"";
    let cases = [
        (
            "negative_alpha.toml",
            edit(coupling, "alpha = -0.1"),
            "coupling.alpha",
        ),
        (
            "no_rule.toml",
            edit(coupling, "points = 7"),
            "coupling.points",
        ),
        (
            "unknown_method.toml",
            edit(coupling, "force = \"drag_law\""),
            "coupling.force",
        ),
        (
            "misspelt.toml",
            edit(coupling, "alpah = 0.1"),
            "coupling.alpah",
        ),
        (
            // a [coupling] section without particles (nor walls)
            "no_particles.toml",
            base[..base.find("[[walls]]").expect("a wall")].to_string(),
            "coupling",
        ),
    ];
    check_rejects(dir.path(), &cases);
}

/// `grainflow check` on each (file name, scene text, field) exits 2 naming the field.
fn check_rejects(dir: &Path, cases: &[(&str, String, &str)]) {
    for (name, text, field) in cases {
        let path = write_scene(dir, name, text);
        let (code, _, stderr) = run_cli(&["check", path.to_str().unwrap()]);
        assert_eq!(code, 2, "{name}: expected exit 2\n{stderr}");
        assert!(
            stderr.contains(&format!("`{field}`")),
            "{name}: the message does not name `{field}`:\n{stderr}"
        );
    }
}
