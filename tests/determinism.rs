//! Reproducibility of runs (no physical reference: the property is that the result is a
//! function of the scene alone). grainflow's contact loop sums each particle's forces over
//! its own row of the full Verlet list in list order, and every reduction runs over fixed
//! chunks of `grainflow_systems::CHUNK` rows added in chunk order (`systems/src/lib.rs`,
//! `hertz.rs`, `monitor.rs`), so the thread count must not change a single bit.
//!
//! The CLI runs a small scene (two polydisperse blocks, about 3500 spheres, so that the
//! work is split in two chunks of 2048 rows and the two threads really share it; one falls
//! onto the other in a box) with `--threads 1` and `--threads 2`, and again with
//! `--threads 2`. Every dataset and attribute of every frame of `particles.h5` must be
//! bitwise identical, and so must `kinetic_energy` and `max_overlap_ratio` of
//! `summary.json`. Tolerance: none (bit equality).
mod common;

use std::collections::BTreeMap;
use std::path::Path;

use common::*;

const SCENE: &str = r#"
[simulation]
dt = 5e-6
end_time = 1.0
gravity = [0.0, 0.0, -9.81]
output_interval = 2.5e-4

[[materials]]
name = "grain"
density = 2500.0
youngs_modulus = 1e7
poisson_ratio = 0.3
restitution = 0.5

[[walls]]
type = "box"
material = "grain"
min = [0.0, 0.0, 0.0]
max = [0.04, 0.04, 0.05]

# Lower block, at rest on the floor.
[[blocks]]
material = "grain"
radius = 1.0e-3
min = [1.2e-3, 1.2e-3, 1.2e-3]
max = [0.0388, 0.0388, 0.0095]
spacing = 2.3e-3
jitter = 1.0
count = 1700

# Upper block of smaller spheres falling onto it at 1 m/s, moving sideways.
[[blocks]]
material = "grain"
radius = 0.6e-3
min = [0.8e-3, 0.8e-3, 0.0105]
max = [0.0392, 0.0392, 0.0160]
spacing = 1.4e-3
jitter = 1.0
velocity = [0.3, -0.2, -1.0]
count = 1800
"#;

/// Everything in `particles.h5`: (frame/dataset or frame@attribute) -> raw bits.
fn read_h5(path: &Path) -> BTreeMap<String, Vec<u64>> {
    let file = hdf5::File::open(path).expect("open particles.h5");
    let mut out = BTreeMap::new();
    for frame in file.member_names().expect("list frames") {
        let group = file.group(&frame).expect("frame group");
        let time: f64 = group
            .attr("time")
            .and_then(|a| a.read_scalar())
            .expect("time attribute");
        out.insert(format!("{frame}@time"), vec![time.to_bits()]);
        for name in group.member_names().expect("list datasets") {
            let ds = group.dataset(&name).expect("dataset");
            let bits: Vec<u64> = if name == "id" || name == "clump" {
                ds.read_raw::<u32>()
                    .expect("read ids")
                    .into_iter()
                    .map(u64::from)
                    .collect()
            } else {
                ds.read_raw::<f64>()
                    .expect("read data")
                    .into_iter()
                    .map(f64::to_bits)
                    .collect()
            };
            out.insert(format!("{frame}/{name}"), bits);
        }
    }
    out
}

struct RunResult {
    h5: BTreeMap<String, Vec<u64>>,
    summary: serde_json::Value,
}

fn run(scene: &Path, out: &Path, threads: usize) -> RunResult {
    let (code, stdout, stderr) = run_cli(&[
        "run",
        scene.to_str().expect("utf-8 path"),
        "--out",
        out.to_str().expect("utf-8 path"),
        "--steps",
        "600",
        "--threads",
        &threads.to_string(),
    ]);
    assert_eq!(
        code, 0,
        "run with {threads} threads failed\nstdout:\n{stdout}\nstderr:\n{stderr}"
    );
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("summary.json")).expect("summary.json"),
    )
    .expect("summary.json is JSON");
    RunResult {
        h5: read_h5(&out.join("particles.h5")),
        summary,
    }
}

fn assert_identical(a: &RunResult, b: &RunResult, what: &str) {
    assert_eq!(
        a.h5.keys().collect::<Vec<_>>(),
        b.h5.keys().collect::<Vec<_>>(),
        "{what}: particles.h5 holds different frames or datasets"
    );
    for (key, bits) in &a.h5 {
        let other = &b.h5[key];
        assert_eq!(bits.len(), other.len(), "{what}: {key} has another length");
        if let Some(k) = (0..bits.len()).find(|&k| bits[k] != other[k]) {
            panic!(
                "{what}: {key} differs first at element {k}: {:e} vs {:e}",
                f64::from_bits(bits[k]),
                f64::from_bits(other[k])
            );
        }
    }
    for field in ["kinetic_energy", "max_overlap_ratio", "total_steps"] {
        let (x, y) = (&a.summary[field], &b.summary[field]);
        assert!(!x.is_null(), "summary.json has no {field}");
        assert_eq!(x, y, "{what}: summary.json {field} differs");
    }
}

