//! grainflow ECS data: plain components and resources, no behaviour.
//!
//! Per-particle data lives in structure-of-arrays blocks ([`Particles`], [`GearState`])
//! owned by the ECS world as resources; the hot loops of `grainflow-systems` run on their
//! contiguous columns. Any per-particle block implements [`PerParticle`] so that particle
//! re-sorting and insertion keep every block aligned without the owner of the block being
//! known to the neighbour-list or insertion systems.

pub mod clock;
pub mod clump;
pub mod contact_law;
pub mod coupling;
pub mod energy;
pub mod health;
pub mod inflow;
pub mod integrator;
pub mod lubrication;
pub mod material;
pub mod neighbour;
pub mod particles;
pub mod rotation;
pub mod sinks;
pub mod walls;

pub use clock::SimClock;
pub use clump::{BodyAux, BodyState, ClumpMember, ClumpType, Clumps};
pub use contact_law::{
    AdhesionLaw, ContactLaw, ContactLaws, FrictionLaw, HistoryLayout, RollingLaw,
    TangentialStiffness, WallHistory,
};
pub use coupling::{
    BoundaryRule, CellMarkers, Coupling, ForceMethod, HydroForces, InsideFluid, ParticleFace,
    ParticleUpdate, SphereRule,
};
pub use energy::EnergyBalance;
pub use health::RunHealth;
pub use inflow::{Inflow, InflowRegion, Inflows};
pub use integrator::{GearState, IntegratorKind, PredictAhead, VerletState};
pub use lubrication::Lubrication;
pub use material::{BodyAcceleration, DampingLaw, Material, Materials, PairParams};
pub use neighbour::{
    ContactHistory, NeighbourSettings, PairList, Reorder, ScatterPlan, StepMotion, VerletList,
    WallList,
};
pub use particles::{NewParticle, Particles, PerParticle};
pub use rotation::{Clamped, Rotation};
pub use sinks::{Sink, SinkEvent, Sinks};
pub use walls::{Wall, WallShape, Walls};

/// Three coordinate columns of one per-particle vector quantity (x, y, z).
pub type Columns = [Vec<f64>; 3];
