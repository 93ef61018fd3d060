//! Rigid clump bodies (`contact/shapes/clump.rs`): Newton-Euler for the centre of mass X,
//! the orientation q of the principal frame and the angular momentum L about the centre
//! (world frame), the seed's slide on Newton-Euler with the full inertia tensor:
//!
//!   M dV/dt = F + M a_b,   dL/dt = T,   w = R(q) I^-1 R(q)^T L,   dq/dt = 1/2 (0, w) q,
//!
//! with F and T the sums over the members of their contact (and hydrodynamic) forces and
//! of (x_k - X) x F_k plus their torques, in member order (the same sum for any thread
//! count), and a_b the body acceleration of the clump's material. Integrating L in the
//! world frame carries the gyroscopic term (dw/dt = I^-1 (T - w x I w) in the body frame)
//! without writing it; with no torque L is conserved exactly.
//!
//! The centre goes through the scene's integrator as a sphere's centre does: Gear's
//! predictor-corrector (the same formulas, `gear.rs`) or velocity Verlet (`verlet.rs`);
//! L through the same scheme as a sphere's w (Gear: L, T, dT/dt, d2T/dt2; velocity Verlet:
//! half kicks). The orientation turns over a step by the free rotation of the body with
//! its angular momentum held at the step's mean ([`turn`]: classical fourth-order
//! Runge-Kutta on q, renormalised), so a torque-free body conserves L exactly and its
//! energy to O(dt^4) per step.
//!
//! The members are rows of the particle block: after each predictor and corrector
//! ([`clump_predict`], [`clump_correct`]) they are put where the body holds them, with
//! the rigid velocity V + w x (x_k - X) and the body's w (the sphere integrators' own
//! move of those rows is overwritten; its and this move are both reported to the
//! neighbour list, an upper bound of the members' motion).
use bevy_ecs::prelude::*;
use glam::{DQuat, DVec3};
use grainflow_components::clump::angular_velocity;
use grainflow_components::{
    BodyAcceleration, BodyState, Clumps, GearState, IntegratorKind, NewParticle, Particles,
    Reorder, Rotation, SimClock, StepMotion,
};

use super::gear::{
    correct_row, flush_tiny, predict_row, predicted_derivatives, predictor_steps,
    CorrectorCoefficients,
};

/// Whether the scene has clump bodies.
pub fn has_clumps(w: &World) -> bool {
    w.contains_resource::<Clumps>()
}

/// The orientation after `dt` of free rotation from `q` with angular momentum `l` (world
/// frame) and principal moments `inertia`: dq/dt = 1/2 q (0, w_b), w_b = I^-1 (q^-1 L q),
/// by one classical Runge-Kutta step (more for |w| dt > 0.1), renormalised.
pub fn turn(q: DQuat, l: DVec3, inertia: DVec3, dt: f64) -> DQuat {
    let rate = |q: DQuat| {
        let w_body = (q.inverse() * l) / inertia;
        q * DQuat::from_xyzw(w_body.x, w_body.y, w_body.z, 0.0) * 0.5
    };
    let w = angular_velocity(q, inertia, l).length();
    let steps = ((w * dt) / 0.1).ceil().max(1.0) as usize;
    let h = dt / steps as f64;
    let mut q = q;
    for _ in 0..steps {
        let k1 = rate(q);
        let k2 = rate((q + k1 * (0.5 * h)).normalize());
        let k3 = rate((q + k2 * (0.5 * h)).normalize());
        let k4 = rate((q + k3 * h).normalize());
        q = (q + (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0)).normalize();
    }
    q
}

