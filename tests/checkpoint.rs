//! Checkpoint and restart (`src/checkpoint.rs`, docs/output-format.md): a run stopped at
//! a checkpoint and resumed writes the same particles.h5 as the run that was never
//! stopped, bit for bit (every frame, every dataset), and ends in the same state
//! (`summary.json`'s physical fields), on 1 and 2 threads; for a dry hopper filling
//! from an inflow (stopped mid-inflow), the same with friction (contacts and wall contacts
//! carrying tangential springs), and an adhesive chain with friction and rolling
//! resistance hanging from a fixed sphere, and a frictional hopper discharging through
//! a sink (particles removed before and after the checkpoint); and coupled scenes stopped
//! between fluid steps (the flow's output and coupling history as well). SIGTERM and SIGINT stop a run at a
//! checkpoint (exit 143 / 130, status "interrupted"); a run killed outright resumes from
//! its last complete checkpoint; bad input to `resume` and `--checkpoint-every` exits 2.
mod common;

use std::path::Path;
use std::process::Stdio;
use std::time::Duration;

use common::{grainflow, run_cli};

/// One frame of particles.h5: group name, time, the f64 datasets, the ids.
type Frame = (String, f64, Vec<Vec<f64>>, Vec<u32>);

/// One case: name, scene, overrides, stop time, checkpoint interval, end time.
type Case<'a> = (&'a str, &'a str, &'a [&'a str], &'a str, &'a str, &'a str);

/// Every frame of `dir/particles.h5`, in step order.
fn frames(dir: &Path) -> Vec<Frame> {
    let file = hdf5::File::open(dir.join("particles.h5")).expect("particles.h5");
    let mut names = file.member_names().expect("groups");
    names.sort();
    names
        .into_iter()
        .map(|name| {
            let g = file.group(&name).expect("group");
            let time: f64 = g.attr("time").unwrap().read_scalar().unwrap();
            let data = ["position", "velocity", "angular_velocity", "radius"]
                .iter()
                .map(|d| g.dataset(d).unwrap().read_raw::<f64>().unwrap())
                .collect();
            let ids = g.dataset("id").unwrap().read_raw::<u32>().unwrap();
            (name, time, data, ids)
        })
        .collect()
}

/// The fields of `summary.json` that describe the state, not the run's timing.
fn physics(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("summary.json")).expect("summary.json");
    let s: serde_json::Value = serde_json::from_str(&text).expect("json");
    serde_json::json!({
        "total_steps": s["total_steps"],
        "simulated_time": s["simulated_time"],
        "particles": s["particles"],
        "kinetic_energy": s["kinetic_energy"],
        "max_overlap_ratio": s["max_overlap_ratio"],
        "neighbour_list_builds": s["neighbour_list_builds"],
        "energy": s["energy"],
    })
}

fn status(dir: &Path) -> String {
    let text = std::fs::read_to_string(dir.join("summary.json")).expect("summary.json");
    let s: serde_json::Value = serde_json::from_str(&text).expect("json");
    s["status"].as_str().unwrap_or_default().to_string()
}

fn ok(args: &[&str]) {
    let (code, stdout, stderr) = run_cli(args);
    assert_eq!(code, 0, "grainflow {args:?}\n{stdout}\n{stderr}");
}

/// The resumed run `b` wrote what the uninterrupted `a` wrote.
fn assert_same_output(a: &Path, b: &Path, what: &str) {
    let (fa, fb) = (frames(a), frames(b));
    assert_eq!(
        fa.iter().map(|f| &f.0).collect::<Vec<_>>(),
        fb.iter().map(|f| &f.0).collect::<Vec<_>>(),
        "{what}: the frames differ"
    );
    for (x, y) in fa.iter().zip(&fb) {
        assert!(
            x.1.to_bits() == y.1.to_bits() && x.3 == y.3,
            "{what}: frame {} time or ids differ",
            x.0
        );
        for (k, (u, v)) in x.2.iter().zip(&y.2).enumerate() {
            let same =
                u.len() == v.len() && u.iter().zip(v).all(|(p, q)| p.to_bits() == q.to_bits());
            assert!(same, "{what}: frame {} dataset {k} differs", x.0);
        }
    }
    assert_eq!(physics(a), physics(b), "{what}: the final state differs");
}

