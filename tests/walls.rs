//! Wall geometry and wall events: the distance and normal from a sphere centre to a plane,
//! a cylinder, a cone and a pipe (closest point on the meridian segment, less half the
//! wall thickness for the pipe's shell, checked against the geometry worked out by hand),
//! the removal of the outlet plate at its time, and a pipe wall that is also the flow's
//! obstacle.
use std::f64::consts::SQRT_2;

use grainflow_components::WallShape;
use grainflow_systems::contact::walls::{wall_contains, wall_distance, WallLanes};
use grainflow_systems::real::V3;
use wide::f64x4;

mod common;

fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
    (0..3).all(|d| (a[d] - b[d]).abs() < tol)
}

#[test]
fn plane_distance_is_signed_along_the_normal() {
    let plane = WallShape::Plane {
        point: [0.0, 0.0, 1.0],
        normal: [0.0, 0.0, 1.0],
    };
    let (d, n) = wall_distance(&plane, [3.0, -2.0, 1.25]);
    assert!((d - 0.25).abs() < 1e-15 && n == [0.0, 0.0, 1.0]);
    assert!((wall_distance(&plane, [0.0, 0.0, 0.5]).0 + 0.5).abs() < 1e-15);
    assert_eq!(wall_contains(&plane, [0.0, 0.0, 0.5]), Some(false));
}

#[test]
fn cylinder_distance_is_radial_inside_and_past_the_ends() {
    // Axis z through (1, 2), radius 0.5, from z = 0 to z = 2.
    let cyl = WallShape::Revolution {
        origin: [1.0, 2.0, 0.0],
        axis: [0.0, 0.0, 1.0],
        r0: 0.5,
        h0: 0.0,
        r1: 0.5,
        h1: 2.0,
        thickness: 0.0,
    };
    let (d, n) = wall_distance(&cyl, [1.3, 2.0, 1.0]);
    assert!((d - 0.2).abs() < 1e-14, "{d}");
    assert!(close(n, [-1.0, 0.0, 0.0], 1e-14), "{n:?}");
    // Above the top rim: the closest point is the rim itself.
    let (d, _) = wall_distance(&cyl, [1.0, 2.5, 2.3]);
    assert!((d - 0.3).abs() < 1e-14, "{d}");
    assert_eq!(wall_contains(&cyl, [1.2, 2.0, 1.0]), Some(true));
    assert_eq!(wall_contains(&cyl, [1.6, 2.0, 1.0]), Some(false));
    assert_eq!(wall_contains(&cyl, [1.6, 2.0, 3.0]), None);
}

/// A pipe of inner radius 2, outer 2.5 (mid-surface 2.25, thickness 0.5) from z = 1 to 5:
/// in the bore the distance is 2 - rho with the normal towards the axis, outside rho - 2.5
/// outward, below the mouth the distance to the rounded rim (a half circle of radius 0.25
/// about (2.25, 1)), and the solid itself is outside the particle side.
#[test]
fn pipe_distance_is_to_its_bore_its_outside_and_its_rounded_rim() {
    let pipe = WallShape::Revolution {
        origin: [0.0; 3],
        axis: [0.0, 0.0, 1.0],
        r0: 2.25,
        h0: 1.0,
        r1: 2.25,
        h1: 5.0,
        thickness: 0.5,
    };
    let (d, n) = wall_distance(&pipe, [1.5, 0.0, 3.0]);
    assert!((d - 0.5).abs() < 1e-14, "bore: {d}");
    assert!(close(n, [-1.0, 0.0, 0.0], 1e-14), "{n:?}");
    let (d, n) = wall_distance(&pipe, [0.0, 3.0, 3.0]);
    assert!((d - 0.5).abs() < 1e-14, "outside: {d}");
    assert!(close(n, [0.0, 1.0, 0.0], 1e-14), "{n:?}");
    // Straight below the mid-surface: 0.6 below the rim's centre, 0.35 below its surface.
    let (d, n) = wall_distance(&pipe, [2.25, 0.0, 0.4]);
    assert!((d - 0.35).abs() < 1e-14, "rim: {d}");
    assert!(close(n, [0.0, 0.0, -1.0], 1e-14), "{n:?}");
    // Inside the shell: a negative distance, and not on the particle side.
    let (d, _) = wall_distance(&pipe, [2.3, 0.0, 3.0]);
    assert!((d + 0.2).abs() < 1e-14, "in the wall: {d}");
    assert_eq!(wall_contains(&pipe, [2.3, 0.0, 3.0]), Some(false));
    // Both sides of the shell hold particles: the wall does not decide there.
    assert_eq!(wall_contains(&pipe, [1.0, 0.0, 3.0]), None);
    assert_eq!(wall_contains(&pipe, [3.0, 0.0, 3.0]), None);
}

