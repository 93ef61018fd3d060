//! Rotation of a free sphere (Newton-Euler with no torque): the angular velocity stays
//! constant and the orientation quaternion turns by the angle |w| t about w, q(t) =
//! (cos(|w| t/2), sin(|w| t/2) w/|w|) (rigid-body kinematics, dq/dt = 1/2 (0, w) q). The
//! scene has friction, so that the rotation systems run; the sphere touches nothing.
mod common;

use grainflow_components::{Particles, Rotation};

const SCENE: &str = r#"
[simulation]
dt = 5.0e-5
end_time = 1.0
gravity = [0.0, 0.0, 0.0]
integrator = "INTEGRATOR"

[[materials]]
name = "steel"
density = 7800.0
youngs_modulus = 2.0e8
poisson_ratio = 0.3
friction = 0.3

[[spheres]]
material = "steel"
radius = 0.005
position = [0.0, 0.0, 0.0]
angular_velocity = [3.0, 0.0, 4.0]
"#;

#[test]
fn free_sphere_turns_at_constant_angular_velocity() {
    for integrator in ["gear", "velocity_verlet"] {
        let mut sim = common::simulation(
            &SCENE.replace("INTEGRATOR", integrator),
            "free-rotation.toml",
        );
        // 4,000 steps of 5e-5 s at |w| = 5 rad/s: 1 rad.
        let report = sim.run(4000);
        assert!(report.failure.is_none(), "{:?}", report.failure);
        let p = sim.world.resource::<Particles>();
        let w = [0, 1, 2].map(|d| p.angular_velocity[d][0]);
        assert_eq!(w, [3.0, 0.0, 4.0], "{integrator}: w changed without torque");
        let q = &sim.world.resource::<Rotation>().orientation;
        let q = [q[0][0], q[1][0], q[2][0], q[3][0]];
        let half: f64 = 0.5 * 5.0 * 0.2;
        let want = [half.cos(), 0.6 * half.sin(), 0.0, 0.8 * half.sin()];
        // Second-order update: the half angle lags by (|w| dt)^3/24 = 6.5e-13 per step,
        // 2.6e-9 after 4000 steps; 5e-9 bar.
        for k in 0..4 {
            assert!(
                (q[k] - want[k]).abs() < 5e-9,
                "{integrator}: orientation {q:?}, expected {want:?}"
            );
        }
    }
}
