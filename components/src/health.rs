use bevy_ecs::prelude::Resource;

/// Per-step diagnostics written by the contact and integrator systems and checked by the
/// monitor: largest overlap (as a fraction of the smaller radius) and the first failure.
#[derive(Resource, Debug, Clone, Default)]
pub struct RunHealth {
    /// Largest overlap / radius of this step and the stable id of the particle that has it.
    pub max_overlap_ratio: f64,
    pub max_overlap_particle: u32,
    /// Largest overlap ratio seen over the whole run.
    pub run_max_overlap_ratio: f64,
    /// Overlap ratio above which the run is declared unstable.
    pub overlap_limit: f64,
    /// Set by an integrator whose own pass found every position and velocity it left
    /// finite, well below overflow: the monitor then skips its pass over them (and clears
    /// it).
    pub state_found_finite: bool,
    /// Stable id of a particle whose state is not finite after the corrector, if any.
    pub non_finite_particle: Option<u32>,
    /// Set by the monitor: why the run must stop.
    pub failure: Option<String>,
}