/// Append a body of type `kind` with the scene-frame orientation `scene_q` at centre
/// `state.position` to `clumps`, and its members to `particles` with the ids from
/// `next_id` on.
pub fn insert_clump(
    clumps: &mut Clumps,
    particles: &mut Particles,
    kind: u16,
    scene_q: DQuat,
    mut state: BodyState,
    next_id: &mut u32,
) {
    let ty = &clumps.types[kind as usize];
    // Principal frame = scene frame turned by the type's frame: world = Q_s (p - c) =
    // Q_s frame^-1 p'.
    state.orientation = (scene_q * ty.frame.inverse()).normalize();
    let w = state.angular_velocity;
    for (k, m) in ty.members.iter().enumerate() {
        let arm = state.orientation * m.offset;
        let velocity = state.velocity + w.cross(arm);
        // Contacts of a member see the body's mass (the damping's 1/m*): the member's
        // density is the one that gives its sphere that mass.
        let volume = 4.0 / 3.0 * std::f64::consts::PI * m.radius.powi(3);
        particles.push(NewParticle {
            id: *next_id + k as u32,
            material: ty.material,
            radius: m.radius,
            density: ty.mass / volume,
            position: (state.position + arm).to_array(),
            velocity: velocity.to_array(),
            angular_velocity: w.to_array(),
        });
    }
    let first = *next_id;
    *next_id += ty.members.len() as u32;
    clumps.push(kind, state, first);
}

/// A uniformly random rotation (Shoemake 1992, Graphics Gems III: from three uniform
/// numbers).
pub fn random_rotation(rng: &mut u64) -> DQuat {
    let (u1, u2, u3) = (
        crate::inflow::next_f64(rng),
        crate::inflow::next_f64(rng),
        crate::inflow::next_f64(rng),
    );
    let tau = 2.0 * std::f64::consts::PI;
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    DQuat::from_xyzw(
        a * (tau * u2).sin(),
        a * (tau * u2).cos(),
        b * (tau * u3).sin(),
        b * (tau * u3).cos(),
    )
    .normalize()
}

/// Find every member's row from its particle id (after an insertion), or follow a
/// re-sort of the rows (`perm`: new row k holds old row perm[k]).
pub(crate) fn follow_rows(clumps: &mut Clumps, particles: &Particles, perm: Option<&[u32]>) {
    if clumps.rows_stale {
        let max_id = particles
            .id
            .iter()
            .copied()
            .max()
            .map_or(0, |m| m as usize + 1);
        let mut row_of_id = vec![u32::MAX; max_id.max(clumps.body_of_id.len())];
        for (row, &id) in particles.id.iter().enumerate() {
            row_of_id[id as usize] = row as u32;
        }
        for b in 0..clumps.len() {
            let first = clumps.first_member[b];
            let range = clumps.member_start[b] as usize..clumps.member_start[b + 1] as usize;
            for (k, slot) in range.enumerate() {
                clumps.member_row[slot] = row_of_id[first as usize + k];
            }
        }
        assert!(
            clumps.member_row.iter().all(|&r| r != u32::MAX),
            "every clump member is a particle row"
        );
        clumps.rows_stale = false;
    } else if let Some(perm) = perm {
        // Old rows reach past the new row count when rows were dropped (a sink).
        let old_rows = clumps
            .member_row
            .iter()
            .max()
            .map_or(0, |&r| r as usize + 1);
        let mut new_row = vec![u32::MAX; old_rows.max(perm.len())];
        for (k, &old) in perm.iter().enumerate() {
            if let Some(slot) = new_row.get_mut(old as usize) {
                *slot = k as u32;
            }
        }
        for r in &mut clumps.member_row {
            *r = new_row[*r as usize];
        }
    }
}

/// Members follow a re-sort of the particle rows (the `Reorder` set).
pub fn clump_member_rows(
    particles: Res<Particles>,
    reorder: Res<Reorder>,
    mut clumps: ResMut<Clumps>,
) {
    if reorder.perm.is_some() || clumps.rows_stale {
        follow_rows(&mut clumps, &particles, reorder.perm.as_deref());
    }
}

/// Put every member of every body where the body holds it, with the rigid velocity and
/// the body's angular velocity (and the scene-frame orientation, when the rows have one);
/// returns the largest change of a member's position coordinate.
fn place_members(
    clumps: &Clumps,
    particles: &mut Particles,
    rotation: Option<&mut Rotation>,
) -> f64 {
    let mut largest = 0.0f64;
    let mut orientation = rotation.map(|r| &mut r.orientation);
    for b in 0..clumps.len() {
        let (x, q) = (clumps.position[b], clumps.orientation[b]);
        let ty = &clumps.types[clumps.kind[b] as usize];
        let w = angular_velocity(q, ty.inertia, clumps.angular_momentum[b]);
        let scene_q = q * ty.frame;
        for (slot, member) in clumps.members(b) {
            let i = clumps.member_row[slot] as usize;
            let arm = q * member.offset;
            let p = x + arm;
            let v = clumps.velocity[b] + w.cross(arm);
            for d in 0..3 {
                largest = largest.max((particles.position[d][i] - p[d]).abs());
                particles.position[d][i] = p[d];
                particles.velocity[d][i] = v[d];
                particles.angular_velocity[d][i] = w[d];
            }
            if let Some(o) = orientation.as_deref_mut() {
                (o[0][i], o[1][i], o[2][i], o[3][i]) = (scene_q.w, scene_q.x, scene_q.y, scene_q.z);
            }
        }
    }
    largest
}

