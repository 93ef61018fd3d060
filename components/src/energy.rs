use bevy_ecs::prelude::Resource;

/// The particles' mechanical energy against what they started with and what the inflows
/// brought in, kept by the energy monitor (`grainflow-systems` `energy`). Energies in J;
/// potential energy of the body acceleration (gravity less buoyancy) with its zero at the
/// origin of the scene's coordinates.
#[derive(Resource, Debug, Clone, Default)]
pub struct EnergyBalance {
    /// Whether a growth beyond [`EnergyBalance::tolerance`] stops the run: only where
    /// nothing but contacts and the body acceleration acts on the particles (no flow grid,
    /// no kinematic particles, no adhesion, whose surface energy may turn into motion).
    pub enforced: bool,
    /// Allowed growth of the energy over `initial + inserted`, as a fraction of
    /// [`EnergyBalance::scale`].
    pub tolerance: f64,
    /// Kinetic energy of translation and of rotation, potential energy of the body
    /// acceleration and elastic (Hertz) energy of the contacts, at the last check.
    pub kinetic: f64,
    pub rotational: f64,
    pub potential: f64,
    pub elastic: f64,
    /// Mechanical energy (all four) of the particles present at the start.
    pub initial: f64,
    /// Kinetic plus potential energy of the inserted particles, each at the first check
    /// that saw it.
    pub inserted: f64,
    /// Kinetic (translation and rotation) plus potential energy of the particles removed
    /// through sinks, each at the check that found it past its sink.
    pub removed: f64,
    /// Particle ids below this one are in `initial` or `inserted`.
    pub counted_ids: u32,
    /// The energy the growth is measured against: the largest kinetic energy (translation
    /// and rotation) of any check so far, at least sum m |a| r (lifting every particle by
    /// its radius) and at least the largest elastic energy.
    pub scale: f64,
    /// The largest growth seen, `(E - initial - inserted) / scale`, and its step.
    pub largest_growth: f64,
    pub largest_growth_step: u64,
    /// The step of the last check.
    pub checked_step: u64,
    /// Checks made (the start and every `ENERGY_CHECK_INTERVAL` steps).
    pub checks: u64,
}

impl EnergyBalance {
    /// Kinetic (translation and rotation), potential and elastic energy at the last check.
    pub fn total(&self) -> f64 {
        self.kinetic + self.rotational + self.potential + self.elastic
    }
    /// The energy the particles present should hold without dissipation:
    /// `initial + inserted - removed`.
    pub fn supplied(&self) -> f64 {
        self.initial + self.inserted - self.removed
    }
    /// What damping and friction dissipated (with the energy of the tangential and
    /// rolling springs, not counted): `supplied - total`.
    pub fn dissipated(&self) -> f64 {
        self.supplied() - self.total()
    }
}
