//! The time step of grainflow, in order, and the table of its systems.
//!
//! A scene with a flow steps as the seed's "Coupling of FEM-DEM on the time level": one
//! fluid step, its coupling to the particles, then n_s DEM substeps
//! (`crate::coupling::subcycles`). [`CoupledStep`] runs it, one DEM substep at a time:
//!
//! ```text
//! every fluid step (dt_F):
//!     DEM substep 1 of n_s (dt_D' = dt_F / n_s):
//!         DEM first half:    Events, SyncRows, Predict, NeighbourList, Reorder, Contact
//!         fluid step:        CouplingBeforeFlow, FlowStep, CouplingAfterFlow
//!         DEM second half:   HydrodynamicForce, Correct, Monitor, Output
//!     DEM substeps 2 .. n_s:
//!         DEM first half, DEM second half
//! ```
//!
//! A scene without a flow has only the two halves of the DEM step; a scene with a flow and
//! no particles has only the fluid step and the clock and output of the second half. The
//! sets (the seed's "efficient computation" slide: neighbour list, contact,
//! hydrodynamics, Gear predictor-corrector):
//!
//! 1. `Events`: walls removed at their time, particles past a sink queued for removal
//!    (`sink_removal`; the neighbour list drops their rows), particles inserted by inflows
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
//! 7. `CouplingBeforeFlow`: the particles' cell markers and their rigid-body velocity on
//!    the faces inside them (`cell_markers`), and the smooth transition around them
//!    (`velocity_blending`, when the scene sets `alpha`)
//! 8. `FlowStep`: one Navier-Stokes step of dt_F (`multigrid_fluid`)
//! 9. `CouplingAfterFlow`: the hydrodynamic force and torque of every particle from the
//!    new flow (`hydrodynamic_sampling`)
//! 10. `HydrodynamicForce`: in every substep the force and torque of the last fluid step,
//!     held constant, added to the contact forces (`held_hydrodynamic_force`)
//! 11. `Correct`: integrator corrector with body forces (gravity, buoyancy), rotation
//!     under contact torques; the clock; kinematic (fixed) particles put back on their
//!     path. When the run loop grants `PredictAhead` (see
//!     [`corrector_may_predict_ahead`]), the translation corrector also runs the next
//!     step's predictor on each row in the same pass
//! 12. `Monitor`: stability checks (overlap, non-finite state) and the energy balance
//!     (`energy_monitor`, every 64 steps)
//! 13. `Output`: writers (added by the application)
//!
//! A scene gets only the systems whose `wanted` test passes on its world, so a scene
//! without inflow, walls, Gear or a flow neither runs nor allocates their systems. Adding
//! a model means one file with its systems and one line in [`REGISTRY`].
use bevy_ecs::prelude::*;
use bevy_ecs::schedule::SingleThreadedExecutor;
use grainflow_components::{GearState, IntegratorKind, SimClock, VerletState, Walls};

use crate::contact::with_history::has_contact_laws;
use crate::contact::{frictionless, wall_pass, walls, with_history};
use crate::coupling::{has_blending, has_coupling};
use crate::fluid::{has_fluid, FluidFlow};
use crate::integrate::clamp::has_clamped;
use crate::integrate::rigid_body::has_clumps;
use crate::integrate::rotation::has_rotation;
use crate::integrate::{clamp, gear, rigid_body, rotation, verlet};
use crate::neighbour::verlet_list;
use crate::{coupling, energy, fluid, inflow, monitor, rows, sinks};
use grainflow_components::{Clamped, Coupling, HydroForces, Rotation};

/// The ordered phases of a step.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum StepSet {
    Events,
    SyncRows,
    Predict,
    NeighbourList,
    Reorder,
    Contact,
    CouplingBeforeFlow,
    FlowStep,
    CouplingAfterFlow,
    HydrodynamicForce,
    Correct,
    Monitor,
    Output,
}

/// The DEM substep up to its contact forces, in order.
pub const DEM_FIRST_HALF: [StepSet; 6] = [
    StepSet::Events,
    StepSet::SyncRows,
    StepSet::Predict,
    StepSet::NeighbourList,
    StepSet::Reorder,
    StepSet::Contact,
];

