//! The time step of grainflow, in order, and the table of its systems.
//!
//! One DEM step runs the sets below in this order (the seed's "efficient computation"
//! slide: neighbour list, contact, hydrodynamics, Gear predictor-corrector):
//!
//! 1. `Events`: walls removed at their time, particles inserted by inflows
//! 2. `SyncRows`: per-particle blocks grown to the particle count
//! 3. `Predict`: integrator predictor (Gear: Taylor step of x and v); it skips the rows
//!    that the last corrector predicted already (below)
//! 4. `NeighbourList`: cell index + half Verlet list, rebuilt when a particle may have
//!    moved skin/2; particles re-sorted in cell order; wall candidate lists
//! 5. `Reorder`: every other per-particle block follows the re-sort
//! 6. `Contact`: contact forces: Hertz normal + damping between particles and with walls
//!    (`hertz_contact`), or, when some material pair has friction, rolling resistance or
//!    adhesion, the same plus those models with per-contact history (`granular_contact`);
//!    in coupled scenes that ask for it, the lubrication correction of pairs closer than
//!    about one fluid cell (`lubrication`)
//! 7. `VelocityBlending`: when a fluid step is due, the particles' cell markers, their
//!    rigid-body velocity on the faces inside them and the smooth transition around them
//!    (`velocity_blending`)
//! 8. `MultigridFluid`: a Navier-Stokes step whenever the fluid time is reached (every
//!    n_s DEM steps: the DEM subcycles inside a fluid step)
//! 9. `HydrodynamicSampling`: after a fluid step, the hydrodynamic force and torque of
//!    every particle from the new flow; in every subcycle they are added, held constant,
//!    to the contact forces (`hydrodynamic_sampling`)
//! 10. `Correct`: integrator corrector with body forces (gravity, buoyancy), rotation
//!     under contact torques; the clock; kinematic (fixed) particles put back on their
//!     path. When the run loop grants `PredictAhead` (see
//!     [`corrector_may_predict_ahead`]), the translation corrector also runs the next
//!     step's predictor on each row in the same pass
//! 11. `Monitor`: stability checks (overlap, non-finite state)
//! 12. `Output`: writers (added by the application)
//!
//! A scene gets only the systems whose `wanted` test passes on its world, so a scene
//! without inflow, walls or Gear neither runs nor allocates their systems. Adding a model
//! means one file with its systems and one line in [`REGISTRY`].
use bevy_ecs::prelude::*;
use bevy_ecs::schedule::SingleThreadedExecutor;
use grainflow_components::{GearState, IntegratorKind, VerletState, Walls};

use crate::clamp::has_clamped;
use crate::fictitious::has_coupling;
use crate::fluid::has_fluid;
use crate::granular::has_contact_laws;
use crate::rotation::has_rotation;
use crate::{
    clamp, fictitious, fluid, gear, granular, hertz, hydrodynamic, inflow, lubrication, monitor,
    neighbour_list, rotation, rows, verlet, walls,
};
use grainflow_components::{Clamped, HydroForces, Rotation};

/// The ordered phases of a DEM step.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum StepSet {
    Events,
    SyncRows,
    Predict,
    NeighbourList,
    Reorder,
    Contact,
    VelocityBlending,
    MultigridFluid,
    HydrodynamicSampling,
    Correct,
    Monitor,
    Output,
}

/// All sets in step order.
pub const STEP_ORDER: [StepSet; 12] = [
    StepSet::Events,
    StepSet::SyncRows,
    StepSet::Predict,
    StepSet::NeighbourList,
    StepSet::Reorder,
    StepSet::Contact,
    StepSet::VelocityBlending,
    StepSet::MultigridFluid,
    StepSet::HydrodynamicSampling,
    StepSet::Correct,
    StepSet::Monitor,
    StepSet::Output,
];

/// The place of one registry entry inside its [`StepSet`]; slots of a set run in table
/// order.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Slot(pub usize);

/// Which schedule a system belongs to: the time step, the start-up (forces at t = 0 and
/// integrator initialisation), or both.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    Step,
    Startup,
    Both,
}

/// One registered system: its name (as printed by `grainflow check`), its set, the
/// schedules it joins, when a world needs it, and how it is added.
pub struct SystemEntry {
    pub name: &'static str,
    pub set: StepSet,
    pub phase: Phase,
    pub wanted: fn(&World) -> bool,
    pub add: fn(&mut Schedule, Slot),
}

