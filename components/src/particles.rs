use bevy_ecs::prelude::Resource;

use crate::Columns;

/// A block of per-particle rows that must stay aligned with [`Particles`].
pub trait PerParticle: Send + Sync + 'static {
    /// Grow (new rows take their default) or shrink to `n` rows.
    fn resize_rows(&mut self, n: usize);
    /// Apply `new[k] = old[perm[k]]` to every column.
    fn permute_rows(&mut self, perm: &[u32]);
    /// Memory held per particle row, for the run report.
    fn bytes_per_row(&self) -> usize;
}

/// Gather `col` through `perm` (`new[k] = old[perm[k]]`), in parallel.
pub fn permute_column<T: Copy + Send + Sync>(col: &mut Vec<T>, perm: &[u32]) {
    use rayon::prelude::*;
    let old = &*col;
    let permuted: Vec<T> = perm.par_iter().map(|&k| old[k as usize]).collect();
    *col = permuted;
}

/// One sphere to append to [`Particles`].
#[derive(Debug, Clone, Copy)]
pub struct NewParticle {
    pub id: u32,
    pub material: u16,
    pub radius: f64,
    /// Solid density, kg/m^3 (gives the mass).
    pub density: f64,
    pub position: [f64; 3],
    pub velocity: [f64; 3],
    pub angular_velocity: [f64; 3],
}

/// The spheres, as structure-of-arrays columns in the current (cell-sorted) order.
/// `id` is the stable particle id used in output.
#[derive(Resource, Debug, Clone, Default)]
pub struct Particles {
    pub id: Vec<u32>,
    pub material: Vec<u16>,
    pub radius: Vec<f64>,
    pub inv_mass: Vec<f64>,
    pub position: Columns,
    pub velocity: Columns,
    pub angular_velocity: Columns,
    /// Contact force of the current step (body forces are added by the integrator).
    pub force: Columns,
}

impl Particles {
    pub fn len(&self) -> usize {
        self.id.len()
    }
    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }
    /// Append one particle.
    pub fn push(&mut self, p: NewParticle) {
        let mass = p.density * 4.0 / 3.0 * std::f64::consts::PI * p.radius.powi(3);
        self.id.push(p.id);
        self.material.push(p.material);
        self.radius.push(p.radius);
        self.inv_mass.push(1.0 / mass);
        for d in 0..3 {
            self.position[d].push(p.position[d]);
            self.velocity[d].push(p.velocity[d]);
            self.angular_velocity[d].push(p.angular_velocity[d]);
            self.force[d].push(0.0);
        }
    }
    pub fn mass(&self, i: usize) -> f64 {
        1.0 / self.inv_mass[i]
    }
}

impl PerParticle for Particles {
    fn resize_rows(&mut self, n: usize) {
        assert_eq!(n, self.len(), "Particles defines the row count");
    }
    fn permute_rows(&mut self, perm: &[u32]) {
        permute_column(&mut self.id, perm);
        permute_column(&mut self.material, perm);
        permute_column(&mut self.radius, perm);
        permute_column(&mut self.inv_mass, perm);
        for d in 0..3 {
            permute_column(&mut self.position[d], perm);
            permute_column(&mut self.velocity[d], perm);
            permute_column(&mut self.angular_velocity[d], perm);
            permute_column(&mut self.force[d], perm);
        }
    }
    fn bytes_per_row(&self) -> usize {
        4 + 2 + 8 + 8 + 4 * 24
    }
}
