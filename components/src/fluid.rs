use bevy_ecs::prelude::Resource;
use grainflow_fluid::{NavierStokes, StepReport};

/// The flow of a scene with a fluid grid: the Navier-Stokes solver of `grainflow-fluid`
/// (its grid, velocity on faces and pressure on cells, multigrid hierarchies), the time
/// of its next step, and the run figures of its steps. Present only when the scene has a
/// fluid grid.
#[derive(Resource)]
pub struct FluidFlow {
    pub solver: NavierStokes,
    /// Fluid time step dt_F.
    pub dt: f64,
    /// Simulated time at which the next fluid step starts.
    pub next_time: f64,
    pub stats: FluidStats,
    /// Velocity scale of the scene (its units): the largest of the boundary speeds,
    /// sqrt(|f| L) of the body force f, sqrt(|g| L) of gravity and the viscous speed
    /// nu / L (L the domain's diagonal). A flow faster than `RUNAWAY_FACTOR` times it
    /// (or than that multiple of the fastest particle) has run away
    /// (`grainflow_systems::fluid`).
    pub velocity_scale: f64,
}

impl FluidFlow {
    /// Whether the DEM step starting at `time` (length `dt`) starts a fluid step: the
    /// fluid time is reached within half a DEM step.
    pub fn is_due(&self, time: f64, dt: f64) -> bool {
        time + 0.5 * dt >= self.next_time
    }
}

/// Sums over the fluid steps of a run, for the run report.
#[derive(Debug, Clone, Copy, Default)]
pub struct FluidStats {
    pub steps: u64,
    pub seconds: f64,
    pub momentum_cycles: u64,
    /// Sum of ln(reduction per cycle) over the steps (their geometric mean is reported).
    pub momentum_log_rate: f64,
    pub pressure_cycles: u64,
    pub pressure_log_rate: f64,
    /// Wall seconds of the momentum solves and of the pressure solves.
    pub momentum_seconds: f64,
    pub pressure_seconds: f64,
    pub max_divergence: f64,
}

impl FluidStats {
    /// Add one step's report.
    pub fn add(&mut self, r: &StepReport) {
        self.steps += 1;
        self.seconds += r.seconds;
        self.momentum_cycles += r.momentum_cycles as u64;
        self.momentum_log_rate += r.momentum_reduction.max(1e-300).ln();
        self.pressure_cycles += r.pressure_cycles as u64;
        self.pressure_log_rate += r.pressure_reduction.max(1e-300).ln();
        self.momentum_seconds += r.momentum_seconds;
        self.pressure_seconds += r.pressure_seconds;
        self.max_divergence = self.max_divergence.max(r.max_divergence);
    }
}