/// Scenes stopped at awkward moments, resumed, against the uninterrupted run.
#[test]
fn a_resumed_run_writes_what_the_uninterrupted_run_writes() {
    let root = env!("CARGO_MANIFEST_DIR");
    let hopper = format!("{root}/cases/hopper-fill-small.toml");
    let chain = format!("{root}/cases/pendulum-rolling.toml");
    let discharge = format!("{root}/cases/hopper-discharge-small.toml");
    let cases: [Case; 4] = [
        // Particles leaving through a sink before and after the checkpoint, with friction.
        (
            "hopper discharge",
            &discharge,
            &[
                "blocks.0.count=300",
                "walls.2.remove_at=0.02",
                "sinks.0.point.2=-0.05",
                "simulation.output_interval=0.02",
            ],
            "0.1337",
            "0.0437",
            "0.2",
        ),
        // Mid-inflow (batches every 0.01 s), a checkpoint between batches.
        ("hopper", &hopper, &[], "0.0437", "0.0219", "0.06"),
        (
            "hopper with friction",
            &hopper,
            &["materials.0.friction=0.5"],
            "0.0437",
            "0.0219",
            "0.06",
        ),
        // Contacts with springs, adhesion and rolling history from t = 0.
        (
            "adhesive chain",
            &chain,
            &["simulation.output_interval=0.0005"],
            "0.00377",
            "0.00123",
            "0.005",
        ),
    ];
    resumed_runs_match(&cases, assert_same_output);
}

/// Clumps poured into the small hopper (cases/hopper-fill-clumps.toml, 300 clumps) and
/// taken by a sink raised to z = 0.5 m into the pour: bodies removed and the rest
/// renumbered before and after the checkpoint. Besides the frames and the final state,
/// the bodies' `clump` index and `orientation` of every frame agree bit for bit.
#[test]
fn a_resumed_clump_run_with_a_sink_writes_what_the_uninterrupted_run_writes() {
    let root = env!("CARGO_MANIFEST_DIR");
    let scene = format!("{root}/cases/hopper-fill-clumps.toml");
    let cases: [Case; 1] = [(
        "clumps through a sink",
        &scene,
        &[
            "inflows.0.total=300",
            "sinks.0.point.2=0.5",
            "simulation.output_interval=0.02",
        ],
        "0.2137",
        "0.1093",
        "0.3",
    )];
    resumed_runs_match(&cases, |a, b, what| {
        assert_same_output(a, b, what);
        let bodies = |dir: &Path| -> Vec<(Vec<u32>, Vec<u64>)> {
            let file = hdf5::File::open(dir.join("particles.h5")).expect("particles.h5");
            let mut names = file.member_names().expect("groups");
            names.sort();
            names
                .iter()
                .map(|n| {
                    let g = file.group(n).expect("group");
                    let clump = g.dataset("clump").unwrap().read_raw::<u32>().unwrap();
                    let q = g.dataset("orientation").unwrap().read_raw::<f64>().unwrap();
                    (clump, q.iter().map(|x| x.to_bits()).collect())
                })
                .collect()
        };
        let (ba, bb) = (bodies(a), bodies(b));
        assert!(ba == bb, "{what}: clump indices or orientations differ");
        // Bodies were removed and renumbered: the last frame's indices are 0 .. n - 1,
        // two member rows each.
        let last = &ba.last().expect("frames").0;
        let mut count = std::collections::BTreeMap::new();
        for &c in last {
            *count.entry(c).or_insert(0) += 1;
        }
        assert!(
            count.values().all(|&k| k == 2),
            "{what}: a body without two members"
        );
        assert_eq!(
            count.keys().copied().collect::<Vec<_>>(),
            (0..count.len() as u32).collect::<Vec<_>>(),
            "{what}: bodies not renumbered"
        );
        let s: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(a.join("summary.json")).unwrap())
                .unwrap();
        let removed = s["sinks"][0]["removed"].as_u64().unwrap();
        assert!(removed > 20, "{what}: only {removed} clumps removed");
        assert_eq!(
            removed + last.len() as u64 / 2,
            300,
            "{what}: clumps lost or made"
        );
    });
}

