//! Kinematic (fixed) particles: after the corrector, every held particle is put back on
//! its prescribed path x(t) = x(0) + v t with velocity v, no rotation, and no stored
//! acceleration, so the next predictor moves it exactly. The contact forces on it are
//! computed as for any particle (they are the reaction a test reads).
use bevy_ecs::prelude::*;
use grainflow_components::{Clamped, GearState, Particles, Rotation, SimClock, VerletState};

pub fn has_clamped(w: &World) -> bool {
    w.contains_resource::<Clamped>()
}

/// After the corrector (and the clock): held particles at x(t), integrator state reset.
pub fn hold_clamped(
    clamped: Res<Clamped>,
    clock: Res<SimClock>,
    particles: ResMut<Particles>,
    gear: Option<ResMut<GearState>>,
    verlet: Option<ResMut<VerletState>>,
    rotation: Option<ResMut<Rotation>>,
) {
    let _span = tracing::info_span!("hold_clamped").entered();
    hold(&clamped, clock.time, particles, gear, verlet, rotation);
}

/// After the predictor: held particles at x(t + dt), for the contact forces of the step
/// (the Verlet predictor would have moved them by the force).
pub fn hold_clamped_predicted(
    clamped: Res<Clamped>,
    clock: Res<SimClock>,
    particles: ResMut<Particles>,
    verlet: Option<ResMut<VerletState>>,
) {
    let _span = tracing::info_span!("hold_clamped_predicted").entered();
    hold(
        &clamped,
        clock.time + clock.dt,
        particles,
        None,
        verlet,
        None,
    );
}

fn hold(
    clamped: &Clamped,
    time: f64,
    mut particles: ResMut<Particles>,
    gear: Option<ResMut<GearState>>,
    verlet: Option<ResMut<VerletState>>,
    rotation: Option<ResMut<Rotation>>,
) {
    let held = || (0..clamped.held.len()).filter(|&i| clamped.held[i]);
    for d in 0..3 {
        for i in held() {
            let v = clamped.velocity[d][i];
            particles.position[d][i] = clamped.origin[d][i] + v * time;
            particles.velocity[d][i] = v;
            particles.angular_velocity[d][i] = 0.0;
        }
    }
    let zero = |cols: &mut [grainflow_components::Columns]| {
        for col in cols.iter_mut().flatten() {
            for i in held() {
                col[i] = 0.0;
            }
        }
    };
    if let Some(mut gear) = gear {
        let GearState {
            acc, jerk, snap, ..
        } = &mut *gear;
        zero(std::slice::from_mut(acc));
        zero(std::slice::from_mut(jerk));
        zero(std::slice::from_mut(snap));
    }
    if let Some(mut verlet) = verlet {
        for d in 0..3 {
            for i in held() {
                verlet.half_velocity[d][i] = clamped.velocity[d][i];
            }
        }
    }
    if let Some(mut rotation) = rotation {
        zero(&mut rotation.aux);
    }
}