/// Force and torque (about the centre) on every body from its members' rows, summed in
/// member order, into `clumps.force` and `clumps.torque`.
fn gather_loads(clumps: &mut Clumps, particles: &Particles, rotation: Option<&Rotation>) {
    for b in 0..clumps.len() {
        let x = clumps.position[b];
        let (mut f, mut t) = (DVec3::ZERO, DVec3::ZERO);
        let range = clumps.member_start[b] as usize..clumps.member_start[b + 1] as usize;
        for &row in &clumps.member_row[range] {
            let i = row as usize;
            let fk = DVec3::from_array([0, 1, 2].map(|d| particles.force[d][i]));
            let xk = DVec3::from_array([0, 1, 2].map(|d| particles.position[d][i]));
            f += fk;
            t += (xk - x).cross(fk);
            if let Some(r) = rotation {
                t += DVec3::from_array([0, 1, 2].map(|d| r.torque[d][i]));
            }
        }
        clumps.force[b] = f;
        clumps.torque[b] = t;
    }
}

/// Acceleration of body `b`'s centre under `clumps.force` and the body acceleration.
fn body_acceleration(clumps: &Clumps, body: &BodyAcceleration, b: usize) -> DVec3 {
    let ty = &clumps.types[clumps.kind[b] as usize];
    clumps.force[b] / ty.mass + DVec3::from_array(body.per_material[ty.material as usize])
}

/// Start-up: loads at t = 0 and the integrator's start values (Gear: a = F/M + a_b, L' =
/// T, higher derivatives zero); the members placed.
pub fn clump_start(
    mut clumps: ResMut<Clumps>,
    particles: Res<Particles>,
    rotation: Option<Res<Rotation>>,
    body: Res<BodyAcceleration>,
) {
    let clumps = &mut *clumps;
    follow_rows(clumps, &particles, None);
    gather_loads(clumps, &particles, rotation.as_deref());
    for b in 0..clumps.len() {
        let a = body_acceleration(clumps, &body, b);
        let aux = &mut clumps.aux[b];
        aux.acc = [a, DVec3::ZERO, DVec3::ZERO];
        aux.torque_rate = [clumps.torque[b], DVec3::ZERO, DVec3::ZERO];
    }
}

/// After the spheres' predictors: every body predicted to t + dt (Gear: Taylor steps of X,
/// V and L, the orientation turned with the mean of L and its prediction; velocity Verlet:
/// the half kicks of V and L with the last loads, the drift of X and the turn with the
/// half-step L, and the estimates V*, L* at t + dt for the velocity-dependent forces), its
/// members placed.
pub fn clump_predict(
    mut clumps: ResMut<Clumps>,
    mut particles: ResMut<Particles>,
    rotation: Option<ResMut<Rotation>>,
    kind: Res<IntegratorKind>,
    body: Res<BodyAcceleration>,
    clock: Res<SimClock>,
    mut motion: ResMut<StepMotion>,
) {
    let _span = tracing::info_span!("clump_predict").entered();
    let clumps = &mut *clumps;
    follow_rows(clumps, &particles, None);
    let dt = clock.dt;
    for b in 0..clumps.len() {
        let inertia = clumps.types[clumps.kind[b] as usize].inertia;
        let (q, l) = (clumps.orientation[b], clumps.angular_momentum[b]);
        match *kind {
            IntegratorKind::Gear => {
                let steps = predictor_steps(dt);
                let aux = &mut clumps.aux[b];
                aux.start_orientation = q;
                aux.start_momentum = l;
                let [a, da, dda] = aux.acc;
                let [t, dt_, ddt] = aux.torque_rate;
                let (x, v) = (&mut clumps.position[b], &mut clumps.velocity[b]);
                for d in 0..3 {
                    predict_row([&mut x[d], &mut v[d]], a[d], da[d], dda[d], steps);
                }
                let [h, h2, h3, _] = steps;
                let l_p = l + t * h + dt_ * h2 + ddt * h3;
                clumps.angular_momentum[b] = l_p;
                clumps.orientation[b] = turn(q, 0.5 * (l + l_p), inertia, dt);
            }
            IntegratorKind::VelocityVerlet => {
                let half = 0.5 * dt;
                let kick = half * body_acceleration(clumps, &body, b);
                let aux = &mut clumps.aux[b];
                aux.half_velocity = clumps.velocity[b] + kick;
                aux.half_momentum = l + clumps.torque[b] * half;
                clumps.position[b] += aux.half_velocity * dt;
                clumps.orientation[b] = turn(q, aux.half_momentum, inertia, dt);
                clumps.velocity[b] = aux.half_velocity + kick;
                clumps.angular_momentum[b] = aux.half_momentum + clumps.torque[b] * half;
            }
        }
    }
    let moved = place_members(clumps, &mut particles, rotation.map(|r| r.into_inner()));
    motion.add(moved * (1.0 + 1e-12));
}

