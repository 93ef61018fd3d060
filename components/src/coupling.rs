//! ECS data of the fluid-particle coupling (seed, "Coupling of the phases"): the
//! coupling parameters, the level-set cell markers of the fictitious domain, and the
//! hydrodynamic force and torque of every particle, held constant over the DEM subcycles
//! of a fluid step. Present only when a scene has both a fluid grid and particles.
use bevy_ecs::prelude::Resource;

use crate::particles::permute_column;
use crate::{Columns, PerParticle};

/// How the hydrodynamic force on a particle is computed from the flow.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ForceMethod {
    /// Lagrangian force points on the sphere's surface with Lebedev-Laikov weights
    /// (seed: `F = J sum_i w_i t_i`, `J = 4 pi r^2`, `t = <sigma> n`).
    SurfacePoints,
    /// The volume integral of the fictitious boundary method, F = -int sigma . grad(alpha)
    /// over the cells cut by the particle (Wan & Turek 2006).
    VolumeIntegral,
}

/// Where the fluid sees a particle's surface.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoundaryRule {
    /// A face belongs to the particle when its centre lies inside: the body the flow sees
    /// is a staircase of faces, up to a face spacing inside the true surface, and it
    /// changes in steps as the particle moves.
    FaceCentre,
    /// As [`BoundaryRule::FaceCentre`], plus an implicit penalty on the faces within one
    /// cell outside the surface that places the no-slip wall at the true surface
    /// (`grainflow_systems::coupling::distance_penalty`).
    DistancePenalty,
}

/// How a free particle's velocity follows from the flow at each fluid step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParticleUpdate {
    /// The faces inside the particle start the fluid step at its rigid-body velocity and
    /// move with the fluid through the step; the momentum they gain is the hydrodynamic
    /// impulse on the particle (Sharma & Patankar 2005, J. Comput. Phys. 205:439: the
    /// rigid motion from the momentum of the fluid inside the particle). The fluid inside
    /// takes its pressure and viscous impulses in the same implicit solve as the fluid
    /// around it, so the added mass is implicit: stable for any density ratio >= 1.
    FluidMomentum,
    /// The faces inside the particle are held at its rigid-body velocity through the
    /// step (a Dirichlet condition, Wan & Turek 2006) and the force is computed from the
    /// new flow by [`ForceMethod`]: explicit in the particle velocity.
    Prescribed,
}

/// How the fluid inside a free particle accelerates through a fluid step under
/// [`ParticleUpdate::FluidMomentum`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InsideFluid {
    /// With the particle: a load on the faces inside (the particle's predicted
    /// acceleration less the fluid's own, `grainflow_systems::coupling::markers`) keeps
    /// them moving as the particle does through the step, so the flow sees the particle
    /// where and as fast as it is.
    Particle,
    /// As fluid, by the force of the fluid around it alone (the rule before issue 37): at
    /// a terminal velocity the body the flow sees slows by `(rho_p / rho_f - 1) g dt_F`
    /// within each step while the particle does not, a first-order time error (a settling
    /// sphere falls too fast).
    Fluid,
}

/// A fluid face inside a particle under [`ParticleUpdate::FluidMomentum`]: its index,
/// the particle's row and id (the row may change before the next fluid step, the id
/// does not), the rigid-body velocity it started the fluid step with, and the body force
/// per unit mass it felt through the step (the load that makes the fluid inside the
/// particle accelerate with the particle).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ParticleFace {
    pub face: u32,
    pub row: u32,
    pub id: u32,
    pub start: [f64; 3],
    pub load: [f64; 3],
}

/// Directions and weights of a quadrature rule on the unit sphere (weights sum to 1).
#[derive(Debug, Clone, Default)]
pub struct SphereRule {
    pub direction: Vec<[f64; 3]>,
    pub weight: Vec<f64>,
}

/// Coupling parameters of the scene.
#[derive(Resource, Debug, Clone)]
pub struct Coupling {
    /// Fluid density rho_f (the flow solver works with density 1: stresses are scaled).
    pub fluid_density: f64,
    /// Kinematic viscosity nu of the fluid.
    pub viscosity: f64,
    /// Exponent factor of the velocity blending phi = exp(-alpha Re_p) (Luo et al. 2007);
    /// `None`: no blending.
    pub alpha: Option<f64>,
    /// Force on particles whose faces are held ([`ParticleUpdate::Prescribed`], and
    /// fixed particles under any update).
    pub method: ForceMethod,
    /// How free particles follow the flow.
    pub update: ParticleUpdate,
    /// How the fluid inside free particles accelerates (fluid-momentum update).
    pub inside: InsideFluid,
    /// Where the fluid sees the particles' surfaces.
    pub boundary: BoundaryRule,
    /// Force points of [`ForceMethod::SurfacePoints`].
    pub rule: SphereRule,
    /// DEM subcycles per fluid step, n_s = int(dt_F / dt_D) + 1 (seed; Feng & Owen).
    pub subcycles: u32,
}

/// Level-set markers of the fluid cells (seed: 0 outer, p boundary, -p inner cell of
/// particle p = row + 1 of the current particle order), the list of marked cells, the
/// faces held at a particle's rigid-body velocity at the last marking (so that clearing
/// costs what marking cost, not the grid), the faces inside free particles under
/// [`ParticleUpdate::FluidMomentum`] (sorted by face; each face belongs to one particle),
/// when the scene blends, the faces to blend: (face, particle row) of the faces of a
/// particle's boundary cells that lie outside every particle (sorted), and under
/// [`BoundaryRule::DistancePenalty`] the particle row of each penalised face, in the order
/// of the flow solver's penalty list.
#[derive(Resource, Debug, Clone, Default)]
pub struct CellMarkers {
    pub marker: Vec<i32>,
    pub marked: Vec<u32>,
    pub rigid_faces: Vec<u32>,
    pub particle_faces: Vec<ParticleFace>,
    pub blend_faces: Vec<(u32, u32)>,
    pub penalty_rows: Vec<u32>,
}

/// Hydrodynamic force and torque on every particle from the last fluid step, added to
/// the contact forces in every DEM subcycle until the next fluid step.
#[derive(Resource, Debug, Clone, Default)]
pub struct HydroForces {
    pub force: Columns,
    pub torque: Columns,
    /// Momentum per time moved between the fluid and each particle before the last fluid
    /// step, by the faces that entered and left it (fluid-momentum update) and by the
    /// velocity blending; added to `force` and `torque` when they are sampled.
    pub exchange_force: Columns,
    pub exchange_torque: Columns,
    /// Force of the fluid around each free particle on the fluid inside it in the last
    /// fluid step (fluid-momentum update, without the load): what accelerates the fluid
    /// inside when it carries no load.
    pub inside_force: Columns,
    /// Fluid steps whose forces have been sampled.
    pub sampled_steps: u64,
}

impl HydroForces {
    fn columns(&mut self) -> impl Iterator<Item = &mut Vec<f64>> {
        self.force
            .iter_mut()
            .chain(self.torque.iter_mut())
            .chain(self.exchange_force.iter_mut())
            .chain(self.exchange_torque.iter_mut())
            .chain(self.inside_force.iter_mut())
    }
}

impl PerParticle for HydroForces {
    fn resize_rows(&mut self, n: usize) {
        for col in self.columns() {
            col.resize(n, 0.0);
        }
    }
    fn permute_rows(&mut self, perm: &[u32]) {
        for col in self.columns() {
            permute_column(col, perm);
        }
    }
    fn bytes_per_row(&self) -> usize {
        8 * 15
    }
}
