use bevy_ecs::prelude::Resource;

use crate::{Columns, PerParticle};

/// Time integrator of the DEM equations of motion.
#[derive(Resource, Debug, Clone, Copy, PartialEq, Eq)]
pub enum IntegratorKind {
    /// Gear predictor-corrector with five values (x, v, a, b = da/dt, c = db/dt),
    /// Allen & Tildesley (1987), Appendix E.
    Gear,
    /// Velocity Verlet (Swope et al. 1982).
    VelocityVerlet,
}

/// Higher time derivatives of the position kept by the Gear predictor-corrector
/// (acceleration, its first and second time derivative), one row per particle, as the
/// last corrector left them (the predictor moves x and v only; the corrector forms the
/// predicted derivatives itself). Allocated only when the scene uses Gear.
#[derive(Resource, Debug, Clone, Default)]
pub struct GearState {
    pub acc: Columns,
    pub jerk: Columns,
    pub snap: Columns,
    /// Corrector coefficient alpha_0: 19/120, or 19/90 when forces depend on velocity.
    pub alpha0: f64,
    /// Rows 0..predicted_rows of `Particles::position` and `velocity` already hold this
    /// step's prediction: the last corrector predicted ahead ([`PredictAhead`]). The
    /// predictor moves the other rows and sets it back to 0.
    pub predicted_rows: usize,
}

/// Leave for the corrector (Gear or velocity Verlet) to predict the next step's x and v
/// in its own pass (one pass over the integrator state per step instead of two), set by
/// the run loop before each step. The world has it only when no system between the
/// corrector and the next predictor changes the particle state or reads it on every step;
/// the run loop grants it for a step unless a writer reads the state after it or the run
/// ends with it.
#[derive(Resource, Debug, Clone, Copy, Default)]
pub struct PredictAhead {
    pub allowed: bool,
}

impl PerParticle for GearState {
    fn resize_rows(&mut self, n: usize) {
        for col in self
            .acc
            .iter_mut()
            .chain(&mut self.jerk)
            .chain(&mut self.snap)
        {
            col.resize(n, 0.0);
        }
    }
    fn permute_rows(&mut self, perm: &[u32]) {
        for col in self
            .acc
            .iter_mut()
            .chain(&mut self.jerk)
            .chain(&mut self.snap)
        {
            crate::particles::permute_column(col, perm);
        }
    }
    fn bytes_per_row(&self) -> usize {
        9 * 8
    }
}

/// The half-step velocity v(t + dt/2) kept by velocity Verlet between its predictor and
/// corrector, one row per particle; meanwhile `Particles::velocity` holds the estimate of
/// v(t + dt) used by velocity-dependent (damping) forces. Allocated only when the scene
/// uses velocity Verlet.
#[derive(Resource, Debug, Clone, Default)]
pub struct VerletState {
    pub half_velocity: Columns,
    /// Rows 0..predicted_rows already hold this step's prediction (as in [`GearState`]).
    pub predicted_rows: usize,
}

impl PerParticle for VerletState {
    fn resize_rows(&mut self, n: usize) {
        for col in self.half_velocity.iter_mut() {
            col.resize(n, 0.0);
        }
    }
    fn permute_rows(&mut self, perm: &[u32]) {
        for col in self.half_velocity.iter_mut() {
            crate::particles::permute_column(col, perm);
        }
    }
    fn bytes_per_row(&self) -> usize {
        3 * 8
    }
}
