//! Output files a user opens: the log on stderr (plain lines when it is not a terminal), particles.h5 (one group per frame, rows by stable id, the
//! `time` attribute), the particles.xdmf sidecar whose every data path exists in the HDF5
//! file, summary.json, the Chrome trace with a span per system, and particles read from a
//! LAMMPS `atom_style sphere` data file; coupling.csv written fluid step by fluid step; the
//! files of an earlier run in the output directory removed, the user's kept.
use std::path::Path;

use grainflow::run::Simulation;
use grainflow_systems::fluid::FluidFlow;

mod common;

const SCENE: &str = r#"
[simulation]
dt = 1.0e-5
end_time = 0.002
gravity = [0.0, 0.0, -9.81]
output_interval = 0.0005
[[materials]]
name = "glass"
density = 2500.0
youngs_modulus = 1.0e7
poisson_ratio = 0.25
restitution = 0.8
[[walls]]
type = "box"
material = "glass"
min = [0.0, 0.0, 0.0]
max = [0.02, 0.02, 0.02]
[[lammps]]
file = "atoms.data"
material = "glass"
"#;

const DATA: &str = "LAMMPS data file via write_data

3 atoms
1 atom types

0 0.02 xlo xhi
0 0.02 ylo yhi
0 0.02 zlo zhi

Atoms # sphere

3 1 0.002 2500 0.015 0.01 0.01 0 0 0
1 1 0.002 2500 0.005 0.01 0.01 0 0 0
2 1 0.004 2500 0.010 0.01 0.005 0 0 0

Velocities

1 0.1 0 0 0 0 0
2 0 0 -0.2 0 0 0
3 -0.1 0 0 0 0 0.5
";

#[test]
fn h5_xdmf_summary_and_trace_are_consistent() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::write_scene(dir.path(), "out.toml", SCENE);
    std::fs::write(dir.path().join("atoms.data"), DATA).unwrap();
    let out = dir.path().join("run");
    let trace = dir.path().join("trace.json");
    let (code, _, err) = common::run_cli(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--threads",
        "1",
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");

    let file = hdf5::File::open(out.join("particles.h5")).unwrap();
    let mut groups = file.member_names().unwrap();
    groups.sort();
    // t = 0, then every 0.5 ms to 2 ms: five frames.
    assert_eq!(
        groups,
        [
            "step_00000000",
            "step_00000050",
            "step_00000100",
            "step_00000150",
            "step_00000200"
        ]
    );
    let first = file.group("step_00000000").unwrap();
    let time: f64 = first.attr("time").unwrap().read_scalar().unwrap();
    assert_eq!(time, 0.0);
    let ids: Vec<u32> = first.dataset("id").unwrap().read_raw().unwrap();
    assert_eq!(ids, [0, 1, 2], "rows in stable id order");
    // Ids follow the LAMMPS ids in order: LAMMPS atom 1 is particle 0.
    let pos: Vec<f64> = first.dataset("position").unwrap().read_raw().unwrap();
    assert_eq!(&pos[0..3], &[0.005, 0.01, 0.01]);
    assert_eq!(&pos[6..9], &[0.015, 0.01, 0.01]);
    let radius: Vec<f64> = first.dataset("radius").unwrap().read_raw().unwrap();
    assert_eq!(radius, [0.001, 0.002, 0.001]);
    let vel: Vec<f64> = first.dataset("velocity").unwrap().read_raw().unwrap();
    assert_eq!(&vel[3..6], &[0.0, 0.0, -0.2]);
    let omega: Vec<f64> = first
        .dataset("angular_velocity")
        .unwrap()
        .read_raw()
        .unwrap();
    assert_eq!(omega[8], 0.5);
    let last = file.group("step_00000200").unwrap();
    let t_last: f64 = last.attr("time").unwrap().read_scalar().unwrap();
    assert!((t_last - 0.002).abs() < 1e-12);

    // Every HDF path in the XDMF sidecar exists.
    let xdmf = std::fs::read_to_string(out.join("particles.xdmf")).unwrap();
    let mut paths = 0;
    for item in xdmf.split("particles.h5:").skip(1) {
        let path = item.split('<').next().unwrap();
        assert!(
            file.dataset(path).is_ok(),
            "xdmf references {path}, missing in particles.h5"
        );
        paths += 1;
    }
    assert_eq!(paths, 5 * 5, "five datasets per frame");
    assert_eq!(xdmf.matches("<Time Value=").count(), 5);

    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["status"], "completed");
    assert_eq!(summary["steps"], 200);
    assert_eq!(summary["particles"], 3);
    assert!(summary["particle_steps_per_s"].as_f64().unwrap() > 0.0);

    let trace = std::fs::read_to_string(&trace).unwrap();
    for system in [
        "gear_predict",
        "verlet_list",
        "hertz_contact",
        "gear_correct",
        "stability_monitor",
    ] {
        assert!(trace.contains(system), "trace has a span for {system}");
    }
}