/// Coupled scenes stopped between two fluid steps (the DEM subcycles of a fluid step
/// half done, the hydrodynamic forces held), resumed, against the uninterrupted run:
/// 64 spheres settling with friction and lubrication under the fluid-momentum update, and
/// two spheres under the distance-penalty boundary (the penalty list carried over) and
/// under the prescribed update with velocity blending; the particles, the flow's frames
/// (fluid.h5, fluid.xdmf), coupling.csv and the observables agree bit for bit.
#[test]
fn a_resumed_coupled_run_writes_what_the_uninterrupted_run_writes() {
    let root = env!("CARGO_MANIFEST_DIR");
    let sedimentation = format!("{root}/cases/sedimentation-64.toml");
    let dkt = format!("{root}/cases/dkt.toml");
    // dt_F = 2.5e-3 with 63 subcycles; the stop falls in the 10th substep of a fluid step
    let cases: [Case; 3] = [
        (
            "64 spheres settling",
            &sedimentation,
            &[
                "fluid.level=3",
                "coupling.lubrication=true",
                "simulation.output_interval=0.01",
            ],
            "0.0321",
            "0.0137",
            "0.05",
        ),
        // dt_F = 1e-4 with 11 subcycles; the stop falls in the 8th substep
        (
            "two spheres, distance penalty",
            &dkt,
            &[
                "fluid.level=2",
                "coupling.boundary=distance_penalty",
                "simulation.output_interval=0.001",
            ],
            "0.00337",
            "0.00131",
            "0.006",
        ),
        (
            "two spheres, prescribed and blended",
            &dkt,
            &[
                "fluid.level=2",
                "coupling.update=prescribed",
                "coupling.alpha=0.1",
                "simulation.output_interval=0.001",
            ],
            "0.00337",
            "0.00131",
            "0.006",
        ),
    ];
    resumed_runs_match(&cases, assert_same_flow);
}

/// As [`assert_same_output`], and the flow's output, the coupling history and the
/// observables.
fn assert_same_flow(a: &Path, b: &Path, what: &str) {
    assert_same_output(a, b, what);
    let flow = |dir: &Path| -> Vec<(String, u64, Vec<u64>, Vec<u64>)> {
        let file = hdf5::File::open(dir.join("fluid.h5")).expect("fluid.h5");
        let mut names = file.member_names().expect("groups");
        names.sort();
        let bits = |v: Vec<f64>| v.into_iter().map(f64::to_bits).collect();
        names
            .into_iter()
            .map(|name| {
                let g = file.group(&name).expect("group");
                let time: f64 = g.attr("time").unwrap().read_scalar().unwrap();
                let read = |d: &str| bits(g.dataset(d).unwrap().read_raw::<f64>().unwrap());
                (name, time.to_bits(), read("velocity"), read("pressure"))
            })
            .collect()
    };
    let (fa, fb) = (flow(a), flow(b));
    assert!(fa.len() > 2, "{what}: {} flow frames", fa.len());
    assert!(fa == fb, "{what}: fluid.h5 differs");
    for file in ["fluid.xdmf", "coupling.csv"] {
        let read = |dir: &Path| std::fs::read_to_string(dir.join(file)).expect(file);
        assert!(read(a) == read(b), "{what}: {file} differs");
    }
    let observables = |dir: &Path| {
        let text = std::fs::read_to_string(dir.join("summary.json")).expect("summary.json");
        let s: serde_json::Value = serde_json::from_str(&text).expect("json");
        s["observables"].clone()
    };
    assert_eq!(observables(a), observables(b), "{what}: observables differ");
}

/// Each case run uninterrupted into `a`, and stopped (checkpointed at its interval and
/// at its stop) into `b` and resumed there, on 1 and 2 threads; `same` compares them.
fn resumed_runs_match(cases: &[Case], same: fn(&Path, &Path, &str)) {
    for threads in ["1", "2"] {
        for (name, scene, sets, stop, every, end) in cases.iter().copied() {
            let dir = tempfile::tempdir().expect("temp dir");
            let a = dir.path().join("a");
            let b = dir.path().join("b");
            let set: Vec<String> = sets
                .iter()
                .flat_map(|s| ["--set".to_string(), s.to_string()])
                .collect();
            let set: Vec<&str> = set.iter().map(String::as_str).collect();
            let (a_s, b_s) = (a.to_str().unwrap(), b.to_str().unwrap());
            let mut args = vec![
                "run",
                scene,
                "--out",
                a_s,
                "--until",
                end,
                "--threads",
                threads,
            ];
            args.extend(&set);
            ok(&args);
            let mut args = vec![
                "run",
                scene,
                "--out",
                b_s,
                "--until",
                stop,
                "--threads",
                threads,
                "--checkpoint-every",
                every,
            ];
            args.extend(&set);
            ok(&args);
            ok(&["resume", b_s, "--until", end, "--threads", threads]);
            same(&a, &b, &format!("{name}, {threads} threads"));
        }
    }
}

