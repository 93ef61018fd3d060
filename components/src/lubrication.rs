//! Parameters of the lubrication correction between particles closer than the fluid grid
//! resolves (see `grainflow_systems::coupling::lubrication`). Present only in coupled scenes that
//! ask for it.
use bevy_ecs::prelude::Resource;

/// Lubrication correction settings of the scene.
#[derive(Resource, Debug, Clone, Copy, PartialEq)]
pub struct Lubrication {
    /// Dynamic viscosity mu = rho_f nu of the fluid.
    pub viscosity: f64,
    /// Surface gap below which the correction acts (about one fluid cell: above it the
    /// grid resolves the squeeze flow).
    pub range: f64,
    /// Smallest gap the correction uses (surface roughness): below it, and in contact, the
    /// force is that of this gap, so it stays finite.
    pub roughness: f64,
}
