use bevy_ecs::prelude::Resource;

/// Region in which inflowing particles are placed.
#[derive(Debug, Clone)]
pub enum InflowRegion {
    /// Axis-aligned box.
    Box { min: [f64; 3], max: [f64; 3] },
    /// Cylinder with axis along z.
    CylinderZ {
        center: [f64; 2],
        radius: f64,
        z_min: f64,
        z_max: f64,
    },
}

/// Continuous particle inflow: `rate` particles per second of simulated time, inserted in
/// batches every `interval` seconds into free places of `region`, radii drawn from the
/// table `radii` with probabilities `fractions` (number fractions).
#[derive(Debug, Clone)]
pub struct Inflow {
    pub material: u16,
    /// A clump type (index into `Clumps::types`) instead of spheres: every site gets a
    /// randomly oriented clump; `radii` then holds the clump's bounding radius.
    pub clump: Option<u16>,
    pub rate: f64,
    pub start: f64,
    pub stop: f64,
    pub total: u64,
    pub interval: f64,
    pub region: InflowRegion,
    pub radii: Vec<f64>,
    pub fractions: Vec<f64>,
    pub velocity: [f64; 3],
    pub velocity_jitter: f64,
    /// Particles inserted so far, the time of the next batch, and the placement RNG state.
    pub inserted: u64,
    pub next_time: f64,
    pub rng_state: u64,
}

/// All inflows of the scene, in scene order.
#[derive(Resource, Debug, Clone, Default)]
pub struct Inflows {
    pub list: Vec<Inflow>,
    /// Next stable particle id to hand out.
    pub next_id: u32,
}