fn always(_: &World) -> bool {
    true
}
/// The DEM part runs when the scene has particles (or walls and inflows): the world then
/// has an integrator.
fn has_dem(w: &World) -> bool {
    w.contains_resource::<IntegratorKind>()
}
fn uses_gear(w: &World) -> bool {
    w.get_resource::<IntegratorKind>() == Some(&IntegratorKind::Gear)
}
fn uses_verlet(w: &World) -> bool {
    w.get_resource::<IntegratorKind>() == Some(&IntegratorKind::VelocityVerlet)
}
fn has_walls(w: &World) -> bool {
    w.contains_resource::<Walls>()
}
fn frictionless(w: &World) -> bool {
    has_dem(w) && !has_contact_laws(w)
}
fn wall_history(w: &World) -> bool {
    has_contact_laws(w) && has_walls(w)
}
fn gear_rotation(w: &World) -> bool {
    uses_gear(w) && has_rotation(w)
}
fn verlet_rotation(w: &World) -> bool {
    uses_verlet(w) && has_rotation(w)
}
fn has_removable_walls(w: &World) -> bool {
    w.get_resource::<Walls>()
        .is_some_and(|ws| ws.list.iter().any(|x| x.remove_at.is_some()))
}

/// The table of DEM systems, in step order within each set.
pub const REGISTRY: &[SystemEntry] = &[
    SystemEntry {
        name: "wall_removal",
        set: StepSet::Events,
        phase: Phase::Step,
        wanted: has_removable_walls,
        add: |s, set| {
            s.add_systems(walls::wall_removal.in_set(set));
        },
    },
    SystemEntry {
        name: "inflow_insertion",
        set: StepSet::Events,
        phase: Phase::Step,
        wanted: inflow::has_inflow,
        add: |s, set| {
            s.add_systems(inflow::inflow_insertion.in_set(set));
        },
    },
    SystemEntry {
        name: "sync_rows<GearState>",
        set: StepSet::SyncRows,
        phase: Phase::Both,
        wanted: uses_gear,
        add: |s, set| {
            s.add_systems(rows::sync_rows::<GearState>.in_set(set));
        },
    },
    SystemEntry {
        name: "sync_rows<VerletState>",
        set: StepSet::SyncRows,
        phase: Phase::Both,
        wanted: uses_verlet,
        add: |s, set| {
            s.add_systems(rows::sync_rows::<VerletState>.in_set(set));
        },
    },
    SystemEntry {
        name: "sync_rows<Rotation>",
        set: StepSet::SyncRows,
        phase: Phase::Both,
        wanted: has_rotation,
        add: |s, set| {
            s.add_systems(rows::sync_rows::<Rotation>.in_set(set));
        },
    },
    SystemEntry {
        name: "sync_rows<Clamped>",
        set: StepSet::SyncRows,
        phase: Phase::Both,
        wanted: has_clamped,
        add: |s, set| {
            s.add_systems(rows::sync_rows::<Clamped>.in_set(set));
        },
    },
    SystemEntry {
        name: "sync_rows<HydroForces>",
        set: StepSet::SyncRows,
        phase: Phase::Both,
        wanted: has_coupling,
        add: |s, set| {
            s.add_systems(rows::sync_rows::<HydroForces>.in_set(set));
        },
    },
    SystemEntry {
        name: "gear_predict",
        set: StepSet::Predict,
        phase: Phase::Step,
        wanted: uses_gear,
        add: |s, set| {
            s.add_systems(gear::gear_predict.in_set(set));
        },
    },
    SystemEntry {
        name: "verlet_predict",
        set: StepSet::Predict,
        phase: Phase::Step,
        wanted: uses_verlet,
        add: |s, set| {
            s.add_systems(verlet::verlet_predict.in_set(set));
        },
    },
    SystemEntry {
        name: "gear_rotation_predict",
        set: StepSet::Predict,
        phase: Phase::Step,
        wanted: gear_rotation,
        add: |s, set| {
            s.add_systems(rotation::gear_rotation_predict.in_set(set));
        },
    },
    SystemEntry {
        name: "verlet_rotation_predict",
        set: StepSet::Predict,
        phase: Phase::Step,
        wanted: verlet_rotation,
        add: |s, set| {
            s.add_systems(rotation::verlet_rotation_predict.in_set(set));
        },
    },
    SystemEntry {
        name: "hold_clamped_predicted",
        set: StepSet::Predict,
        phase: Phase::Step,
        wanted: has_clamped,
        add: |s, set| {
            s.add_systems(clamp::hold_clamped_predicted.in_set(set));
        },
    },
    SystemEntry {
        name: "verlet_list",
        set: StepSet::NeighbourList,
        phase: Phase::Both,
        wanted: has_dem,
        add: |s, set| {
            s.add_systems(neighbour_list::verlet_list.in_set(set));
        },
    },
    SystemEntry {
        name: "wall_list",
        set: StepSet::NeighbourList,
        phase: Phase::Both,
        wanted: has_walls,
        add: |s, set| {
            s.add_systems(walls::wall_list.in_set(set));
        },
    },
    SystemEntry {
        name: "carry_wall_history",
        set: StepSet::NeighbourList,
        phase: Phase::Both,
        wanted: wall_history,
        add: |s, set| {
            s.add_systems(granular::carry_wall_history.in_set(set));
        },
    },
    SystemEntry {
        name: "permute_rows<GearState>",
        set: StepSet::Reorder,
        phase: Phase::Both,
        wanted: uses_gear,
        add: |s, set| {
            s.add_systems(rows::permute_rows::<GearState>.in_set(set));
        },
    },
    SystemEntry {
        name: "permute_rows<VerletState>",
        set: StepSet::Reorder,
        phase: Phase::Both,
        wanted: uses_verlet,
        add: |s, set| {
            s.add_systems(rows::permute_rows::<VerletState>.in_set(set));
        },
    },
    SystemEntry {
        name: "permute_rows<Rotation>",
        set: StepSet::Reorder,
        phase: Phase::Both,
        wanted: has_rotation,
        add: |s, set| {
            s.add_systems(rows::permute_rows::<Rotation>.in_set(set));
        },
    },
    SystemEntry {
        name: "permute_rows<Clamped>",
        set: StepSet::Reorder,
        phase: Phase::Both,
        wanted: has_clamped,
        add: |s, set| {
            s.add_systems(rows::permute_rows::<Clamped>.in_set(set));
        },
    },
    SystemEntry {
        name: "permute_rows<HydroForces>",
        set: StepSet::Reorder,
        phase: Phase::Both,
        wanted: has_coupling,
        add: |s, set| {
            s.add_systems(rows::permute_rows::<HydroForces>.in_set(set));
        },
    },
    SystemEntry {
        name: "hertz_contact",
        set: StepSet::Contact,
        phase: Phase::Both,
        wanted: frictionless,
        add: |s, set| {
            s.add_systems(hertz::hertz_contact.in_set(set));
        },
    },
    SystemEntry {
        name: "granular_contact",
        set: StepSet::Contact,
        phase: Phase::Both,
        wanted: has_contact_laws,
        add: |s, set| {
            s.add_systems(granular::granular_contact.in_set(set));
        },
    },
    SystemEntry {
        name: "lubrication",
        set: StepSet::Contact,
        phase: Phase::Both,
        wanted: lubrication::has_lubrication,
        add: |s, set| {
            s.add_systems(lubrication::lubrication.in_set(set));
        },
    },
    SystemEntry {
        name: "velocity_blending",
        set: StepSet::VelocityBlending,
        phase: Phase::Step,
        wanted: has_coupling,
        add: |s, set| {
            s.add_systems(fictitious::velocity_blending.in_set(set));
        },
    },
    SystemEntry {
        name: "multigrid_fluid",
        set: StepSet::MultigridFluid,
        phase: Phase::Step,
        wanted: has_fluid,
        add: |s, set| {
            s.add_systems(fluid::multigrid_fluid.in_set(set));
        },
    },
    SystemEntry {
        name: "hydrodynamic_sampling",
        set: StepSet::HydrodynamicSampling,
        phase: Phase::Step,
        wanted: has_coupling,
        add: |s, set| {
            s.add_systems(hydrodynamic::hydrodynamic_sampling.in_set(set));
        },
    },
    SystemEntry {
        name: "gear_correct",
        set: StepSet::Correct,
        phase: Phase::Step,
        wanted: uses_gear,
        add: |s, set| {
            s.add_systems(gear::gear_correct.in_set(set));
        },
    },
    SystemEntry {
        name: "gear_start",
        set: StepSet::Correct,
        phase: Phase::Startup,
        wanted: uses_gear,
        add: |s, set| {
            s.add_systems(gear::gear_start.in_set(set));
        },
    },
    SystemEntry {
        name: "verlet_correct",
        set: StepSet::Correct,
        phase: Phase::Step,
        wanted: uses_verlet,
        add: |s, set| {
            s.add_systems(verlet::verlet_correct.in_set(set));
        },
    },
    SystemEntry {
        name: "gear_rotation_correct",
        set: StepSet::Correct,
        phase: Phase::Step,
        wanted: gear_rotation,
        add: |s, set| {
            s.add_systems(rotation::gear_rotation_correct.in_set(set));
        },
    },
    SystemEntry {
        name: "gear_rotation_start",
        set: StepSet::Correct,
        phase: Phase::Startup,
        wanted: gear_rotation,
        add: |s, set| {
            s.add_systems(rotation::gear_rotation_start.in_set(set));
        },
    },
    SystemEntry {
        name: "verlet_rotation_correct",
        set: StepSet::Correct,
        phase: Phase::Step,
        wanted: verlet_rotation,
        add: |s, set| {
            s.add_systems(rotation::verlet_rotation_correct.in_set(set));
        },
    },
    SystemEntry {
        name: "advance_clock",
        set: StepSet::Correct,
        phase: Phase::Step,
        wanted: always,
        add: |s, set| {
            s.add_systems(monitor::advance_clock.in_set(set));
        },
    },
    SystemEntry {
        name: "hold_clamped",
        set: StepSet::Correct,
        phase: Phase::Both,
        wanted: has_clamped,
        add: |s, set| {
            s.add_systems(clamp::hold_clamped.in_set(set));
        },
    },
    SystemEntry {
        name: "stability_monitor",
        set: StepSet::Monitor,
        phase: Phase::Both,
        wanted: has_dem,
        add: |s, set| {
            s.add_systems(monitor::stability_monitor.in_set(set));
        },
    },
];

