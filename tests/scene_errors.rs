//! Scene validation through the command line (no physical reference: the contract of
//! `src/scene.rs` and `src/cli.rs`): every bad scene makes `grainflow check` and
//! `grainflow run` exit with code 2, and the message names the scene file and the field
//! (`path: field `x.y`: what was expected`). A good scene passes `check` with exit code 0
//! and the printed schedule; a frictionless dry scene's schedule has no friction,
//! adhesion, rolling-resistance or fluid system, and lists only registered systems
//! (`grainflow_systems::REGISTRY`, plus the application's writer).
mod common;

use std::path::Path;

use common::*;

const GOOD: &str = r#"
[simulation]
dt = 2.0e-6
end_time = 1.0
gravity = [0.0, 0.0, -9.81]

[[materials]]
name = "steel"
density = 7800.0
youngs_modulus = 2.0e8
poisson_ratio = 0.3
restitution = 0.5

[[walls]]
type = "plane"
material = "steel"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]

[[spheres]]
material = "steel"
radius = 0.005
position = [0.0, 0.0, 0.05]
"#;

/// `GOOD` with the first occurrence of `from` replaced by `to`.
fn edited(from: &str, to: &str) -> String {
    assert!(GOOD.contains(from), "`{from}` is not in the good scene");
    GOOD.replacen(from, to, 1)
}

/// Both commands must reject `scene` with exit code 2 and name the file and `field`;
/// returns the message of the last.
fn rejected(dir: &Path, scene: &Path, extra: &[&str], field: &str) -> String {
    let path = scene.to_str().expect("utf-8 path");
    let out = dir.join("out");
    let out = out.to_str().expect("utf-8 path");
    let mut message = String::new();
    for command in [
        vec!["check", path],
        vec!["run", path, "--out", out, "--steps", "1"],
    ] {
        let args: Vec<&str> = command.iter().chain(extra).copied().collect();
        let (code, stdout, stderr) = run_cli(&args);
        assert_eq!(
            code, 2,
            "grainflow {args:?}: expected exit code 2\nstdout:\n{stdout}\nstderr:\n{stderr}"
        );
        assert!(
            stderr.contains(path),
            "grainflow {args:?}: the message does not name the file {path}:\n{stderr}"
        );
        assert!(
            stderr.contains(&format!("`{field}`")),
            "grainflow {args:?}: the message does not name the field `{field}`:\n{stderr}"
        );
        message = stderr;
    }
    message
}

#[test]
fn bad_scenes_exit_2_naming_file_and_field() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let sink = |body: &str| format!("{GOOD}\n[[sinks]]\n{body}\n");
    let cases: [(&str, String, &str); 11] = [
        (
            "sink_zero_normal.toml",
            sink("point = [0.0, 0.0, -1.0]\nnormal = [0.0, 0.0, 0.0]"),
            "sinks[0].normal",
        ),
        (
            "sink_nan_point.toml",
            sink("point = [0.0, nan, -1.0]\nnormal = [0.0, 0.0, 1.0]"),
            "sinks[0].point",
        ),
        (
            "sink_unknown_field.toml",
            sink("point = [0.0, 0.0, -1.0]\nnormal = [0.0, 0.0, 1.0]\nradious = 1.0"),
            "sinks[0].radious",
        ),
        (
            "sink_bad_radius.toml",
            sink("point = [0.0, 0.0, -1.0]\nnormal = [0.0, 0.0, 1.0]\nradius = -1.0"),
            "sinks[0].radius",
        ),
        (
            "unknown_field.toml",
            edited("dt = 2.0e-6", "dtt = 2.0e-6"),
            "simulation.dtt",
        ),
        (
            "wrong_type.toml",
            edited("dt = 2.0e-6", "dt = \"abc\""),
            "simulation.dt",
        ),
        (
            "negative_radius.toml",
            edited("radius = 0.005", "radius = -0.005"),
            "spheres[0].radius",
        ),
        (
            "outside_walls.toml",
            edited(
                "position = [0.0, 0.0, 0.05]",
                "position = [0.0, 0.0, -0.05]",
            ),
            "spheres[0]",
        ),
        (
            // 0.5 ms: some 12 times the stable limit of this scene (about 4e-5 s).
            "impossible_dt.toml",
            edited("dt = 2.0e-6", "dt = 5.0e-4"),
            "simulation.dt",
        ),
        (
            "unknown_wall_material.toml",
            edited(
                "[[walls]]\ntype = \"plane\"\nmaterial = \"steel\"",
                "[[walls]]\ntype = \"plane\"\nmaterial = \"steal\"",
            ),
            "walls[0].material",
        ),
        (
            "unknown_sphere_material.toml",
            edited(
                "[[spheres]]\nmaterial = \"steel\"",
                "[[spheres]]\nmaterial = \"iron\"",
            ),
            "spheres[0].material",
        ),
    ];
    for (name, text, field) in &cases {
        let path = write_scene(d, name, text);
        rejected(d, &path, &[], field);
    }
}

