//! Rotation of the spheres under contact torques, seed slide on Newton-Euler:
//! I dw/dt = T with I = (2/5) m r^2 (so 1/I = 5/2 (1/m) / r^2, from the particle
//! columns), and the orientation quaternion dq/dt = 1/2 (0, w) q.
//!
//! The angular velocity goes through the same integrator as the translation: the Gear
//! predictor-corrector with w in the place of the velocity (its predictor and corrector
//! coefficients 1, 3/4, 1/2, 1/12 on w, dw/dt, d2w/dt2, d3w/dt3; see `gear.rs`), or
//! velocity Verlet with w(t + dt/2) (see `verlet.rs`). The orientation turns by w dt
//! after each corrector (second order, see `turn_orientations`).
use bevy_ecs::prelude::*;
use grainflow_components::{IntegratorKind, Particles, Rotation, SimClock};
use rayon::prelude::*;

use crate::integrate::gear::{flush_tiny, predicted_derivatives};
use crate::team::StaticSplit;
use crate::CHUNK;

/// Whether the world integrates rotation (some contact law produces torques).
pub fn has_rotation(w: &World) -> bool {
    w.contains_resource::<Rotation>()
}

/// Columns of `Rotation::aux` each integrator keeps.
pub fn aux_columns(kind: IntegratorKind) -> usize {
    match kind {
        IntegratorKind::Gear => 3,
        IntegratorKind::VelocityVerlet => 1,
    }
}

/// Gear predictor for w: w += w' dt + w'' dt^2/2 + w''' dt^3/6. As for the translation
/// (`gear.rs`), the predicted w' and w'' are formed by the corrector.
pub fn gear_rotation_predict(
    mut particles: ResMut<Particles>,
    rotation: Res<Rotation>,
    clock: Res<SimClock>,
) {
    let _span = tracing::info_span!("gear_rotation_predict").entered();
    let dt = clock.dt;
    let (h2, h3) = (dt * dt / 2.0, dt * dt * dt / 6.0);
    let [acc, jerk, snap] = &rotation.aux[..] else {
        unreachable!("Gear keeps three rotation columns")
    };
    for d in 0..3 {
        (
            particles.angular_velocity[d].par_chunks_mut(CHUNK),
            acc[d].par_chunks(CHUNK),
            jerk[d].par_chunks(CHUNK),
            snap[d].par_chunks(CHUNK),
        )
            .into_par_iter()
            .static_for_each(|(w, a, b, c)| {
                for k in 0..w.len() {
                    w[k] += a[k] * dt + b[k] * h2 + c[k] * h3;
                }
            });
    }
}

/// Gear corrector for w with the predicted w'_p = w' + w'' dt + w''' dt^2/2 and
/// w''_p = w'' + w''' dt, and Delta = T/I - w'_p: w += 3/8 dt Delta, w' = w'_p + Delta,
/// w'' = w''_p + 3/2 Delta/dt, w''' += Delta/dt^2; then the orientation. As for the
/// translation, |w''|, |w'''| < 1e-150 are set to zero (they decay geometrically without
/// torque and would become slow subnormal numbers).
pub fn gear_rotation_correct(
    mut particles: ResMut<Particles>,
    mut rotation: ResMut<Rotation>,
    clock: Res<SimClock>,
) {
    let _span = tracing::info_span!("gear_rotation_correct").entered();
    let dt = clock.dt;
    let h2 = dt * dt / 2.0;
    let (cw, cb, cc) = (3.0 / 8.0 * dt, 1.5 / dt, 1.0 / (dt * dt));
    let Rotation { torque, aux, .. } = &mut *rotation;
    let [acc, jerk, snap] = &mut aux[..] else {
        unreachable!("Gear keeps three rotation columns")
    };
    let Particles {
        angular_velocity,
        inv_mass,
        radius,
        ..
    } = &mut *particles;
    for d in 0..3 {
        (
            angular_velocity[d].par_chunks_mut(CHUNK),
            acc[d].par_chunks_mut(CHUNK),
            jerk[d].par_chunks_mut(CHUNK),
            snap[d].par_chunks_mut(CHUNK),
            torque[d].par_chunks(CHUNK),
            inv_mass.par_chunks(CHUNK),
            radius.par_chunks(CHUNK),
        )
            .into_par_iter()
            .static_for_each(|(w, a, b, c, t, im, r)| {
                for k in 0..w.len() {
                    let (a_p, b_p) = predicted_derivatives(a[k], b[k], c[k], dt, h2);
                    let delta = t[k] * inverse_inertia(im[k], r[k]) - a_p;
                    w[k] += cw * delta;
                    a[k] = a_p + delta;
                    b[k] = flush_tiny(b_p + cb * delta);
                    c[k] = flush_tiny(c[k] + cc * delta);
                }
            });
    }
    turn_orientations(&particles, &mut rotation, dt);
}

