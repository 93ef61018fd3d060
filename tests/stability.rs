//! Time-step stability of a dense bed against the Rayleigh time step
//! dt_R = pi R sqrt(rho/G) / (0.1631 nu + 0.8766), G = E / (2 (1 + nu)) (Li, Xu & Thornton
//! 2005; formula from `shared/reference/contact-benchmarks.md`).
//!
//! A bed of 200 spheres (R = 1 mm, E = 1 GPa, nu = 0.3, rho = 2500 kg/m^3, e = 0.3), built
//! as a touching cubic lattice in a box and settled under gravity at 0.2 dt_R, is saved as
//! a scene and given to the CLI with dt raised step by step:
//! - `grainflow check` prints dt_R as the formula gives it (0.1 %, its printed digits);
//!   it passes small steps silently, and flags (prints "warning" or exits with 2) every
//!   dt from some value below dt_R on;
//! - experimentally (measured: stable at 0.5 dt_R, the overlap runs away within 82 steps
//!   at dt_R and within 9 steps at 5 dt_R), a run at the check's own limit completes
//!   while runs at dt_R and at 5 dt_R with `allow_unstable_dt = true` stop with exit
//!   code 1 and a message naming the step and the particle; the particles.h5 they leave
//!   holds only finite values, and frames only from before the failing step;
//! - without `allow_unstable_dt` a run at 5 dt_R is refused (exit 2, field
//!   `simulation.dt`).
mod common;

use std::path::Path;

use common::*;
use grainflow_components::{Particles, VerletState};

const R: f64 = 1e-3;
const E: f64 = 1e9;
const NU: f64 = 0.3;
const RHO: f64 = 2500.0;

fn header(dt: f64) -> String {
    format!(
        "[simulation]\ndt = {dt:e}\nend_time = 1.0\ngravity = [0.0, 0.0, -9.81]\n\n\
         [[materials]]\nname = \"grain\"\ndensity = {RHO}\nyoungs_modulus = {E:e}\n\
         poisson_ratio = {NU}\nrestitution = 0.3\n\n\
         [[walls]]\ntype = \"box\"\nmaterial = \"grain\"\nmin = [0.0, 0.0, 0.0]\n\
         max = [0.012, 0.012, 0.03]\n"
    )
}

/// The settled bed as a scene with explicit spheres.
fn settled_bed(dt_r: f64) -> String {
    let lattice = format!(
        "{}\n[[blocks]]\nmaterial = \"grain\"\nradius = {R}\nmin = [{R}, {R}, {R}]\n\
         max = [0.011, 0.011, 0.0155]\nspacing = {:e}\n",
        header(0.2 * dt_r),
        2.0 * R
    );
    let mut sim = simulation(&lattice, "bed.toml");
    let report = sim.run(3000);
    assert!(report.failure.is_none(), "{:?}", report.failure);
    let p = sim.world.resource::<Particles>();
    assert!(p.len() >= 200, "only {} spheres in the bed", p.len());
    let mut text = header(0.2 * dt_r);
    for i in 0..p.len() {
        let (x, v) = (|d: usize| p.position[d][i], |d: usize| p.velocity[d][i]);
        text += &format!(
            "\n[[spheres]]\nmaterial = \"grain\"\nradius = {R}\n\
             position = [{:e}, {:e}, {:e}]\nvelocity = [{:e}, {:e}, {:e}]\n",
            x(0),
            x(1),
            x(2),
            v(0),
            v(1),
            v(2)
        );
    }
    text
}

#[derive(Debug, PartialEq)]
enum Verdict {
    Ok,
    Warning,
    Rejected,
}

/// `grainflow check` at `dt`; also returns the printed Rayleigh time step and limit.
fn check(scene: &Path, dt: f64) -> (Verdict, f64, f64) {
    let set = format!("simulation.dt={dt:e}");
    let (code, stdout, stderr) = run_cli(&["check", scene.to_str().unwrap(), "--set", &set]);
    let printed = |label: &str| -> f64 {
        let line = stdout
            .lines()
            .find(|l| l.trim_start().starts_with(label))
            .unwrap_or_else(|| panic!("check prints no `{label}` line:\n{stdout}"));
        line.split_whitespace()
            .rev()
            .nth(1)
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("cannot read a time from `{line}`"))
    };
    let verdict = match code {
        2 => {
            assert!(
                stderr.contains("`simulation.dt`"),
                "rejected without naming simulation.dt:\n{stderr}"
            );
            Verdict::Rejected
        }
        0 if stdout.contains("warning") || stderr.contains("warning") => Verdict::Warning,
        0 => Verdict::Ok,
        c => panic!("check exited with {c}:\n{stdout}\n{stderr}"),
    };
    (verdict, printed("Rayleigh time step"), printed("limit"))
}