/// Contact-law fields: out of range, a parameter without its model, mu_d > mu_s, an
/// interaction naming an unknown material or giving no law, a Verlet skin shorter than
/// the JKR critical separation.
#[test]
fn bad_contact_laws_exit_2_naming_the_field() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let law = |line: &str| edited("restitution = 0.5", &format!("restitution = 0.5\n{line}"));
    let interaction = |body: &str| format!("{GOOD}\n[[interactions]]\n{body}\n");
    let cases = [
        (
            "negative_friction.toml",
            law("friction = -0.1"),
            "materials[0].friction",
        ),
        (
            "dynamic_above_static.toml",
            law("friction = 0.3\ndynamic_friction = 0.5"),
            "materials[0].dynamic_friction",
        ),
        (
            "damping_without_friction.toml",
            law("tangential_damping = 0.1"),
            "materials[0].tangential_damping",
        ),
        (
            "rolling_stiffness_without_rolling.toml",
            law("rolling_stiffness = 10.0"),
            "materials[0].rolling_stiffness",
        ),
        (
            "zero_work.toml",
            law("work_of_adhesion = 0.0"),
            "materials[0].work_of_adhesion",
        ),
        (
            "misspelt_law.toml",
            law("frictoin = 0.3"),
            "materials[0].frictoin",
        ),
        (
            "interaction_unknown_material.toml",
            interaction("materials = [\"steel\", \"rubber\"]\nfriction = 0.5"),
            "interactions[0].materials[1]",
        ),
        (
            "interaction_without_law.toml",
            interaction("materials = [\"steel\", \"steel\"]"),
            "interactions[0]",
        ),
        (
            // delta_s of steel on the steel wall (R* = 5 mm, E* = 1.1e8 Pa, W = 50 J/m^2)
            // is about 1.6e-5 m: a skin of 1e-6 m would lose stretched contacts.
            "skin_below_jkr_range.toml",
            format!(
                "{}\n[neighbour]\nskin = 1.0e-6\n",
                law("work_of_adhesion = 50.0")
            ),
            "neighbour.skin",
        ),
    ];
    for (name, text, field) in &cases {
        let path = write_scene(d, name, text);
        rejected(d, &path, &[], field);
    }
}

/// Checks of wall and inflow values that the types cannot express: NaN or out-of-order
/// numbers, negative jitter, an inflow region narrower than its particles.
/// The clump fields: a type with members that do not touch, an unknown type, a zero
/// orientation, a block naming both a clump and a radius, an inflow naming both a clump
/// and a material.
#[test]
fn bad_clump_values_exit_2_naming_the_field() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let ty = "\n[[clump_types]]\nname = \"pair\"\nmaterial = \"steel\"\n\
              spheres = [{ offset = [0.0, 0.0, 0.0], radius = 0.005 }, { offset = [0.006, 0.0, 0.0], radius = 0.005 }]\n";
    let clump = "\n[[clumps]]\ntype = \"pair\"\nposition = [0.0, 0.0, 0.1]\n";
    let block = "\n[[blocks]]\nclump = \"pair\"\nmin = [0.0, 0.0, 0.2]\nmax = [0.1, 0.1, 0.3]\n";
    let inflow = "\n[[inflows]]\nclump = \"pair\"\nrate = 100.0\ntotal = 10\n\
                  region = { type = \"box\", min = [0.0, 0.0, 0.4], max = [0.1, 0.1, 0.5] }\n";
    let penalty = "\n[fluid]\ndensity = 1000.0\nviscosity = 1.0e-6\nmin = [-0.5, -0.5, 0.0]\nmax = [0.5, 0.5, 1.0]\ncells = [2, 2, 2]\n\
                   level = 1\ndt = 1.0e-3\n\n[coupling]\nboundary = \"distance_penalty\"\n";
    let cases = [
        (
            "clump_apart.toml",
            format!("{GOOD}{}{clump}", ty.replace("0.006", "0.02")),
            "clump_types[0].shape",
        ),
        (
            "clump_unknown_type.toml",
            format!("{GOOD}{ty}{}", clump.replace("\"pair\"", "\"triple\"")),
            "clumps[0].type",
        ),
        (
            "clump_zero_orientation.toml",
            format!("{GOOD}{ty}{clump}orientation = [0.0, 0.0, 0.0, 0.0]\n"),
            "clumps[0].orientation",
        ),
        (
            "clump_block_radius.toml",
            format!("{GOOD}{ty}{block}radius = 0.005\n"),
            "blocks[0].radius",
        ),
        (
            "clump_inflow_material.toml",
            format!("{GOOD}{ty}{inflow}material = \"steel\"\n"),
            "inflows[0].material",
        ),
        (
            "clump_distance_penalty.toml",
            format!("{GOOD}{ty}{clump}{penalty}"),
            "coupling.boundary",
        ),
    ];
    for (name, text, field) in cases {
        let scene = write_scene(d, name, &text);
        rejected(d, &scene, &[], field);
    }
}

