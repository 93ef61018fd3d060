//! The scenes under `cases/`: every one passes `grainflow check` (known fields, valid
//! values, particles inside the walls, a stable time step), and the dense state of the
//! small hopper has the walls of that hopper, the benchmark hopper of
//! `shared/bench/lammps-hopper` scaled by s = (20000/50000)^(1/3) (hopper_params.lmp:
//! outlet radius 0.20 s at z = 0, 45-degree cone), not those of the 50,000-particle one;
//! and `check` tells in which of them the corrector predicts ahead; the seed's cloud
//! cases run a few fluid steps on a coarse grid and report the cloud observables.
use std::path::{Path, PathBuf};

mod common;
use common::run_cli;

/// A LAMMPS `atom_style sphere` data file of two spheres (r = 0.02 m, rho = 10) resting
/// at z = 0.02 m, the second at radius `x` from the hopper axis.
fn two_spheres(dir: &Path, x: f64) -> PathBuf {
    let text = format!(
        "two spheres\n\n2 atoms\n1 atom types\n\n-1.5 1.5 xlo xhi\n-1.5 1.5 ylo yhi\n\
         -0.1 3.0 zlo zhi\n\nAtoms # sphere\n\n1 1 0.04 10 0.0 0.0 0.02 0 0 0\n\
         2 1 0.04 10 {x} 0.0 0.02 0 0 0\n"
    );
    let path = dir.join(format!("two_{x}.data"));
    std::fs::write(&path, text).expect("write data file");
    path
}

fn cases() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases");
    let mut cases: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("cases/")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    cases.sort();
    cases
}

/// `grainflow check CASE`, with the LAMMPS data file of a benchmark state replaced by
/// `data` (the harness's files are not part of the repository; a case whose data file
/// is, as the suction case's bed, keeps it).
fn check(case: &Path, data: &Path) -> (i32, String, String) {
    let scene = grainflow::scene::load(case, &[]).expect("case parses");
    let set = format!("lammps.0.file={}", data.display());
    let mut args = vec!["check", case.to_str().expect("utf-8 path")];
    if scene.lammps.first().is_some_and(|l| !l.file.is_file()) {
        args.extend(["--set", &set]);
    }
    run_cli(&args)
}

#[test]
fn every_case_passes_check() {
    let dir = tempfile::tempdir().expect("temp dir");
    let data = two_spheres(dir.path(), 0.05);
    let cases = cases();
    assert!(cases.len() >= 19, "cases/ holds the scenes: {cases:?}");
    for case in &cases {
        let (code, stdout, stderr) = check(case, &data);
        assert_eq!(code, 0, "{}: {stderr}", case.display());
        assert!(stdout.contains("schedule"), "{}: {stdout}", case.display());
    }
}

#[test]
fn small_dense_state_has_the_walls_of_the_small_hopper() {
    let dir = tempfile::tempdir().expect("temp dir");
    let cases = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases");
    let (small, large) = (
        cases.join("bench-hopper-small-dense.toml"),
        cases.join("bench-hopper-dense.toml"),
    );
    // The cone's radius at z = 0.02 m: 0.20 s + 0.02 = 0.1674 m in the small hopper,
    // 0.22 m in the large one.
    let s = (20_000.0f64 / 50_000.0).cbrt();
    let rim = 0.20 * s + 0.02;
    let inside = two_spheres(dir.path(), rim - 0.005);
    let between = two_spheres(dir.path(), rim + 0.01);
    assert_eq!(check(&small, &inside).0, 0);
    let (code, _, stderr) = check(&small, &between);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("outside wall `hopper cone`"), "{stderr}");
    assert_eq!(check(&large, &between).0, 0);
}

/// `grainflow check` says when the corrector predicts the next step in its own pass: in
/// the benchmark states and the impact (nothing between the corrector and the next
/// predictor changes or reads the particles every step), not with an inflow (the hopper
/// fill), a held particle (the pendulums) or fluid coupling (the sedimentation).
#[test]
fn check_tells_where_the_corrector_predicts_ahead() {
    let dir = tempfile::tempdir().expect("temp dir");
    let data = two_spheres(dir.path(), 0.05);
    let cases = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases");
    let line = "the corrector also predicts the next step in its pass";
    for (case, ahead) in [
        ("bench-hopper-loose.toml", true),
        ("two-sphere-impact.toml", true),
        ("hopper-fill-small.toml", false),
        ("pendulum-rolling.toml", false),
        ("sedimentation-single.toml", false),
    ] {
        let (code, stdout, stderr) = check(&cases.join(case), &data);
        assert_eq!(code, 0, "{case}: {stderr}");
        assert_eq!(stdout.contains(line), ahead, "{case}:\n{stdout}");
    }
}

/// The seed's 64-sphere cases start and report the cloud observables: four fluid steps at
/// level 3 (seconds). Every sphere starts apart (64 clusters, `clusters_max`); the block
/// has begun to fall.
#[test]
fn cloud_cases_run_and_report_the_cloud_observables() {
    let dir = tempfile::tempdir().expect("temp dir");
    let cases = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases");
    for case in ["sedimentation-64.toml", "sedimentation-adhesion.toml"] {
        let out = dir.path().join(case);
        let (code, _, stderr) = run_cli(&[
            "run",
            cases.join(case).to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--until",
            "0.01",
            "--set",
            "fluid.level=3",
            "--threads",
            "1",
        ]);
        assert_eq!(code, 0, "{case}: {stderr}");
        let summary: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(out.join("summary.json")).expect("summary.json"),
        )
        .expect("json");
        let o = &summary["observables"];
        assert_eq!(o["clusters_max"], 64, "{case}: {o}");
        assert!(
            o["settling_velocity_final"].as_f64().unwrap() > 0.0,
            "{case}: {o}"
        );
        assert!(o["landing_time"].is_null(), "{case}: {o}");
    }
}