/// Start-up: w' from the torques at t = 0, higher derivatives zero.
pub fn gear_rotation_start(particles: Res<Particles>, mut rotation: ResMut<Rotation>) {
    let Rotation { torque, aux, .. } = &mut *rotation;
    for d in 0..3 {
        for k in 0..particles.len() {
            aux[0][d][k] =
                torque[d][k] * inverse_inertia(particles.inv_mass[k], particles.radius[k]);
            aux[1][d][k] = 0.0;
            aux[2][d][k] = 0.0;
        }
    }
}

/// Velocity Verlet predictor for w: w(t + dt/2) = w(t) + T(t)/I dt/2, and the estimate
/// w*(t + dt) = w(t + dt/2) + T(t)/I dt/2 for the velocity-dependent forces.
pub fn verlet_rotation_predict(
    mut particles: ResMut<Particles>,
    mut rotation: ResMut<Rotation>,
    clock: Res<SimClock>,
) {
    let _span = tracing::info_span!("verlet_rotation_predict").entered();
    verlet_rotation_half_step(&mut particles, &mut rotation, 0.5 * clock.dt, true);
}

/// Velocity Verlet corrector for w: w(t + dt) = w(t + dt/2) + T(t + dt)/I dt/2; then the
/// orientation.
pub fn verlet_rotation_correct(
    mut particles: ResMut<Particles>,
    mut rotation: ResMut<Rotation>,
    clock: Res<SimClock>,
) {
    let _span = tracing::info_span!("verlet_rotation_correct").entered();
    verlet_rotation_half_step(&mut particles, &mut rotation, 0.5 * clock.dt, false);
    turn_orientations(&particles, &mut rotation, clock.dt);
}

/// The half kick `T/I h` of velocity Verlet on w: from w(t) to w(t + dt/2) and the
/// estimate of w(t + dt) (`predict`), or from w(t + dt/2) to w(t + dt).
fn verlet_rotation_half_step(
    particles: &mut Particles,
    rotation: &mut Rotation,
    h: f64,
    predict: bool,
) {
    let Rotation { torque, aux, .. } = rotation;
    let Particles {
        angular_velocity,
        inv_mass,
        radius,
        ..
    } = particles;
    for d in 0..3 {
        (
            angular_velocity[d].par_chunks_mut(CHUNK),
            aux[0][d].par_chunks_mut(CHUNK),
            torque[d].par_chunks(CHUNK),
            inv_mass.par_chunks(CHUNK),
            radius.par_chunks(CHUNK),
        )
            .into_par_iter()
            .static_for_each(|(w, wh, t, im, r)| {
                for k in 0..w.len() {
                    let kick = h * t[k] * inverse_inertia(im[k], r[k]);
                    if predict {
                        wh[k] = w[k] + kick;
                    }
                    w[k] = wh[k] + kick;
                }
            });
    }
}

/// 1/I of a solid sphere, I = (2/5) m r^2.
#[inline(always)]
pub fn inverse_inertia(inv_mass: f64, radius: f64) -> f64 {
    2.5 * inv_mass / (radius * radius)
}

/// q <- normalise(q + dt/2 (0, w) q): the exact turn exp(dt/2 (0, w)) q to second order
/// (after normalisation the angle is atan(|w| dt/2) for |w| dt/2, an error of
/// (|w| dt)^3/24 per step), without trigonometric functions.
fn turn_orientations(particles: &Particles, rotation: &mut Rotation, dt: f64) {
    let [wx, wy, wz] = &particles.angular_velocity;
    let [q0, q1, q2, q3] = &mut rotation.orientation;
    let h = 0.5 * dt;
    (
        (
            q0.par_chunks_mut(CHUNK),
            q1.par_chunks_mut(CHUNK),
            q2.par_chunks_mut(CHUNK),
            q3.par_chunks_mut(CHUNK),
        ),
        (
            wx.par_chunks(CHUNK),
            wy.par_chunks(CHUNK),
            wz.par_chunks(CHUNK),
        ),
    )
        .into_par_iter()
        .static_for_each(|((q0, q1, q2, q3), (wx, wy, wz))| {
            for k in 0..q0.len().min(wx.len()) {
                let w = glam::DQuat::from_xyzw(h * wx[k], h * wy[k], h * wz[k], 0.0);
                let q = glam::DQuat::from_xyzw(q1[k], q2[k], q3[k], q0[k]);
                let q = (q + w * q).normalize();
                (q0[k], q1[k], q2[k], q3[k]) = (q.w, q.x, q.y, q.z);
            }
        });
}
