//! The hydrodynamic force and torque on the particles (seed, "Hydrodynamic forces"), and
//! their part in the Newton-Euler equations: `m dU/dt = (rho - rho_f) V g + F_p + F_f`,
//! `I dw/dt = T_p + T_f`.
//!
//! After each fluid step the force of every particle is computed from the new flow
//! ([`hydrodynamic_sampling`]): by the scene's [`ForceMethod`] for particles whose faces
//! are held ([`super::surface_points`], [`super::volume_integral`]), from the momentum of
//! the fluid inside them for free particles under the fluid-momentum update
//! ([`super::fluid_momentum`]), plus the momentum the velocity blending moved
//! ([`super::blending`]), plus the reaction of the distance penalty
//! ([`super::distance_penalty`]). It is then held constant over the DEM subcycles up to the next
//! fluid step (Feng & Owen 2007) and added to the contact forces in every subcycle
//! ([`held_hydrodynamic_force`]).
use bevy_ecs::prelude::*;
use grainflow_components::{
    BoundaryRule, CellMarkers, Clamped, Clumps, ContactLaws, Coupling, ForceMethod, HydroForces,
    Particles, Rotation,
};
use rayon::prelude::*;

use super::bodies::{Bodies, Body};
use super::distance_penalty::penalty_reaction;
use super::fluid_momentum::fluid_momentum_force;
use super::holds_faces;
use super::surface_points::{surface_force_over, surface_point_force};
use super::volume_integral::{volume_integral_force, volume_integral_over};
use super::Wrap;
use crate::fluid::FluidFlow;

/// `hydrodynamic_sampling`: after each fluid step, the force and torque of every
/// particle from the new flow, held until the next fluid step.
pub fn hydrodynamic_sampling(
    coupling: Res<Coupling>,
    flow: Res<FluidFlow>,
    markers: Res<CellMarkers>,
    (clamped, clumps): (Option<Res<Clamped>>, Option<Res<Clumps>>),
    particles: Res<Particles>,
    mut hydro: ResMut<HydroForces>,
) {
    let _span = tracing::info_span!("hydrodynamic_sampling").entered();
    hydro.sampled_steps = flow.stats.steps;
    let ns = &flow.solver;
    let (grid, u, p) = (ns.grid(), [&ns.u[0][..], &ns.u[1], &ns.u[2]], &ns.p[..]);
    let carried = fluid_momentum_force(
        ns,
        &markers.particle_faces,
        &particles,
        coupling.fluid_density,
        flow.dt,
    );
    let bodies = Bodies::new(&particles, clumps.as_deref());
    let ft: Vec<([f64; 3], [f64; 3])> = (0..particles.len())
        .into_par_iter()
        .map(|i| {
            if bodies.is_member(i) {
                return match bodies.owned_by(i) {
                    Some(body) if holds_faces(&coupling, clamped.as_deref(), i) => {
                        let (f, t) = body_force(ns, &coupling, &bodies, body);
                        (f, Bodies::torque_about_owner(body, &particles, f, t))
                    }
                    Some(_) => carried[i],
                    None => ([0.0; 3], [0.0; 3]), // the body's force is on its owner row
                };
            }
            if !holds_faces(&coupling, clamped.as_deref(), i) {
                return carried[i];
            }
            let xp = [0, 1, 2].map(|d| particles.position[d][i]);
            let r = particles.radius[i];
            match coupling.method {
                ForceMethod::SurfacePoints => surface_point_force(grid, u, p, &coupling, xp, r),
                ForceMethod::VolumeIntegral => volume_integral_force(ns, &coupling, xp, r),
            }
        })
        .collect();
    let reaction = (coupling.boundary == BoundaryRule::DistancePenalty).then(|| {
        penalty_reaction(
            ns,
            &markers.penalty_rows,
            &particles,
            coupling.fluid_density,
        )
    });
    for (i, (f, _)) in carried.iter().enumerate() {
        for (d, &fd) in f.iter().enumerate() {
            hydro.inside_force[d][i] = fd;
        }
    }
    for (i, (f, t)) in ft.iter().enumerate() {
        let (rf, rt) = reaction.as_ref().map_or(([0.0; 3], [0.0; 3]), |r| r[i]);
        for d in 0..3 {
            hydro.force[d][i] = f[d] + rf[d] + hydro.exchange_force[d][i];
            hydro.torque[d][i] = t[d] + rt[d] + hydro.exchange_torque[d][i];
        }
    }
}

/// Force and torque (about its centre) on a body of another shape than the sphere whose
/// faces are held ([`super::bodies`]), by the scene's [`ForceMethod`] over its whole
/// solid through its fluid indicator: the volume integral over the faces inside it
/// (`depth > 0`), or the surface force over its shape's surface points, each face or point
/// once however many members hold it.
fn body_force(
    ns: &grainflow_fluid::NavierStokes,
    coupling: &Coupling,
    bodies: &Bodies,
    body: &Body,
) -> ([f64; 3], [f64; 3]) {
    let reach = bodies.reach[body.kind];
    match coupling.method {
        ForceMethod::VolumeIntegral => {
            volume_integral_over(ns, coupling, body.centre, reach, |arm| {
                bodies.depth(body, arm) > 0.0
            })
        }
        ForceMethod::SurfacePoints => {
            let grid = ns.grid();
            let wrap = Wrap::new(grid);
            let xc = wrap.image(body.centre);
            let q = body.orientation;
            let points = bodies.shapes[body.kind]
                .surface_points(&coupling.rule)
                .into_iter()
                .map(|sp| {
                    let arm = (q * sp.position).to_array();
                    let n = (q * sp.normal).to_array();
                    (arm, n, coupling.fluid_density * sp.area)
                });
            let u = [&ns.u[0][..], &ns.u[1], &ns.u[2]];
            surface_force_over(grid, u, &ns.p, coupling, xc, points, |x| {
                bodies.depth(body, wrap.arm(x, xc)) <= 0.0
            })
        }
    }
}

/// `held_hydrodynamic_force`: in every DEM substep, the force and torque of the last
/// fluid step added to the contact force and torque.
pub fn held_hydrodynamic_force(
    hydro: Res<HydroForces>,
    laws: Option<Res<ContactLaws>>,
    mut particles: ResMut<Particles>,
    mut rotation: ResMut<Rotation>,
) {
    let _span = tracing::info_span!("held_hydrodynamic_force").entered();
    for d in 0..3 {
        for (f, h) in particles.force[d].iter_mut().zip(&hydro.force[d]) {
            *f += h;
        }
    }
    // Contact laws with torques write the torque of the step; otherwise the hydrodynamic
    // torque is the only one.
    let contact_torque = laws.is_some_and(|l| l.has_torques());
    for d in 0..3 {
        for (t, h) in rotation.torque[d].iter_mut().zip(&hydro.torque[d]) {
            *t = if contact_torque { *t + h } else { *h };
        }
    }
}