#[test]
fn cone_distance_is_perpendicular_to_the_45_degree_meridian() {
    // The benchmark hopper cone: radius 0.2 at z = 0 to 1.25 at z = 1.05 (45 degrees).
    let cone = WallShape::Revolution {
        origin: [0.0; 3],
        axis: [0.0, 0.0, 1.0],
        r0: 0.2,
        h0: 0.0,
        r1: 1.25,
        h1: 1.05,
        thickness: 0.0,
    };
    // A point on the axis-plane y = 0 at (x, z) = (0.5, 0.5): wall radius there is 0.7, so
    // the point is 0.2 inside horizontally and 0.2 / sqrt(2) from the 45-degree line.
    let (d, n) = wall_distance(&cone, [0.5, 0.0, 0.5]);
    assert!((d - 0.2 / SQRT_2).abs() < 1e-14, "{d}");
    assert!(close(n, [-1.0 / SQRT_2, 0.0, 1.0 / SQRT_2], 1e-14), "{n:?}");
    // Same point rotated about the axis: same distance.
    let (d2, _) = wall_distance(&cone, [0.0, 0.5, 0.5]);
    assert!((d2 - d).abs() < 1e-14);
    assert_eq!(wall_contains(&cone, [0.5, 0.0, 0.5]), Some(true));
    assert_eq!(wall_contains(&cone, [0.75, 0.0, 0.5]), Some(false));
}

