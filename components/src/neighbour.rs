use bevy_ecs::prelude::Resource;

use crate::Columns;

/// Verlet-list settings: the skin added to the contact distance, and the particle
/// re-sorting policy.
#[derive(Resource, Debug, Clone, Copy)]
pub struct NeighbourSettings {
    pub skin: f64,
    /// Re-sort particles in cell order at every `sort_every`-th rebuild (0: never).
    pub sort_every: u32,
}

/// Full Verlet neighbour list in compressed rows: the neighbours of particle `i` are
/// `neighbours[start[i]..start[i+1]]`, in cell order. Every pair appears twice (i in j's
/// row and j in i's), so each particle sums its own forces in a fixed order and no two
/// threads ever write the same particle.
#[derive(Resource, Debug, Clone, Default)]
pub struct VerletList {
    pub start: Vec<u32>,
    pub neighbours: Vec<u32>,
    /// Positions at the last rebuild.
    pub reference: Columns,
    /// Set by systems that change the particle set (insertion) to force a rebuild.
    pub stale: bool,
    pub builds: u64,
    pub sorts: u64,
    /// Largest radius present at the last rebuild.
    pub max_radius: f64,
}

/// A permutation of the particle rows applied this step (`new row k = old row perm[k]`),
/// published by the neighbour-list system for every other per-particle block.
#[derive(Resource, Debug, Clone, Default)]
pub struct Reorder {
    pub perm: Option<Vec<u32>>,
}

/// Candidate wall contacts in compressed rows, rebuilt with the Verlet list: the walls
/// within `r_i + skin` of particle `i` are `walls[start[i]..start[i+1]]` (indices into
/// `Walls::list`). Walls are static, so the Verlet criterion covers them too.
#[derive(Resource, Debug, Clone, Default)]
pub struct WallList {
    pub start: Vec<u32>,
    pub walls: Vec<u16>,
    /// `VerletList::builds` when this list was built.
    pub built_for: u64,
}

/// The contact store: per-pair history (the tangential spring of a friction model, the
/// contact state of an adhesion model) kept beside the Verlet list, `width` values per
/// list entry: entry `k` of the list owns `values[k * width..(k + 1) * width]`. Pairs are
/// keyed by the particles' stable ids, so at every rebuild and re-sort the history of a
/// pair that is still listed moves to its new entry; a pair that left the list loses it.
/// Present only when a model needs it.
#[derive(Resource, Debug, Clone, Default)]
pub struct ContactHistory {
    pub width: usize,
    pub values: Vec<f64>,
}
