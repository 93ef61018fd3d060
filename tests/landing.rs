//! Settling of a cloud (`src/cloud.rs`): the settling velocity is the mean velocity along
//! gravity, the floor is the side of the box gravity points at, a sphere lies on the
//! floor when its cluster touches it, and the landing time is the first time every sphere
//! does with the fastest slower than 5 % of the peak settling velocity reached so far.
//! Small configurations with known answers.
mod common;

use grainflow::cloud::{landing_time, CloudSample, CloudState, Floor};

const BOX: ([f64; 3], [f64; 3]) = ([0.0, 0.0, 0.0], [2.0, 2.0, 6.0]);
const DOWN: [f64; 3] = [0.0, 0.0, -1.0];

#[test]
fn settling_velocity_is_the_mean_velocity_along_gravity() {
    let position = [[0.5, 0.5, 3.0], [1.5, 1.5, 4.0], [1.0, 1.0, 5.0]];
    let velocity = [[1.0, 0.0, -3.0], [0.0, 2.0, -6.0], [0.0, 0.0, 0.0]];
    let s = CloudState::of(0.1, &position, &[0.25; 3], &velocity, BOX);
    assert_eq!(s.sample(DOWN).settling_velocity, 3.0);
    // gravity along +x: the mean of the x velocities
    assert!((s.sample([1.0, 0.0, 0.0]).settling_velocity - 1.0 / 3.0).abs() < 1e-15);
    assert_eq!(s.max_speed, 40f64.sqrt());
    assert_eq!(s.clusters, 3);
}

#[test]
fn a_stack_lies_on_the_floor_only_when_its_lowest_sphere_touches_it() {
    let r = 0.25;
    let still = [[0.0; 3]; 3];
    // a column of three touching spheres, the lowest 0.01 r above z = 0
    let column = |lift: f64| -> Vec<[f64; 3]> {
        (0..3)
            .map(|k| [1.0, 1.0, r + lift + f64::from(k) * 2.0 * r])
            .collect()
    };
    let on = CloudState::of(0.0, &column(0.01 * r), &[r; 3], &still, BOX);
    assert!(on.sample(DOWN).all_on_floor);
    assert_eq!(on.clusters, 1);
    // lifted by 0.2 r: a cluster, but off the floor
    let off = CloudState::of(0.0, &column(0.2 * r), &[r; 3], &still, BOX);
    assert!(!off.sample(DOWN).all_on_floor);
    // under gravity along +z the floor is the top of the box, 6 - 1.5 r away
    assert!(!on.sample([0.0, 0.0, 1.0]).all_on_floor);
    // a sphere apart from the column, in mid-fluid: not all on the floor
    let mut apart = column(0.01 * r);
    apart[2][0] += 0.5;
    let s = CloudState::of(0.0, &apart, &[r; 3], &still, BOX);
    assert!(!s.sample(DOWN).all_on_floor);
    assert_eq!(s.clusters, 2);
}

#[test]
fn the_floor_is_the_side_gravity_points_at() {
    let sides = Floor::sides(BOX.0, BOX.1);
    assert_eq!(Floor::side_index(DOWN), 4);
    assert_eq!(Floor::side_index([0.0, 0.0, 1.0]), 5);
    assert_eq!(Floor::side_index([-9.0, 1.0, 0.0]), 0);
    assert_eq!(Floor::side_index([0.1, 0.0, 0.0]), 1);
    // gaps of a sphere r = 0.25 at (0.5, 1.0, 0.3) to the six sides
    let x = [0.5, 1.0, 0.3];
    let gaps = sides.map(|f| f.gap(x, 0.25));
    let expected = [0.25, 1.25, 0.75, 0.75, 0.05, 5.45];
    for (g, e) in gaps.iter().zip(expected) {
        assert!((g - e).abs() < 1e-12, "{gaps:?}");
    }
}

fn sample(time: f64, settling_velocity: f64, max_speed: f64, all_on_floor: bool) -> CloudSample {
    CloudSample {
        time,
        settling_velocity,
        max_speed,
        all_on_floor,
    }
}

#[test]
fn landing_time_is_the_first_time_all_rest_on_the_floor() {
    // at rest where released (not on the floor), falling at a peak of 10, on the floor
    // but still bouncing at 0.6 (above 5 % of 10), then at rest at 0.4
    let samples = [
        sample(0.0, 0.0, 0.0, false),
        sample(0.1, 10.0, 12.0, false),
        sample(0.2, 4.0, 5.0, true),
        sample(0.3, 0.2, 0.6, true),
        sample(0.4, 0.0, 0.4, true),
        sample(0.5, 0.0, 0.1, true),
    ];
    assert_eq!(landing_time(samples), Some(0.4));
    // a cloud released on the floor at rest has not landed until it has moved
    assert_eq!(
        landing_time([sample(0.0, 0.0, 0.0, true), sample(0.1, 0.0, 0.0, true)]),
        None
    );
    // slow but partly off the floor: never lands
    assert_eq!(
        landing_time([sample(0.0, 5.0, 5.0, false), sample(0.1, 0.0, 0.0, false)]),
        None
    );
}

/// Three spheres (r = 0.125 cm, rho / rho_f = 1.5, 4 cells per diameter) released 0.12 r
/// above the floor of a small fluid box, 0.4 r apart: `summary.json` of the run reports
/// three clusters, a positive peak settling velocity and a landing time within the run.
const THREE_ON_THE_FLOOR: &str = r#"
[simulation]
dt = 2.0e-5
end_time = 0.15
gravity = [0.0, 0.0, -980.0]
output_interval = 0.05

[fluid]
density = 1.0
viscosity = 0.01
min = [0.0, 0.0, 0.0]
max = [1.0, 1.0, 1.0]
cells = [4, 4, 4]
level = 2
dt = 1.0e-3

[[materials]]
name = "sphere"
density = 1.5
youngs_modulus = 1.0e6
poisson_ratio = 0.3
restitution = 0.5

[[walls]]
type = "box"
name = "box"
material = "sphere"
min = [0.0, 0.0, 0.0]
max = [1.0, 1.0, 1.0]

[[spheres]]
material = "sphere"
radius = 0.125
position = [0.2, 0.5, 0.14]

[[spheres]]
material = "sphere"
radius = 0.125
position = [0.5, 0.5, 0.14]

[[spheres]]
material = "sphere"
radius = 0.125
position = [0.8, 0.5, 0.14]
"#;

#[test]
fn summary_reports_the_landing_of_a_small_cloud() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = common::write_scene(dir.path(), "three.toml", THREE_ON_THE_FLOOR);
    let out = dir.path().join("out");
    let (code, _, stderr) = common::run_cli(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--threads",
        "1",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let o = &summary["observables"];
    assert_eq!(o["clusters_final"], 3, "{o}");
    assert!(o["settling_velocity_peak"].as_f64().unwrap() > 0.0, "{o}");
    let landed = o["landing_time"].as_f64().unwrap_or_else(|| panic!("{o}"));
    assert!(landed > 0.0 && landed < 0.15, "{o}");
}
