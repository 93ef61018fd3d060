//! The flow step: one time step of the incompressible Navier-Stokes solver
//! (`grainflow-fluid`: Q1~/Q0 elements, discrete projection, multigrid) whenever the
//! simulated time reaches the next fluid time, so that the DEM steps between two fluid
//! steps (the seed's subcycling, dt_F = n_s dt_D) see one flow field.
use bevy_ecs::prelude::*;
use grainflow_components::{FluidFlow, SimClock};

pub fn has_fluid(w: &World) -> bool {
    w.contains_resource::<FluidFlow>()
}

pub fn multigrid_fluid(clock: Res<SimClock>, mut flow: ResMut<FluidFlow>) {
    // Half a DEM step of slack: the fluid step starts at the DEM step nearest its time.
    if clock.time + 0.5 * clock.dt < flow.next_time {
        return;
    }
    let _span = tracing::info_span!("multigrid_fluid").entered();
    let report = flow.solver.step();
    flow.stats.add(&report);
    flow.next_time += flow.dt;
}