#[test]
fn bad_wall_and_inflow_values_exit_2_naming_the_field() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let cylinder = "\n[[walls]]\ntype = \"cylinder\"\nmaterial = \"steel\"\naxis = \"z\"\ncenter = [0.0, 0.0]\nradius = 0.5\n";
    let inflow = "\n[[inflows]]\nmaterial = \"steel\"\nrate = 100.0\ntotal = 10\nradii = [0.005]\nfractions = [1.0]\n\
                  region = { type = \"cylinder\", center = [0.0, 0.0], radius = 0.1, bottom = 0.1, top = 0.2 }\n";
    let pipe =
        "\n[[walls]]\ntype = \"pipe\"\nmaterial = \"steel\"\naxis = \"z\"\ncenter = [0.0, 0.0]\n\
                inner_radius = 0.2\nouter_radius = 0.3\nbottom = 0.5\ntop = 1.0\n";
    let with = |extra: &str, from: &str, to: &str| format!("{GOOD}{}", extra.replacen(from, to, 1));
    let cases = [
        (
            "pipe_inverted_wall.toml",
            with(pipe, "outer_radius = 0.3", "outer_radius = 0.1"),
            "walls[1].outer_radius",
        ),
        (
            "pipe_top_below_bottom.toml",
            with(pipe, "top = 1.0", "top = 0.4"),
            "walls[1].top",
        ),
        (
            "nan_center.toml",
            with(cylinder, "center = [0.0, 0.0]", "center = [nan, 0.0]"),
            "walls[1].center",
        ),
        (
            "nan_top.toml",
            with(
                cylinder,
                "radius = 0.5\n",
                "radius = 0.5\nbottom = 0.0\ntop = nan\n",
            ),
            "walls[1].top",
        ),
        (
            "negative_jitter.toml",
            with(inflow, "total = 10", "total = 10\nvelocity_jitter = -1.0"),
            "inflows[0].velocity_jitter",
        ),
        (
            "stop_before_start.toml",
            with(inflow, "total = 10", "total = 10\nstart = 0.5\nstop = 0.1"),
            "inflows[0].stop",
        ),
        (
            "narrow_region.toml",
            with(inflow, "radius = 0.1,", "radius = 0.004,"),
            "inflows[0].region.radius",
        ),
    ];
    // The unedited additions are accepted: the cases fail for the edited value alone.
    for extra in [cylinder, inflow, pipe] {
        let path = write_scene(d, "base.toml", &format!("{GOOD}{extra}"));
        let (code, _, stderr) = run_cli(&["check", path.to_str().unwrap()]);
        assert_eq!(code, 0, "{stderr}");
    }
    for (name, text, field) in &cases {
        let path = write_scene(d, name, text);
        rejected(d, &path, &[], field);
    }
}

/// `GOOD` in a fluid box of 2 x 2 x 2 coarse cells (a grid, so that the coupling and the
/// solver tolerances apply), followed by `extra`.
fn in_fluid(extra: &str) -> String {
    format!(
        "{GOOD}\n[fluid]\ndensity = 1000.0\nviscosity = 1.0e-6\nmin = [-0.05, -0.05, 0.0]\n\
         max = [0.05, 0.05, 0.1]\ncells = [2, 2, 2]\ndt = 1.0e-3\n{extra}\n"
    )
}