struct Run {
    code: i32,
    stderr: String,
    /// (step, every value finite) of each frame of particles.h5.
    frames: Vec<(u64, bool)>,
}

fn run(scene: &Path, out: &Path, dt: f64, allow: bool, steps: u64) -> Run {
    let sets = [
        format!("simulation.dt={dt:e}"),
        format!("simulation.allow_unstable_dt={allow}"),
        format!("simulation.output_interval={:e}", 5.0 * dt),
    ];
    let steps = steps.to_string();
    let mut args = vec![
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--steps",
        &steps,
        "--threads",
        "1",
    ];
    for s in &sets {
        args.extend(["--set", s]);
    }
    let (code, _, stderr) = run_cli(&args);
    let h5 = out.join("particles.h5");
    let frames = if h5.exists() {
        let file = hdf5::File::open(&h5).expect("open particles.h5");
        file.member_names()
            .expect("frames")
            .iter()
            .map(|name| {
                let step: u64 = name
                    .trim_start_matches("step_")
                    .parse()
                    .expect("frame name step_NNNNNNNN");
                let g = file.group(name).expect("frame");
                let finite = ["position", "velocity", "angular_velocity", "radius"]
                    .iter()
                    .all(|ds| {
                        g.dataset(ds)
                            .and_then(|d| d.read_raw::<f64>())
                            .expect("dataset")
                            .iter()
                            .all(|x| x.is_finite())
                    });
                (step, finite)
            })
            .collect()
    } else {
        Vec::new()
    };
    Run {
        code,
        stderr,
        frames,
    }
}

/// The step number in "unstable at step N".
fn failing_step(stderr: &str) -> u64 {
    let rest = stderr
        .split("unstable at step ")
        .nth(1)
        .unwrap_or_else(|| panic!("no `unstable at step` in:\n{stderr}"));
    rest.split(|c: char| !c.is_ascii_digit())
        .next()
        .and_then(|n| n.parse().ok())
        .expect("step number")
}

/// `total_steps` of the run's summary.json in `out`.
fn summary_total_steps(out: &Path) -> u64 {
    let text = std::fs::read_to_string(out.join("summary.json")).expect("summary.json");
    let summary: serde_json::Value = serde_json::from_str(&text).expect("summary.json is JSON");
    summary["total_steps"].as_u64().expect("total_steps")
}

/// Spheres placed overlapping by 150 % of the radius fail before the first step: the
/// message says step 0 and summary.json counts 0 steps.
#[test]
fn spheres_placed_overlapping_fail_at_step_0() {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut text = header(1e-7);
    for z in [0.005, 0.0055] {
        text += &format!(
            "\n[[spheres]]\nmaterial = \"grain\"\nradius = {R}\nposition = [0.003, 0.003, {z}]\n"
        );
    }
    let scene = write_scene(dir.path(), "overlapping.toml", &text);
    let out = dir.path().join("out");
    let (code, _, stderr) = run_cli(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--steps",
        "5",
    ]);
    assert_eq!(code, 1, "expected exit code 1 (unstable):\n{stderr}");
    assert_eq!(failing_step(&stderr), 0, "{stderr}");
    assert_eq!(summary_total_steps(&out), 0);
}