/// The contact kernel with history computes the walls four entries at a time in lanes:
/// each lane must get exactly the distance and normal of the one-point geometry (equal
/// values; only the sign of a zero may differ, as wide negates by 0 - x), including points on the axis (any perpendicular radial direction), on the
/// surface (the inward normal) and past the ends of the meridian segment.
#[test]
fn wall_geometry_in_lanes_equals_one_point_at_a_time() {
    let shapes = [
        WallShape::Plane {
            point: [0.1, -0.2, 0.3],
            normal: [0.6, 0.0, 0.8],
        },
        WallShape::Revolution {
            origin: [0.0, 0.0, 0.0],
            axis: [0.0, 0.0, 1.0],
            r0: 0.2,
            h0: 0.0,
            r1: 1.25,
            h1: 1.05,
            thickness: 0.0,
        },
        WallShape::Revolution {
            origin: [1.0, 2.0, -1.0],
            axis: [0.0, 0.6, 0.8],
            r0: 0.5,
            h0: -1.0e9,
            r1: 0.5,
            h1: 1.0e9,
            thickness: 0.0,
        },
        WallShape::Revolution {
            origin: [0.5, 0.5, 0.0],
            axis: [0.0, 0.0, 1.0],
            r0: 0.3,
            h0: 0.2,
            r1: 0.3,
            h1: 0.9,
            thickness: 0.1,
        },
    ];
    // A fixed pseudo-random sequence (Weyl), plus the special points.
    let mut points: Vec<[f64; 3]> = (0..64)
        .map(|k| [0.618_034, 0.414_214, 0.732_051].map(|a| ((k as f64 * a).fract() - 0.5) * 3.0))
        .collect();
    points.extend([
        [0.0, 0.0, 0.5],     // on the cone's axis
        [0.2, 0.0, 0.0],     // on the cone's lower rim
        [0.725, 0.0, 0.525], // on the cone's surface
        [1.0, 2.0, 3.0],     // on the cylinder's axis
        [0.0, 0.0, -2.0],    // below the cone's segment
    ]);
    let mut checked = 0;
    for shape in &shapes {
        for four in points.chunks(4) {
            let pick = |d: usize| f64x4::new([0, 1, 2, 3].map(|l| four[l.min(four.len() - 1)][d]));
            let (dist, n) = WallLanes::new(shape).distance(V3::new(pick(0), pick(1), pick(2)));
            for (l, &p) in four.iter().enumerate() {
                let (d1, n1) = wall_distance(shape, p);
                let lanes = [dist, n.x, n.y, n.z].map(|v| v.to_array()[l]);
                assert_eq!(lanes, [d1, n1[0], n1[1], n1[2]], "{shape:?} at {p:?}");
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 4 * 69);
}

#[test]
fn outlet_plate_removed_at_its_time_lets_the_sphere_fall() {
    let scene = r#"
[simulation]
dt = 1.0e-5
end_time = 1.0
gravity = [0.0, 0.0, -9.81]
[[materials]]
name = "steel"
density = 7800.0
youngs_modulus = 2.0e8
poisson_ratio = 0.3
restitution = 0.3
[[walls]]
type = "plane"
material = "steel"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
remove_at = 0.05
[[spheres]]
material = "steel"
radius = 0.005
position = [0.0, 0.0, 0.0051]
"#;
    let mut sim = common::simulation(scene, "plate.toml");
    sim.run(4900);
    let z_rest = common::position(&sim, 0)[2];
    assert!(
        z_rest > 0.0049,
        "held by the plate before t = 0.05 s: z = {z_rest}"
    );
    sim.run(5100);
    // After removal at 0.05 s the sphere falls freely for about 0.05 s: z drops by g t^2 / 2.
    let z = common::position(&sim, 0)[2];
    let expected = z_rest - 0.5 * 9.81 * 0.05f64.powi(2);
    assert!(
        (z - expected).abs() < 2e-4,
        "free fall after the plate is gone: z = {z}, expected {expected}"
    );
}

/// A `type = "pipe"` wall with `fluid_obstacle = true` is the flow's obstacle too: the
/// check lists it among the obstacles with the faces it holds, and a scene without a
/// `[fluid]` section is refused naming the field.
#[test]
fn a_pipe_wall_can_be_the_flows_obstacle_too() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = |fluid: &str| {
        format!(
            r#"
[simulation]
dt = 1.0e-5
end_time = 0.1
gravity = [0.0, 0.0, -9.81]
{fluid}
[[materials]]
name = "steel"
density = 7800.0
youngs_modulus = 2.0e8
poisson_ratio = 0.3
restitution = 0.3
[[walls]]
type = "pipe"
name = "suction pipe"
material = "steel"
axis = "z"
center = [0.5, 0.5]
inner_radius = 0.2
outer_radius = 0.3
bottom = 0.4
top = 1.0
fluid_obstacle = true
[[spheres]]
material = "steel"
radius = 0.02
position = [0.5, 0.5, 0.2]
"#
        )
    };
    let fluid = r#"
[fluid]
density = 1000.0
viscosity = 1.0e-3
min = [0.0, 0.0, 0.0]
max = [1.0, 1.0, 1.0]
cells = [4, 4, 4]
level = 3
dt = 1.0e-3
"#;
    let path = common::write_scene(dir.path(), "pipe.toml", &scene(fluid));
    let (code, stdout, stderr) = common::run_cli(&["check", path.to_str().unwrap()]);
    assert_eq!(code, 0, "{stdout}\n{stderr}");
    let line = stdout
        .lines()
        .find(|l| l.contains("obstacle suction pipe:"))
        .unwrap_or_else(|| panic!("no obstacle line in\n{stdout}"));
    // h = 1/16: the shell 0.1 thick is 1.6 cells.
    assert!(line.contains("wall 1.60 cells thick"), "{line}");
    let path = common::write_scene(dir.path(), "dry.toml", &scene(""));
    let (code, _, stderr) = common::run_cli(&["check", path.to_str().unwrap()]);
    assert_eq!(code, 2, "{stderr}");
    assert!(
        stderr.contains("walls[0].fluid_obstacle") && stderr.contains("[fluid]"),
        "{stderr}"
    );
}