/// `coupling.update` takes "prescribed" or "fluid_momentum"; `fluid.momentum_rtol` and
/// `fluid.pressure_rtol` a number in (0, 1), and only with a grid.
#[test]
fn bad_coupling_update_and_solver_tolerances_exit_2_naming_the_field() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    // The good values are accepted: the cases fail for the edited value alone.
    for extra in [
        "momentum_rtol = 1.0e-4\npressure_rtol = 1.0e-6\n\n[coupling]\nupdate = \"prescribed\"",
        "[coupling]\nupdate = \"fluid_momentum\"",
        "[coupling]\nupdate = \"fluid_momentum\"\ninside_fluid = \"fluid\"",
    ] {
        let path = write_scene(d, "base.toml", &in_fluid(extra));
        let (code, _, stderr) = run_cli(&["check", path.to_str().unwrap()]);
        assert_eq!(code, 0, "{extra}\n{stderr}");
    }
    let update = |name: &str| in_fluid(&format!("[coupling]\nupdate = \"{name}\""));
    let message = rejected(
        d,
        &write_scene(d, "unknown_update.toml", &update("implicit")),
        &[],
        "coupling.update",
    );
    assert!(
        message.contains("implicit")
            && message.contains("fluid_momentum")
            && message.contains("prescribed"),
        "the message does not name the value and the accepted names:\n{message}"
    );
    let inside = in_fluid("[coupling]\nupdate = \"fluid_momentum\"\ninside_fluid = \"solid\"");
    let message = rejected(
        d,
        &write_scene(d, "unknown_inside_fluid.toml", &inside),
        &[],
        "coupling.inside_fluid",
    );
    assert!(
        message.contains("solid") && message.contains("particle") && message.contains("fluid"),
        "the message does not name the value and the accepted names:\n{message}"
    );
    for (name, value) in [
        ("zero", "0.0"),
        ("negative", "-1.0e-3"),
        ("one", "1.0"),
        ("above_one", "2.0"),
        ("nan", "nan"),
        ("infinite", "inf"),
    ] {
        for field in ["momentum_rtol", "pressure_rtol"] {
            let file = format!("{field}_{name}.toml");
            let path = write_scene(d, &file, &in_fluid(&format!("{field} = {value}")));
            let message = rejected(d, &path, &[], &format!("fluid.{field}"));
            assert!(
                message.contains("expected a number in (0, 1)"),
                "{file}: the message does not say what was expected:\n{message}"
            );
        }
    }
    // Without a grid a tolerance would be silently ignored.
    for field in ["momentum_rtol", "pressure_rtol"] {
        let text = format!("{GOOD}\n[fluid]\ndensity = 1000.0\n{field} = 1.0e-4\n");
        let path = write_scene(d, &format!("{field}_no_grid.toml"), &text);
        let message = rejected(d, &path, &[], &format!("fluid.{field}"));
        assert!(message.contains("without a grid"), "{message}");
    }
}

#[test]
fn bad_set_overrides_exit_2_naming_file_and_key() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let good = write_scene(d, "good.toml", GOOD);
    for (set, field) in [
        ("simulation.dtt=1e-6", "simulation.dtt"),
        ("simulation.dt=abc", "simulation.dt"),
        ("spheres.0.radius=-1", "spheres[0].radius"),
        ("walls.3.material=steel", "walls.3"),
        ("spheres.0.radius.x=1", "spheres.0.radius"),
        ("simulation.dt=5e-4", "simulation.dt"),
    ] {
        rejected(d, &good, &["--set", set], field);
    }
    // Not KEY=VALUE at all: no field to name, but the file and the item.
    let (code, _, stderr) = run_cli(&["check", good.to_str().unwrap(), "--set", "nonsense"]);
    assert_eq!(code, 2, "{stderr}");
    assert!(
        stderr.contains(good.to_str().unwrap()) && stderr.contains("--set nonsense"),
        "{stderr}"
    );
}