#[test]
fn check_warns_below_the_rayleigh_step_and_unstable_runs_stop_cleanly() {
    let dt_r = rayleigh_time_step(R, E, NU, RHO);
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = write_scene(dir.path(), "bed.toml", &settled_bed(dt_r));

    // 1. The check, dt from 0.05 to 5 dt_R.
    let ladder = [
        0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.4, 0.5, 0.7, 1.0, 1.5, 2.0, 5.0,
    ];
    let mut first_flagged = None;
    let mut limit = 0.0;
    for f in ladder {
        let (verdict, printed_dt_r, printed_limit) = check(&scene, f * dt_r);
        eprintln!("check at {f} dt_R: {verdict:?}");
        assert!(
            rel(printed_dt_r, dt_r) < 1e-3,
            "check prints dt_R = {printed_dt_r:e} s, the formula gives {dt_r:e} s"
        );
        limit = printed_limit;
        match (verdict, first_flagged) {
            (Verdict::Ok, None) => {}
            (Verdict::Ok, Some(g)) => {
                panic!("check passes {f} dt_R after flagging {g} dt_R")
            }
            (_, None) => first_flagged = Some(f),
            (_, Some(_)) => {}
        }
    }
    let first_flagged = first_flagged.expect("check never flags the time step");
    eprintln!("check flags dt from {first_flagged} dt_R; limit {limit:e} s, dt_R {dt_r:e} s");
    assert!(
        first_flagged < 1.0,
        "check first flags dt at {first_flagged} dt_R, not below dt_R"
    );
    assert!(
        first_flagged > 0.05,
        "check flags even dt = 0.05 dt_R: the warning says nothing"
    );

    // 2. At the check's own limit (less its print rounding) the bed stays stable.
    let limit = limit * (1.0 - 1e-3);
    let at_limit = run(&scene, &dir.path().join("limit"), limit, false, 1000);
    assert_eq!(
        at_limit.code, 0,
        "run at the check's limit {limit:e} s failed:\n{}",
        at_limit.stderr
    );

    // 3. At dt_R and far past it the run stops, naming the step and the particle.
    for f in [1.0, 5.0] {
        let r = run(
            &scene,
            &dir.path().join(format!("x{f}")),
            f * dt_r,
            true,
            1000,
        );
        assert_eq!(
            r.code, 1,
            "run at {f} dt_R: expected exit code 1 (unstable)\n{}",
            r.stderr
        );
        let step = failing_step(&r.stderr);
        assert!(
            (1..1000).contains(&step),
            "failing step {step} out of range"
        );
        assert!(
            r.stderr.contains(" particle "),
            "the message names no particle:\n{}",
            r.stderr
        );
        assert_eq!(
            summary_total_steps(&dir.path().join(format!("x{f}"))),
            step,
            "the message and summary.json count the steps alike"
        );
        eprintln!("run at {f} dt_R: stopped at step {step}");
        assert!(
            !r.frames.is_empty(),
            "no frame was written before the failure"
        );
        for (frame, finite) in &r.frames {
            assert!(*finite, "frame {frame} of particles.h5 holds NaN or inf");
            assert!(
                *frame < step,
                "frame {frame} written at or after the failing step {step}"
            );
        }
    }

    // 4. Without the opt-in, far past the limit is refused before running.
    let refused = run(&scene, &dir.path().join("refused"), 5.0 * dt_r, false, 10);
    assert_eq!(refused.code, 2, "{}", refused.stderr);
    assert!(
        refused.stderr.contains("`simulation.dt`"),
        "{}",
        refused.stderr
    );
}

/// A non-finite position or velocity stops the run at the step it appears in and names
/// the particle, whichever pass finds it: the monitor's own pass (velocity Verlet), or the
/// Gear corrector's bound on what it leaves (with and without predicting the next step in
/// the same pass), which spares the monitor its pass only while everything is finite.
#[test]
fn a_non_finite_state_stops_the_run_naming_the_step_and_the_particle() {
    for (integrator, ahead) in [
        ("gear", false),
        ("gear", true),
        ("velocity_verlet", false),
        ("velocity_verlet", true),
    ] {
        for column in ["position", "velocity"] {
            let mut text = header(1e-7).replacen(
                "end_time = 1.0\n",
                &format!("end_time = 1.0\nintegrator = \"{integrator}\"\n"),
                1,
            );
            for x in [0.003, 0.006, 0.009] {
                text += &format!(
                    "\n[[spheres]]\nmaterial = \"grain\"\nradius = {R}\nposition = [{x}, {x}, 0.01]\n"
                );
            }
            let mut sim = simulation(&text, "non_finite.toml");
            for _ in 0..3 {
                sim.step_predicting_ahead(ahead);
            }
            assert!(
                sim.failure().is_none(),
                "{integrator}: failed before the NaN"
            );
            let i = row(&sim, 1);
            let mut particles = sim.world.resource_mut::<Particles>();
            match column {
                "position" => particles.position[2][i] = f64::NAN,
                _ => particles.velocity[0][i] = f64::NAN,
            }
            // Between the passes of a velocity Verlet step that predicted ahead, the
            // velocity the step carries on is v(t + dt/2) (v holds an estimate the
            // corrector replaces): the NaN goes there too.
            if let Some(mut verlet) = sim.world.get_resource_mut::<VerletState>() {
                if column == "velocity" {
                    verlet.half_velocity[0][i] = f64::NAN;
                }
            }
            sim.step_predicting_ahead(ahead);
            let failure = sim.failure().unwrap_or_else(|| {
                panic!("{integrator} (ahead {ahead}): a NaN {column} did not stop the run")
            });
            assert!(
                failure.contains("unstable at step 4")
                    && failure.contains("particle 1 has a non-finite position or velocity"),
                "{integrator} (ahead {ahead}), NaN {column}: {failure}"
            );
        }
    }
}
