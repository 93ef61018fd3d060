use bevy_ecs::prelude::Resource;

/// Simulated time and step counter; `dt` is the DEM time step.
#[derive(Resource, Debug, Clone, Copy)]
pub struct SimClock {
    pub step: u64,
    pub time: f64,
    pub dt: f64,
}

impl SimClock {
    pub fn new(dt: f64) -> Self {
        Self {
            step: 0,
            time: 0.0,
            dt,
        }
    }
}