/// `grainflow run` of the good scene with `flags` must exit with code 2 before it steps,
/// naming the scene file and `flag`; returns the message.
fn run_flag_rejected(dir: &Path, flags: &[&str], flag: &str) -> String {
    let scene = write_scene(dir, "good.toml", GOOD);
    let out = dir.join("out");
    let mut args = vec![
        "run",
        scene.to_str().expect("utf-8 path"),
        "--out",
        out.to_str().expect("utf-8 path"),
    ];
    args.extend_from_slice(flags);
    let (code, stdout, stderr) = run_cli(&args);
    assert_eq!(
        code, 2,
        "grainflow {args:?}: expected exit code 2\nstdout:\n{stdout}\nstderr:\n{stderr}"
    );
    assert!(
        stderr.contains(&format!("`{flag}`")) && stderr.contains(args[1]),
        "grainflow {args:?}: the message does not name `{flag}` and the scene:\n{stderr}"
    );
    assert!(
        !out.join("summary.json").exists(),
        "grainflow {args:?}: a refused run wrote output"
    );
    stderr
}

#[test]
fn a_trace_file_that_cannot_be_created_exits_2_naming_the_path() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let missing = d.join("no-such-dir").join("trace.json");
    let missing = missing.to_str().expect("utf-8 path");
    let stderr = run_flag_rejected(d, &["--steps", "1", "--trace", missing], "--trace");
    assert!(stderr.contains(missing), "{stderr}");
    let directory = d.to_str().expect("utf-8 path");
    let stderr = run_flag_rejected(d, &["--steps", "1", "--trace", directory], "--trace");
    assert!(
        stderr.contains(&format!("trace file {directory}")),
        "{stderr}"
    );
}

#[test]
fn threads_out_of_range_exit_2() {
    let dir = tempfile::tempdir().expect("temp dir");
    for threads in ["0", "100000"] {
        let stderr = run_flag_rejected(
            dir.path(),
            &["--steps", "1", "--threads", threads],
            "--threads",
        );
        assert!(
            stderr.contains("expected 1 to") && stderr.contains(&format!("got {threads}")),
            "{stderr}"
        );
    }
}

#[test]
fn step_counts_beyond_1e12_exit_2_naming_the_flag_and_dt() {
    let dir = tempfile::tempdir().expect("temp dir");
    let stderr = run_flag_rejected(dir.path(), &["--until", "1e300"], "--until");
    assert!(
        stderr.contains("5.000e305 steps of dt = 2.000e-6 s") && stderr.contains("at most 1e12"),
        "{stderr}"
    );
    let stderr = run_flag_rejected(dir.path(), &["--steps", "18446744073709551615"], "--steps");
    assert!(stderr.contains("1.845e19 steps"), "{stderr}");
}

/// The system names of `grainflow check`'s schedule block.
fn schedule(stdout: &str) -> Vec<String> {
    let mut lines = stdout
        .lines()
        .skip_while(|l| !l.starts_with("schedule"))
        .skip(1);
    let mut names = Vec::new();
    for l in lines.by_ref() {
        if !l.starts_with("  ") {
            break;
        }
        if l.starts_with("    ") {
            names.push(l.trim().to_string());
        }
    }
    names
}

/// The systems that friction, rolling resistance or adhesion bring (contact with
/// history, wall-contact history, rotation), absent from frictionless dry scenes.
const CONTACT_LAW_SYSTEMS: [&str; 6] = [
    "granular_contact",
    "carry_wall_history",
    "gear_rotation_predict",
    "gear_rotation_correct",
    "sync_rows<Rotation>",
    "permute_rows<Rotation>",
];