/// A log that goes to a pipe or a file (here a pipe) holds plain lines, without the
/// colour escape codes a terminal gets.
#[test]
fn a_piped_log_is_plain_text() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::write_scene(dir.path(), "out.toml", SCENE);
    std::fs::write(dir.path().join("atoms.data"), DATA).unwrap();
    let out = common::grainflow()
        .args(["run", scene.to_str().unwrap(), "--steps", "10", "--out"])
        .arg(dir.path().join("run"))
        .env("RUST_LOG", "info")
        .output()
        .unwrap();
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains(" INFO "), "info lines on stderr: {err}");
    assert!(
        !err.contains('\u{1b}'),
        "escape codes in a piped log: {err:?}"
    );
}

/// A run into the directory of an earlier one removes that run's files (here a flow and a
/// coupling history a dry scene does not write) and keeps the user's; a scene refused as
/// bad input leaves the directory as it was.
#[test]
fn a_run_removes_the_files_of_an_earlier_run_in_its_directory() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::write_scene(dir.path(), "out.toml", SCENE);
    std::fs::write(dir.path().join("atoms.data"), DATA).unwrap();
    let run_dir = dir.path().join("run");
    std::fs::create_dir(&run_dir).unwrap();
    let earlier = ["fluid.h5", "fluid.xdmf", "coupling.csv", "summary.json"];
    for name in earlier.iter().chain(&["notes.txt"]) {
        std::fs::write(run_dir.join(name), "earlier").unwrap();
    }
    let run = |scene: &Path| {
        common::run_cli(&[
            "run",
            scene.to_str().unwrap(),
            "--steps",
            "10",
            "--out",
            run_dir.to_str().unwrap(),
        ])
    };

    let bad = common::write_scene(
        dir.path(),
        "bad.toml",
        &SCENE.replace("dt = 1.0e-5", "dt = -1.0e-5"),
    );
    let (code, _, stderr) = run(&bad);
    assert_eq!(code, 2, "{stderr}");
    for name in earlier.iter().chain(&["notes.txt"]) {
        assert!(run_dir.join(name).exists(), "bad input removed {name}");
    }

    let (code, _, stderr) = run(&scene);
    assert_eq!(code, 0, "{stderr}");
    for name in ["fluid.h5", "fluid.xdmf", "coupling.csv"] {
        assert!(
            !run_dir.join(name).exists(),
            "{name} of the earlier run is left"
        );
    }
    let summary = std::fs::read_to_string(run_dir.join("summary.json")).unwrap();
    assert!(summary.contains("\"steps\": 10"), "{summary}");
    assert!(run_dir.join("particles.h5").exists());
    assert_eq!(
        std::fs::read_to_string(run_dir.join("notes.txt")).unwrap(),
        "earlier",
        "a file grainflow does not write is kept"
    );
}

#[test]
fn lammps_data_errors_name_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let bad = DATA.replace("2 1 0.004 2500", "2 1 -0.004 2500");
    std::fs::write(dir.path().join("atoms.data"), bad).unwrap();
    let scene = common::write_scene(dir.path(), "bad.toml", SCENE);
    let (code, _, err) = common::run_cli(&["check", scene.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("lammps[0].file") && err.contains("diameter"),
        "{err}"
    );
    let parsed = grainflow::lammps::read_data(Path::new("/nonexistent.data"));
    assert!(parsed.is_err());
}

/// `coupling.csv` grows by one line per particle at every fluid step while the run goes
/// on (a run that is killed or fails keeps its history), in the documented columns, and
/// ends with the run: here the seed's drag case at level 1, 0.25 s in fluid steps of 0.05.
#[test]
fn coupling_csv_is_written_as_the_run_goes() {
    let dir = tempfile::tempdir().expect("temp dir");
    let case = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/drag-sphere.toml");
    let text = std::fs::read_to_string(&case).expect("drag case");
    let overrides = ["fluid.level=1".to_string()];
    let scene = grainflow::scene::parse(&text, &case, &overrides).expect("drag case parses");
    let mut sim = Simulation::new(scene, &case, Some((dir.path(), 1.0))).expect("drag case builds");
    let csv = dir.path().join("coupling.csv");
    let lines = || {
        std::fs::read_to_string(&csv)
            .expect("coupling.csv")
            .lines()
            .count()
    };
    assert_eq!(lines(), 1, "the header, before any step");
    let fluid_steps = |sim: &Simulation| sim.world.resource::<FluidFlow>().stats.steps;
    while fluid_steps(&sim) < 3 {
        sim.step();
    }
    // the step that ran the third fluid step also sampled and recorded it
    assert_eq!(
        lines(),
        1 + 3,
        "one line per fluid step of the one sphere, so far"
    );
    let text = std::fs::read_to_string(&csv).expect("coupling.csv");
    let mut rows = text.lines();
    assert_eq!(rows.next(), Some("time,id,x,y,z,vx,vy,vz,fx,fy,fz"));
    for row in rows {
        let values: Vec<f64> = row.split(',').map(|v| v.parse().expect("number")).collect();
        assert_eq!(values.len(), 11, "{row}");
        assert_eq!(
            &values[2..5],
            &[1.0, 1.0, 1.0],
            "the fixed sphere's centre: {row}"
        );
    }
    let steps = (0.25 / sim.scene.simulation.dt).round() as u64;
    let now = sim.world.resource::<grainflow_components::SimClock>().step;
    assert!(sim.run(steps - now).failure.is_none());
    assert_eq!(lines() as u64, 1 + fluid_steps(&sim));
    assert_eq!(fluid_steps(&sim), 5);
}