#[test]
fn thread_count_and_repetition_do_not_change_a_bit() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = write_scene(dir.path(), "determinism.toml", SCENE);
    let one = run(&scene, &dir.path().join("t1"), 1);
    let two = run(&scene, &dir.path().join("t2"), 2);
    let again = run(&scene, &dir.path().join("t2-again"), 2);

    // Not vacuous: more than one chunk of rows, several frames, real contacts.
    let n = one.summary["particles"].as_u64().expect("particle count");
    assert!(
        n as usize > grainflow_systems::CHUNK,
        "only {n} particles: the thread split is not exercised"
    );
    let frames = one.h5.keys().filter(|k| k.ends_with("/position")).count();
    assert!(frames >= 10, "only {frames} frames written");
    let overlap = one.summary["max_overlap_ratio"].as_f64().expect("overlap");
    assert!(overlap > 1e-3, "hardly any contact in the run ({overlap})");
    eprintln!("{n} particles, {frames} frames, largest overlap ratio {overlap:.3e}");

    assert_identical(&one, &two, "--threads 1 against --threads 2");
    assert_identical(&two, &again, "two runs with --threads 2");
}

/// The same scene with the upper block slow (settling, not falling): slow enough for the
/// rows to be narrowed between rebuilds (`VerletList::near_end`), whose decisions must
/// not depend on the thread count either.
#[test]
fn narrowed_rows_do_not_change_a_bit() {
    let dir = tempfile::tempdir().expect("temp dir");
    // The lower block a lattice of touching spheres standing on the floor (contacts under
    // their weight from the start), the upper block just above it.
    let text = SCENE
        .replace(
            "velocity = [0.3, -0.2, -1.0]",
            "velocity = [0.0, 0.0, -0.01]",
        )
        .replace("spacing = 2.3e-3", "spacing = 2.0e-3")
        .replace(
            "min = [1.2e-3, 1.2e-3, 1.2e-3]",
            "min = [1.2e-3, 1.2e-3, 1.0e-3]",
        )
        .replace(
            "max = [0.0388, 0.0388, 0.0095]",
            "max = [0.0388, 0.0388, 0.0125]",
        )
        .replace(
            "min = [0.8e-3, 0.8e-3, 0.0105]",
            "min = [0.8e-3, 0.8e-3, 0.0135]",
        )
        .replace(
            "max = [0.0392, 0.0392, 0.0160]",
            "max = [0.0392, 0.0392, 0.0190]",
        );
    let scene = write_scene(dir.path(), "determinism-settling.toml", &text);
    let one = run(&scene, &dir.path().join("t1"), 1);
    let two = run(&scene, &dir.path().join("t2"), 2);
    let narrowings = |r: &RunResult| {
        r.summary["neighbour_list_narrowings"]
            .as_u64()
            .expect("narrowings")
    };
    assert!(narrowings(&one) > 0, "the rows were never narrowed");
    assert_eq!(narrowings(&one), narrowings(&two), "narrowings differ");
    let overlap = one.summary["max_overlap_ratio"].as_f64().expect("overlap");
    assert!(overlap > 1e-3, "hardly any contact in the run ({overlap})");
    eprintln!(
        "{} narrowings, largest overlap ratio {overlap:.3e}",
        narrowings(&one)
    );
    assert_identical(&one, &two, "narrowed rows, --threads 1 against --threads 2");
}

/// The same with Coulomb friction, rolling resistance and JKR adhesion: the contact system
/// with history (pairs in blocks of four lanes, walls scalar) and the rotation integrator
/// are bitwise reproducible too.
#[test]
fn contact_laws_with_history_do_not_change_a_bit() {
    let dir = tempfile::tempdir().expect("temp dir");
    let text = SCENE.replacen(
        "restitution = 0.5",
        "restitution = 0.5\nfriction = 0.4\nrolling_friction = 0.05\nwork_of_adhesion = 0.01",
        1,
    );
    let scene = write_scene(dir.path(), "determinism-laws.toml", &text);
    let one = run(&scene, &dir.path().join("t1"), 1);
    let two = run(&scene, &dir.path().join("t2"), 2);
    let spin = one
        .h5
        .iter()
        .filter(|(k, _)| k.ends_with("/angular_velocity"))
        .flat_map(|(_, v)| v.iter())
        .any(|&bits| f64::from_bits(bits) != 0.0);
    assert!(
        spin,
        "no particle turned: the tangential forces are not exercised"
    );
    assert_identical(&one, &two, "contact laws, --threads 1 against --threads 2");
}

