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
    if !flow.is_due(clock.time, clock.dt) {
        return;
    }
    let _span = tracing::info_span!("multigrid_fluid").entered();
    let report = flow.solver.step();
    flow.stats.add(&report);
    flow.next_time += flow.dt;
}

/// DEM subcycles per fluid step (seed, "Coupling of FEM-DEM on the time level", after
/// Feng & Owen 2007): `n_s = int(dt_F / dt_D) + 1`, run with `dt_D' = dt_F / n_s`. A ratio
/// within 1e-9 of a whole number counts as that number (1e-4 / 1e-5 gives 11 subcycles,
/// not 10 or 11 by rounding luck).
pub fn subcycles(dt_fluid: f64, dt_dem: f64) -> u32 {
    let ratio = dt_fluid / dt_dem;
    let whole = if (ratio - ratio.round()).abs() <= 1e-9 * ratio {
        ratio.round()
    } else {
        ratio.floor()
    };
    whole as u32 + 1
}