#[test]
fn good_frictionless_scene_checks_and_shows_its_schedule() {
    let dir = tempfile::tempdir().expect("temp dir");
    let good = write_scene(dir.path(), "good.toml", GOOD);
    let (code, stdout, stderr) = run_cli(&["check", good.to_str().unwrap()]);
    assert_eq!(code, 0, "stdout:\n{stdout}\nstderr:\n{stderr}");
    assert!(!stdout.contains("warning"), "{stdout}");
    let names = schedule(&stdout);
    for needed in [
        "verlet_list",
        "hertz_contact",
        "gear_predict",
        "gear_correct",
    ] {
        assert!(
            names.iter().any(|n| n == needed),
            "schedule lacks {needed}: {names:?}"
        );
    }
    let registered: Vec<&str> = grainflow_systems::REGISTRY
        .iter()
        .map(|e| e.name)
        .chain(["write_particles"])
        .collect();
    for name in &names {
        assert!(
            registered.contains(&name.as_str()),
            "`{name}` is not a registered system"
        );
        for model in CONTACT_LAW_SYSTEMS.iter().chain(&["fluid"]) {
            assert!(
                !name.contains(model),
                "a frictionless dry scene runs `{name}`: {names:?}"
            );
        }
    }
    // With friction and rolling resistance the contact system with history and the
    // rotation integrator replace the frictionless contact.
    let (code, stdout, _) = run_cli(&[
        "check",
        good.to_str().unwrap(),
        "--set",
        "materials.0.friction=0.5",
        "--set",
        "materials.0.rolling_friction=0.1",
    ]);
    assert_eq!(code, 0);
    let frictional = schedule(&stdout);
    for name in CONTACT_LAW_SYSTEMS {
        assert!(
            frictional.iter().any(|n| n == name),
            "the frictional scene lacks {name}: {frictional:?}"
        );
    }
    assert!(
        !frictional.iter().any(|n| n == "hertz_contact"),
        "{frictional:?}"
    );
    // Velocity Verlet swaps the integrator systems and nothing else.
    let (code, stdout, _) = run_cli(&[
        "check",
        good.to_str().unwrap(),
        "--set",
        "simulation.integrator=velocity_verlet",
    ]);
    assert_eq!(code, 0);
    let verlet = schedule(&stdout);
    assert!(verlet.iter().any(|n| n == "verlet_predict"), "{verlet:?}");
    assert!(!verlet.iter().any(|n| n.contains("gear")), "{verlet:?}");
}