/// Whether the corrector may predict the next step in its own pass
/// ([`grainflow_components::PredictAhead`]) in `world`: no system between the corrector and the next predictor
/// may change the particle state or read it on every step. So no inflow (it inserts rows
/// among particles it looks at), no held particles (put back on their path after the
/// corrector) and no fluid coupling (its recorder reads the particles every step).
pub fn corrector_may_predict_ahead(world: &World) -> bool {
    has_dem(world) && !inflow::has_inflow(world) && !has_clamped(world) && !has_coupling(world)
}

/// Build the step (or start-up) schedule for `world` from `REGISTRY` and the
/// application's `extra` entries (writers). Returns the schedule and the names of the
/// systems it runs, by set, for `grainflow check`.
pub fn build_schedule(
    world: &World,
    phase: Phase,
    extra: &[SystemEntry],
) -> (Schedule, Vec<(StepSet, &'static str)>) {
    let mut schedule = Schedule::default();
    // Systems parallelise internally with rayon; bevy's own task pool stays unused.
    schedule.set_executor(SingleThreadedExecutor::default());
    for pair in STEP_ORDER.windows(2) {
        schedule.configure_sets(pair[1].after(pair[0]));
    }
    let mut names = Vec::new();
    let mut previous: Option<Slot> = None;
    let entries = REGISTRY.iter().chain(extra);
    for set in STEP_ORDER {
        for (k, entry) in entries.clone().enumerate().filter(|(_, e)| e.set == set) {
            let in_phase = entry.phase == Phase::Both || entry.phase == phase;
            if in_phase && (entry.wanted)(world) {
                let slot = Slot(k);
                schedule.configure_sets(slot.in_set(set));
                if let Some(prev) = previous {
                    schedule.configure_sets(slot.after(prev));
                }
                (entry.add)(&mut schedule, slot);
                names.push((set, entry.name));
                previous = Some(slot);
            }
        }
    }
    (schedule, names)
}