/// After the spheres' correctors: every body's loads from its members, the corrector
/// (Gear: the same formulas as the spheres' for X and V with a = F/M + a_b, and for L with
/// L' = T, then the orientation turned from the step's start with the mean of L;
/// velocity Verlet: the second half kicks), its members placed.
#[allow(clippy::too_many_arguments)]
pub fn clump_correct(
    mut clumps: ResMut<Clumps>,
    mut particles: ResMut<Particles>,
    mut rotation: Option<ResMut<Rotation>>,
    kind: Res<IntegratorKind>,
    gear: Option<Res<GearState>>,
    body: Res<BodyAcceleration>,
    clock: Res<SimClock>,
    mut motion: ResMut<StepMotion>,
) {
    let _span = tracing::info_span!("clump_correct").entered();
    let clumps = &mut *clumps;
    gather_loads(clumps, &particles, rotation.as_deref());
    let dt = clock.dt;
    for b in 0..clumps.len() {
        let inertia = clumps.types[clumps.kind[b] as usize].inertia;
        let target = body_acceleration(clumps, &body, b);
        match *kind {
            IntegratorKind::Gear => {
                let alpha0 = gear.as_ref().map_or(19.0 / 120.0, |g| g.alpha0);
                let k = CorrectorCoefficients::new(dt, alpha0);
                let aux = &mut clumps.aux[b];
                let (x, v) = (&mut clumps.position[b], &mut clumps.velocity[b]);
                let [a, da, dda] = &mut aux.acc;
                for d in 0..3 {
                    let row = [&mut x[d], &mut v[d], &mut a[d], &mut da[d], &mut dda[d]];
                    correct_row(row, target[d], &k);
                }
                let h2 = 0.5 * dt * dt;
                let [t, dt_, ddt] = &mut aux.torque_rate;
                let l = &mut clumps.angular_momentum[b];
                for d in 0..3 {
                    let (t_p, dt_p) = predicted_derivatives(t[d], dt_[d], ddt[d], dt, h2);
                    let delta = clumps.torque[b][d] - t_p;
                    l[d] += 3.0 / 8.0 * dt * delta;
                    t[d] = t_p + delta;
                    dt_[d] = flush_tiny(dt_p + 1.5 / dt * delta);
                    ddt[d] = flush_tiny(ddt[d] + delta / (dt * dt));
                }
                let mean = 0.5 * (aux.start_momentum + *l);
                clumps.orientation[b] = turn(aux.start_orientation, mean, inertia, dt);
            }
            IntegratorKind::VelocityVerlet => {
                let half = 0.5 * dt;
                let aux = &clumps.aux[b];
                clumps.velocity[b] = aux.half_velocity + target * half;
                clumps.angular_momentum[b] = aux.half_momentum + clumps.torque[b] * half;
            }
        }
    }
    let moved = place_members(clumps, &mut particles, rotation.as_deref_mut());
    motion.add(moved * (1.0 + 1e-12));
}