/// Two blocks of two-sphere clumps with friction in a box, the upper falling onto the
/// lower (about 2,300 member rows).
const CLUMP_SCENE: &str = r#"
[simulation]
dt = 5e-6
end_time = 1.0
gravity = [0.0, 0.0, -9.81]
output_interval = 2.5e-4

[[materials]]
name = "grain"
density = 2500.0
youngs_modulus = 1e7
poisson_ratio = 0.3
restitution = 0.5
friction = 0.4

[[walls]]
type = "box"
material = "grain"
min = [0.0, 0.0, 0.0]
max = [0.04, 0.04, 0.05]

[[clump_types]]
name = "pair"
material = "grain"
spheres = [{ offset = [-0.5e-3, 0.0, 0.0], radius = 1.0e-3 }, { offset = [0.5e-3, 0.0, 0.0], radius = 1.0e-3 }]

[[clump_types]]
name = "small pair"
material = "grain"
spheres = [{ offset = [-0.3e-3, 0.0, 0.0], radius = 0.6e-3 }, { offset = [0.3e-3, 0.0, 0.0], radius = 0.6e-3 }]

# Lower block (reach 1.5 mm), on the floor.
[[blocks]]
clump = "pair"
min = [1.8e-3, 1.8e-3, 1.8e-3]
max = [0.0382, 0.0382, 0.0110]
spacing = 3.3e-3
jitter = 1.0
count = 600

# Upper block (reach 0.9 mm) falling onto it at 1 m/s, moving sideways.
[[blocks]]
clump = "small pair"
min = [1.2e-3, 1.2e-3, 0.0150]
max = [0.0388, 0.0388, 0.0250]
spacing = 2.0e-3
jitter = 1.0
velocity = [0.3, -0.2, -1.0]
count = 600
"#;

/// Clumps (`integrate/rigid_body.rs`): two blocks of two-sphere clumps with friction, one
/// falling onto the other, about 2,300 member rows (two chunks). The member pairs, the
/// loads summed per body and the bodies' orientation must not depend on the thread count.
#[test]
fn clumps_do_not_change_a_bit() {
    let dir = tempfile::tempdir().expect("temp dir");
    let text = CLUMP_SCENE;
    let scene = write_scene(dir.path(), "determinism-clumps.toml", text);
    let one = run(&scene, &dir.path().join("t1"), 1);
    let two = run(&scene, &dir.path().join("t2"), 2);
    let n = one.summary["particles"].as_u64().expect("particle count");
    assert!(
        n as usize > grainflow_systems::CHUNK,
        "only {n} member rows: the thread split is not exercised"
    );
    assert!(
        one.h5.keys().any(|k| k.ends_with("/orientation")),
        "no orientation written"
    );
    let overlap = one.summary["max_overlap_ratio"].as_f64().expect("overlap");
    assert!(overlap > 1e-3, "hardly any contact in the run ({overlap})");
    assert_identical(&one, &two, "clumps, --threads 1 against --threads 2");
}

/// Particles removed through a sink (`systems/src/sinks.rs`): the rows dropped at the
/// rebuild, the re-sort and the other blocks' row map must not depend on the thread
/// count. The sink cuts through the lower block at t = 0 (removing rows from both
/// chunks) and takes falling spheres of the upper block later.
#[test]
fn particles_removed_through_a_sink_do_not_change_a_bit() {
    let dir = tempfile::tempdir().expect("temp dir");
    let text = format!("{SCENE}\n[[sinks]]\npoint = [0.0, 0.0, 0.006]\nnormal = [0.0, 0.0, 1.0]\n");
    let scene = write_scene(dir.path(), "determinism-sink.toml", &text);
    let one = run(&scene, &dir.path().join("t1"), 1);
    let two = run(&scene, &dir.path().join("t2"), 2);
    let removed = one.summary["sinks"][0]["removed"]
        .as_u64()
        .expect("removed");
    let left = one.summary["particles"].as_u64().expect("particles");
    // The frame at t = 0 holds every placed particle.
    let placed = one
        .h5
        .iter()
        .find(|(k, _)| k.ends_with("/id"))
        .expect("a frame")
        .1
        .len();
    assert!(
        removed > 100 && left as usize > grainflow_systems::CHUNK,
        "{removed} removed, {left} left"
    );
    assert_eq!(removed + left, placed as u64, "particles lost or made");
    assert_eq!(
        one.summary["sinks"], two.summary["sinks"],
        "sink counts differ"
    );
    assert_identical(&one, &two, "sink, --threads 1 against --threads 2");
}