/// The lubrication fields: `lubrication_range` and `lubrication_roughness` positive, only
/// with `lubrication = true`, the roughness below the range (given or the cell size), and
/// an explicit Verlet skin larger than the range.
#[test]
fn bad_lubrication_settings_exit_2_naming_the_field() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let good = in_fluid("[coupling]\nlubrication = true\nlubrication_range = 0.02");
    let path = write_scene(d, "lub.toml", &good);
    let (code, _, stderr) = run_cli(&["check", path.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    for (file, extra, field, expected) in [
        (
            "range_alone.toml",
            "[coupling]\nlubrication_range = 0.02",
            "coupling.lubrication_range",
            "without `lubrication = true`",
        ),
        (
            "range_negative.toml",
            "[coupling]\nlubrication = true\nlubrication_range = -0.02",
            "coupling.lubrication_range",
            "expected a finite number > 0",
        ),
        (
            "rough_above_range.toml",
            "[coupling]\nlubrication = true\nlubrication_range = 0.02\nlubrication_roughness = 0.03",
            "coupling.lubrication_roughness",
            "expected a gap below",
        ),
        (
            "rough_above_cell.toml",
            "[coupling]\nlubrication = true\nlubrication_roughness = 0.5",
            "coupling.lubrication_roughness",
            "expected a gap below the lubrication range",
        ),
        (
            "skin_below_range.toml",
            "[coupling]\nlubrication = true\nlubrication_range = 0.02\n\n[neighbour]\nskin = 0.01",
            "neighbour.skin",
            "lubrication range",
        ),
    ] {
        let path = write_scene(d, file, &in_fluid(extra));
        let message = rejected(d, &path, &[], field);
        assert!(message.contains(expected), "{file}: {message}");
    }
}

/// `coupling.boundary` takes "face_centre" or "distance_penalty"; the penalty needs the
/// volume-integral force and no blending.
#[test]
fn bad_boundary_rules_exit_2_naming_the_field() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let good = in_fluid("[coupling]\nboundary = \"distance_penalty\"");
    let path = write_scene(d, "penalty.toml", &good);
    let (code, _, stderr) = run_cli(&["check", path.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    for (file, extra, expected) in [
        (
            "unknown.toml",
            "[coupling]\nboundary = \"staircase\"",
            "face_centre",
        ),
        (
            "surface_points.toml",
            "[coupling]\nboundary = \"distance_penalty\"\nforce = \"surface_points\"",
            "expected force = \"volume_integral\"",
        ),
        (
            "blending.toml",
            "[coupling]\nboundary = \"distance_penalty\"\nalpha = 0.1",
            "expected no `alpha`",
        ),
    ] {
        let path = write_scene(d, file, &in_fluid(extra));
        let message = rejected(d, &path, &[], "coupling.boundary");
        assert!(message.contains(expected), "{file}: {message}");
    }
}

/// A scene whose state would not fit in the machine's memory is refused before anything
/// is allocated (exit 2), naming its largest source, the estimate and what is available
/// (`src/memory.rs`: at least 285 bytes per particle and 200 per fluid degree of
/// freedom). A block of about 10^11 sites (some 30 TB) and a fluid grid of 2048^3 cells
/// (some 20 TB) exceed any machine this runs on.
#[test]
fn scenes_beyond_the_machines_memory_exit_2_naming_the_source() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let block = format!(
        "{GOOD}\n[[blocks]]\nmaterial = \"steel\"\nradius = 1.0e-4\nmin = [-0.5, -0.5, 0.1]\n\
         max = [0.5, 0.5, 1.1]\n"
    );
    let grid = in_fluid("").replace("cells = [2, 2, 2]", "cells = [16, 16, 16]\nlevel = 8");
    for (name, text, field) in [
        ("huge_block.toml", block, "blocks[0]"),
        ("huge_grid.toml", grid, "fluid.level"),
    ] {
        let path = write_scene(d, name, &text);
        let message = rejected(d, &path, &[], field);
        assert!(
            message.contains("GB") && message.contains("available"),
            "{name}: the message gives no estimate against available memory:\n{message}"
        );
    }
}

/// `[[fluid.obstacles]]` and `[[fluid.outlets]]` (src/scene.rs, `validate_obstacle` and the
/// outlet checks): finite coordinates, positive sizes, ordered bounds, only with a grid.
#[test]
fn bad_obstacles_and_outlets_exit_2_naming_the_field() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let pipe = "[[fluid.obstacles]]\ntype = \"pipe\"\naxis = \"z\"\ncenter = [0.0, 0.0]\n\
                inner_radius = 0.01\nouter_radius = 0.02\nbottom = 0.02\ntop = 0.08";
    let block =
        "[[fluid.obstacles]]\ntype = \"box\"\nmin = [-0.05, -0.05, 0.0]\nmax = [0.05, 0.05, 0.01]";
    let outlet = "[fluid.boundaries]\nzmax = { type = \"outflow\" }\n\n[[fluid.outlets]]\n\
                  side = \"zmax\"\ncenter = [0.0, 0.0]\nradius = 0.02\nvelocity = 0.1";
    for good in [pipe, block, outlet] {
        let path = write_scene(d, "good.toml", &in_fluid(good));
        let (code, _, stderr) = run_cli(&["check", path.to_str().unwrap()]);
        assert_eq!(code, 0, "{good}\n{stderr}");
    }
    for (file, text, field, expected) in [
        (
            "inner",
            pipe.replace("inner_radius = 0.01", "inner_radius = -0.01"),
            "fluid.obstacles[0].inner_radius",
            "> 0",
        ),
        (
            "outer",
            pipe.replace("outer_radius = 0.02", "outer_radius = 0.01"),
            "fluid.obstacles[0].outer_radius",
            "outer_radius > inner_radius",
        ),
        (
            "top",
            pipe.replace("top = 0.08", "top = 0.01"),
            "fluid.obstacles[0].top",
            "top > bottom",
        ),
        (
            "centre",
            pipe.replace("center = [0.0, 0.0]", "center = [nan, 0.0]"),
            "fluid.obstacles[0].center",
            "finite",
        ),
        (
            "box",
            block.replace("max = [0.05, 0.05, 0.01]", "max = [0.05, 0.05, -0.01]"),
            "fluid.obstacles[0].max",
            "max > min",
        ),
        (
            "radius",
            outlet.replace("radius = 0.02", "radius = 0.0"),
            "fluid.outlets[0].radius",
            "> 0",
        ),
        (
            "speed",
            outlet.replace("velocity = 0.1", "velocity = inf"),
            "fluid.outlets[0].velocity",
            "finite",
        ),
        (
            "closed",
            outlet.replace("zmax = { type = \"outflow\" }", ""),
            "fluid.outlets",
            "outflow",
        ),
    ] {
        let path = write_scene(d, &format!("{file}.toml"), &in_fluid(&text));
        let message = rejected(d, &path, &[], field);
        assert!(message.contains(expected), "{file}: {message}");
    }
    // Without a grid an obstacle or outlet would be silently ignored.
    for (file, text, field) in [
        ("pipe", pipe, "fluid.obstacles"),
        ("outlet", outlet, "fluid.outlets"),
    ] {
        let text = format!("{GOOD}\n[fluid]\ndensity = 1000.0\n{text}\n");
        let path = write_scene(d, &format!("{file}_no_grid.toml"), &text);
        let message = rejected(d, &path, &[], field);
        assert!(message.contains("without a grid"), "{message}");
    }
}
