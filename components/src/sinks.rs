use bevy_ecs::prelude::Resource;

/// A plane through which particles leave the scene (a deletion boundary, as MercuryDPM's
/// `DeletionBoundary` or LIGGGHTS' `delete_atoms region`): a particle whose centre lies on
/// the far side of the plane from its `normal` is removed; with a finite `radius`, only
/// within that distance of the line through `point` along `normal` (the half-infinite
/// cylinder of a suction pipe's upper part).
#[derive(Debug, Clone, PartialEq)]
pub struct Sink {
    pub name: String,
    pub point: [f64; 3],
    /// Unit normal, pointing into the part of space where particles stay.
    pub normal: [f64; 3],
    /// Radius of the removing region about the normal line (infinite: the half space).
    pub radius: f64,
}

impl Sink {
    /// Whether a particle centred at `x` has left through this sink.
    #[inline]
    pub fn passed(&self, x: [f64; 3]) -> bool {
        let q = [0, 1, 2].map(|d| x[d] - self.point[d]);
        let s = (0..3).map(|d| q[d] * self.normal[d]).sum::<f64>();
        s < 0.0
            && (self.radius == f64::INFINITY
                || q.iter().map(|c| c * c).sum::<f64>() - s * s < self.radius * self.radius)
    }
}

/// The scene's sinks and what has left through them.
#[derive(Resource, Debug, Clone, Default)]
pub struct Sinks {
    pub list: Vec<Sink>,
    /// Rows found past a sink at this step's check, ascending: the neighbour list drops
    /// them at its rebuild in the same step.
    pub leaving: Vec<u32>,
    /// Particles and their mass (kg) removed so far, per sink.
    pub removed: Vec<u64>,
    pub removed_mass: Vec<f64>,
    /// One record per check that removed particles, per sink, in time order.
    pub events: Vec<SinkEvent>,
}

/// Particles removed by one sink at one check.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SinkEvent {
    /// Simulated time of the check, s.
    pub time: f64,
    pub sink: u32,
    pub count: u64,
    /// kg
    pub mass: f64,
}

impl Sinks {
    pub fn new(list: Vec<Sink>) -> Self {
        let n = list.len();
        Self {
            list,
            leaving: Vec::new(),
            removed: vec![0; n],
            removed_mass: vec![0.0; n],
            events: Vec::new(),
        }
    }
}