/// Clumps removed through a sink (`systems/src/sinks.rs`): the bodies whose centre
/// passed the plane, found in body order, their member rows dropped together, the bodies
/// compacted and the rows re-found must not depend on the thread count. The sink cuts
/// through the lower block of [`CLUMP_SCENE`] at t = 0 (bodies in both chunks) and takes
/// those that settle below it later.
#[test]
fn clumps_removed_through_a_sink_do_not_change_a_bit() {
    let dir = tempfile::tempdir().expect("temp dir");
    // A fuller upper block, so that more than one chunk of rows is left.
    let (lower, upper) = CLUMP_SCENE
        .rsplit_once("count = 600")
        .expect("upper block count");
    let text = format!(
        "{lower}count = 1000{upper}\n[[sinks]]\npoint = [0.0, 0.0, 0.006]\nnormal = [0.0, 0.0, 1.0]\n"
    );
    let scene = write_scene(dir.path(), "determinism-clump-sink.toml", &text);
    let one = run(&scene, &dir.path().join("t1"), 1);
    let two = run(&scene, &dir.path().join("t2"), 2);
    let removed = one.summary["sinks"][0]["removed"]
        .as_u64()
        .expect("removed");
    let left = one.summary["particles"].as_u64().expect("particles");
    // The frame at t = 0 holds every placed member row; bodies counted once, two member
    // rows each.
    let placed = one
        .h5
        .iter()
        .find(|(k, _)| k.ends_with("/id"))
        .expect("a frame")
        .1
        .len() as u64;
    assert!(
        removed > 100 && left as usize > grainflow_systems::CHUNK,
        "{removed} removed, {left} rows left"
    );
    assert_eq!(
        placed - 2 * removed,
        left,
        "bodies lost or orphaned members"
    );
    assert_eq!(
        one.summary["sinks"], two.summary["sinks"],
        "sink counts differ"
    );
    assert_identical(
        &one,
        &two,
        "clumps and a sink, --threads 1 against --threads 2",
    );
}

/// The corrector that also predicts the next step in its own pass (`PredictAhead`,
/// granted by the run loop for every step but the last and those whose end is written)
/// does the predictor's arithmetic in the predictor's order: a run through the run loop
/// and the same steps taken one at a time, never predicting ahead, write bitwise the same
/// frames, for Gear and velocity Verlet (with friction, so that the rotation integrator
/// runs beside them). Tolerance: none (bit equality).
#[test]
fn predicting_ahead_in_the_corrector_does_not_change_a_bit() {
    for integrator in ["gear", "velocity_verlet"] {
        let dir = tempfile::tempdir().expect("temp dir");
        let text = SCENE
            .replacen("restitution = 0.5", "restitution = 0.5\nfriction = 0.4", 1)
            .replacen(
                "end_time = 1.0\n",
                &format!("end_time = 1.0\nintegrator = \"{integrator}\"\n"),
                1,
            );
        let path = Path::new("determinism-ahead.toml");
        let build = |out: &Path| {
            let scene = grainflow::scene::parse(&text, path, &[]).expect("scene parses");
            let interval = scene.simulation.output_interval;
            grainflow::run::Simulation::new(scene, path, Some((out, interval))).expect("builds")
        };
        let steps = 600;
        let mut ahead = build(&dir.path().join("ahead"));
        let report = ahead.run(steps);
        assert!(report.failure.is_none(), "run failed: {:?}", report.failure);
        let mut one_by_one = build(&dir.path().join("one-by-one"));
        for _ in 0..steps {
            one_by_one.step();
        }
        // The last frame, as the run loop writes it.
        assert!(one_by_one.run(0).failure.is_none());

        // Not vacuous: this world lets the corrector predict ahead, and it does.
        let mut probe = simulation(&text, "determinism-ahead.toml");
        probe.step_predicting_ahead(true);
        let n = probe
            .world
            .resource::<grainflow_components::Particles>()
            .len();
        let predicted = match integrator {
            "gear" => {
                probe
                    .world
                    .resource::<grainflow_components::GearState>()
                    .predicted_rows
            }
            _ => {
                probe
                    .world
                    .resource::<grainflow_components::VerletState>()
                    .predicted_rows
            }
        };
        assert_eq!(
            predicted, n,
            "{integrator}: the corrector did not predict ahead"
        );

        let a = read_h5(&dir.path().join("ahead/particles.h5"));
        let b = read_h5(&dir.path().join("one-by-one/particles.h5"));
        let frames = a.keys().filter(|k| k.ends_with("/position")).count();
        assert!(frames >= 10, "only {frames} frames written");
        assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
        for (key, bits) in &a {
            if let Some(k) = (0..bits.len()).find(|&k| bits[k] != b[key][k]) {
                panic!(
                    "{integrator}: {key} differs first at element {k}: {:e} predicting ahead, {:e} not",
                    f64::from_bits(bits[k]),
                    f64::from_bits(b[key][k])
                );
            }
        }
    }
}