/// The fluid step with its coupling, in order: run inside the first DEM substep of each
/// fluid step, after [`DEM_FIRST_HALF`].
pub const FLUID_STEP: [StepSet; 3] = [
    StepSet::CouplingBeforeFlow,
    StepSet::FlowStep,
    StepSet::CouplingAfterFlow,
];

/// The DEM substep from the hydrodynamic force on, in order.
pub const DEM_SECOND_HALF: [StepSet; 4] = [
    StepSet::HydrodynamicForce,
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
        name: "sink_removal",
        set: StepSet::Events,
        phase: Phase::Step,
        wanted: sinks::has_sinks,
        add: |s, set| {
            s.add_systems(sinks::sink_removal.in_set(set));
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
        name: "clump_predict",
        set: StepSet::Predict,
        phase: Phase::Step,
        wanted: has_clumps,
        add: |s, set| {
            s.add_systems(rigid_body::clump_predict.in_set(set));
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
            s.add_systems(verlet_list::verlet_list.in_set(set));
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
            s.add_systems(wall_pass::carry_wall_history.in_set(set));
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
        name: "clump_member_rows",
        set: StepSet::Reorder,
        phase: Phase::Both,
        wanted: has_clumps,
        add: |s, set| {
            s.add_systems(rigid_body::clump_member_rows.in_set(set));
        },
    },
    SystemEntry {
        name: "hertz_contact",
        set: StepSet::Contact,
        phase: Phase::Both,
        wanted: frictionless,
        add: |s, set| {
            s.add_systems(frictionless::hertz_contact.in_set(set));
        },
    },
    SystemEntry {
        name: "granular_contact",
        set: StepSet::Contact,
        phase: Phase::Both,
        wanted: has_contact_laws,
        add: |s, set| {
            s.add_systems(with_history::granular_contact.in_set(set));
        },
    },
    SystemEntry {
        name: "lubrication",
        set: StepSet::Contact,
        phase: Phase::Both,
        wanted: coupling::lubrication::has_lubrication,
        add: |s, set| {
            s.add_systems(coupling::lubrication::lubrication.in_set(set));
        },
    },
    SystemEntry {
        name: "cell_markers",
        set: StepSet::CouplingBeforeFlow,
        phase: Phase::Step,
        wanted: has_coupling,
        add: |s, set| {
            s.add_systems(coupling::markers::cell_markers.in_set(set));
        },
    },
    SystemEntry {
        name: "velocity_blending",
        set: StepSet::CouplingBeforeFlow,
        phase: Phase::Step,
        wanted: has_blending,
        add: |s, set| {
            s.add_systems(coupling::blending::velocity_blending.in_set(set));
        },
    },
    SystemEntry {
        name: "multigrid_fluid",
        set: StepSet::FlowStep,
        phase: Phase::Step,
        wanted: has_fluid,
        add: |s, set| {
            s.add_systems(fluid::multigrid_fluid.in_set(set));
        },
    },
    SystemEntry {
        name: "hydrodynamic_sampling",
        set: StepSet::CouplingAfterFlow,
        phase: Phase::Step,
        wanted: has_coupling,
        add: |s, set| {
            s.add_systems(coupling::sampling::hydrodynamic_sampling.in_set(set));
        },
    },
    SystemEntry {
        name: "held_hydrodynamic_force",
        set: StepSet::HydrodynamicForce,
        phase: Phase::Step,
        wanted: has_coupling,
        add: |s, set| {
            s.add_systems(coupling::sampling::held_hydrodynamic_force.in_set(set));
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
        name: "clump_correct",
        set: StepSet::Correct,
        phase: Phase::Step,
        wanted: has_clumps,
        add: |s, set| {
            s.add_systems(rigid_body::clump_correct.in_set(set));
        },
    },
    SystemEntry {
        name: "clump_start",
        set: StepSet::Correct,
        phase: Phase::Startup,
        wanted: has_clumps,
        add: |s, set| {
            s.add_systems(rigid_body::clump_start.in_set(set));
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
    SystemEntry {
        name: "energy_monitor",
        set: StepSet::Monitor,
        phase: Phase::Both,
        wanted: has_dem,
        add: |s, set| {
            s.add_systems(energy::energy_monitor.in_set(set));
        },
    },
];

/// Whether the corrector may predict the next step in its own pass
/// ([`grainflow_components::PredictAhead`]) in `world`: no system between the corrector and the next predictor
/// may change the particle state or read it on every step. So no inflow (it inserts rows
/// among particles it looks at), no held particles (put back on their path after the
/// corrector), no clumps (their members are placed after the corrector) and no fluid
/// coupling (its recorder reads the particles every step).
pub fn corrector_may_predict_ahead(world: &World) -> bool {
    has_dem(world)
        && !inflow::has_inflow(world)
        && !has_clamped(world)
        && !has_clumps(world)
        && !has_coupling(world)
}

/// Build the schedule of the `sets` (in this order) for `world` from `REGISTRY` and the
/// application's `extra` entries (writers), with the systems of `phase`. Returns the
/// schedule and the names of the systems it runs, by set, for `grainflow check`.
pub fn build_schedule(
    world: &World,
    phase: Phase,
    sets: &[StepSet],
    extra: &[SystemEntry],
) -> (Schedule, Vec<(StepSet, &'static str)>) {
    let mut schedule = Schedule::default();
    // Systems parallelise internally with rayon; bevy's own task pool stays unused.
    schedule.set_executor(SingleThreadedExecutor::default());
    for pair in sets.windows(2) {
        schedule.configure_sets(pair[1].after(pair[0]));
    }
    let mut names = Vec::new();
    let mut previous: Option<Slot> = None;
    let entries = REGISTRY.iter().chain(extra);
    for &set in sets {
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

/// The start-up schedule of `world`: forces at t = 0 and the integrators' start values,
/// the systems of [`Phase::Startup`] in step order.
pub fn build_startup(world: &World) -> Schedule {
    let sets = [&DEM_FIRST_HALF[..], &FLUID_STEP, &DEM_SECOND_HALF].concat();
    build_schedule(world, Phase::Startup, &sets, &[]).0
}

/// The time step of a scene (module docs): the two halves of a DEM substep and, between
/// them in the first substep of each fluid step, the fluid step with its coupling.
pub struct CoupledStep {
    dem_first_half: Schedule,
    /// `None` without a flow.
    fluid_step: Option<Schedule>,
    dem_second_half: Schedule,
    /// DEM substeps per fluid step n_s (1 without coupling).
    pub substeps: u32,
    /// The systems of the first half, the fluid step and the second half, in order, by set.
    pub systems: Vec<(StepSet, &'static str)>,
}

impl CoupledStep {
    /// The step of `world`, with the application's `extra` entries (writers).
    pub fn new(world: &World, extra: &[SystemEntry]) -> Self {
        let (dem_first_half, mut systems) =
            build_schedule(world, Phase::Step, &DEM_FIRST_HALF, extra);
        let fluid_step = has_fluid(world).then(|| {
            let (schedule, names) = build_schedule(world, Phase::Step, &FLUID_STEP, extra);
            systems.extend(names);
            schedule
        });
        let (dem_second_half, names) = build_schedule(world, Phase::Step, &DEM_SECOND_HALF, extra);
        systems.extend(names);
        Self {
            dem_first_half,
            fluid_step,
            dem_second_half,
            substeps: world.get_resource::<Coupling>().map_or(1, |c| c.subcycles),
            systems,
        }
    }

    /// One DEM substep: its first half, the fluid step with its coupling if the substep
    /// starts one ([`starts_fluid_step`]), its second half.
    pub fn run_substep(&mut self, world: &mut World) {
        self.dem_first_half.run(world);
        if let Some(fluid_step) = &mut self.fluid_step {
            if starts_fluid_step(world) {
                fluid_step.run(world);
            }
        }
        self.dem_second_half.run(world);
    }
}

/// Whether the DEM substep under way starts a fluid step: the substep starts within half
/// a step of the fluid time ([`FluidFlow::next_time`], advanced by dt_F at each fluid
/// step). In a coupled scene, whose DEM step is dt_F / n_s, this is the first of every
/// n_s substeps; a scene with a flow and no particles steps its flow at the first step
/// that reaches each multiple of dt_F.
pub fn starts_fluid_step(world: &World) -> bool {
    let clock = world.resource::<SimClock>();
    let flow = world.resource::<FluidFlow>();
    clock.time + 0.5 * clock.dt >= flow.next_time
}