/// SIGTERM (and SIGINT) end the run after a checkpoint with 143 (130) and an
/// "interrupted" summary; resumed, it ends where the uninterrupted run ends.
#[test]
fn a_signal_stops_the_run_at_a_checkpoint_and_it_resumes_exactly() {
    let scene = format!(
        "{}/cases/hopper-fill-small.toml",
        env!("CARGO_MANIFEST_DIR")
    );
    let dir = tempfile::tempdir().expect("temp dir");
    let a = dir.path().join("a");
    ok(&[
        "run",
        &scene,
        "--out",
        a.to_str().unwrap(),
        "--until",
        "0.6",
        "--threads",
        "1",
    ]);
    for (signal, code) in [(15, 143), (2, 130)] {
        let b = dir.path().join(format!("b{signal}"));
        let mut child = grainflow()
            .args([
                "run",
                &scene,
                "--out",
                b.to_str().unwrap(),
                "--until",
                "0.6",
                "--threads",
                "1",
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("spawn grainflow");
        std::thread::sleep(Duration::from_millis(1500));
        let killed = std::process::Command::new("kill")
            .args([format!("-{signal}"), child.id().to_string()])
            .status()
            .expect("kill");
        assert!(killed.success());
        let exit = child.wait().expect("wait");
        assert_eq!(
            exit.code(),
            Some(code),
            "signal {signal}: exit {exit:?} (did the run end before the signal?)"
        );
        assert_eq!(status(&b), "interrupted");
        ok(&[
            "resume",
            b.to_str().unwrap(),
            "--until",
            "0.6",
            "--threads",
            "1",
        ]);
        assert_same_output(&a, &b, &format!("signal {signal}"));
    }
}

/// A run killed with SIGKILL (perhaps while writing a checkpoint, leaving
/// checkpoint.h5.tmp) resumes from its last complete checkpoint.
#[test]
fn a_killed_run_resumes_from_its_last_complete_checkpoint() {
    let scene = format!(
        "{}/cases/hopper-fill-small.toml",
        env!("CARGO_MANIFEST_DIR")
    );
    let dir = tempfile::tempdir().expect("temp dir");
    let a = dir.path().join("a");
    let b = dir.path().join("b");
    ok(&[
        "run",
        &scene,
        "--out",
        a.to_str().unwrap(),
        "--until",
        "0.6",
        "--threads",
        "1",
    ]);
    let mut child = grainflow()
        .args([
            "run",
            &scene,
            "--out",
            b.to_str().unwrap(),
            "--until",
            "0.6",
            "--threads",
            "1",
            "--checkpoint-every",
            "0.001",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("spawn grainflow");
    std::thread::sleep(Duration::from_millis(1500));
    child.kill().expect("SIGKILL");
    let exit = child.wait().expect("wait");
    assert_eq!(exit.code(), None, "the run ended before it was killed");
    // A torn write beside the checkpoint does not matter.
    std::fs::write(b.join("checkpoint.h5.tmp"), b"torn").unwrap();
    ok(&[
        "resume",
        b.to_str().unwrap(),
        "--until",
        "0.6",
        "--threads",
        "1",
    ]);
    assert_same_output(&a, &b, "killed");
}

/// `resume` of a directory without a readable checkpoint, and bad `--checkpoint-every`
/// values or scenes, exit 2 naming the file (and the flag).
#[test]
fn bad_checkpoint_input_exits_2() {
    let root = env!("CARGO_MANIFEST_DIR");
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let missing = d.join("missing");
    let (code, _, stderr) = run_cli(&["resume", missing.to_str().unwrap()]);
    assert!(
        code == 2 && stderr.contains("checkpoint.h5"),
        "{code}: {stderr}"
    );
    std::fs::write(d.join("checkpoint.h5"), b"not hdf5").unwrap();
    let (code, _, stderr) = run_cli(&["resume", d.to_str().unwrap()]);
    assert!(
        code == 2 && stderr.contains("not a readable grainflow checkpoint"),
        "{code}: {stderr}"
    );
    let scene = format!("{root}/cases/sphere-on-plane.toml");
    let out = d.join("out");
    for every in ["0", "-1", "abc", "5parsecs", "0min"] {
        let (code, _, stderr) = run_cli(&[
            "run",
            &scene,
            "--out",
            out.to_str().unwrap(),
            "--steps",
            "10",
            &format!("--checkpoint-every={every}"),
        ]);
        assert!(
            code == 2 && stderr.contains("`--checkpoint-every`"),
            "{every}: {code}: {stderr}"
        );
    }
}
