use bevy_ecs::prelude::Resource;

use crate::particles::permute_column;
use crate::{Columns, PerParticle};

/// Rotational state of the particles, present when some contact produces torques
/// (friction, rolling resistance): torque of the step, the
/// orientation quaternion (w, x, y, z; for later shaped particles and for output), and
/// the integrator's extra columns for the angular velocity (Gear: dw/dt, d2w/dt2,
/// d3w/dt3 as the last corrector left them; velocity Verlet: w(t + dt/2)).
#[derive(Resource, Debug, Clone, Default)]
pub struct Rotation {
    pub torque: Columns,
    pub orientation: [Vec<f64>; 4],
    pub aux: Vec<Columns>,
}

impl PerParticle for Rotation {
    fn resize_rows(&mut self, n: usize) {
        for col in self.torque.iter_mut().chain(self.aux.iter_mut().flatten()) {
            col.resize(n, 0.0);
        }
        self.orientation[0].resize(n, 1.0);
        for col in &mut self.orientation[1..] {
            col.resize(n, 0.0);
        }
    }
    fn permute_rows(&mut self, perm: &[u32]) {
        for col in self
            .torque
            .iter_mut()
            .chain(self.aux.iter_mut().flatten())
            .chain(self.orientation.iter_mut())
        {
            permute_column(col, perm);
        }
    }
    fn bytes_per_row(&self) -> usize {
        8 * (3 + 4 + 3 * self.aux.len())
    }
}

/// Kinematic (fixed) particles: a particle with `held[i]` set moves with its constant
/// velocity and does not rotate, whatever the forces (the anchor of a pendulum, a
/// displacement-controlled probe). Present only when the scene has such particles.
#[derive(Resource, Debug, Clone, Default)]
pub struct Clamped {
    pub held: Vec<bool>,
    /// Position of held particles at t = 0: x(t) = origin + velocity t.
    pub origin: Columns,
    /// Prescribed velocity of held particles (zero rows for free ones).
    pub velocity: Columns,
}

impl PerParticle for Clamped {
    fn resize_rows(&mut self, n: usize) {
        self.held.resize(n, false);
        for col in self.origin.iter_mut().chain(self.velocity.iter_mut()) {
            col.resize(n, 0.0);
        }
    }
    fn permute_rows(&mut self, perm: &[u32]) {
        permute_column(&mut self.held, perm);
        for col in self.origin.iter_mut().chain(self.velocity.iter_mut()) {
            permute_column(col, perm);
        }
    }
    fn bytes_per_row(&self) -> usize {
        1 + 48
    }
}
