//! Keeping per-particle blocks aligned with [`Particles`]: growth after insertion and the
//! cell-order permutation published by the neighbour list.
use bevy_ecs::component::Mutable;
use bevy_ecs::prelude::*;
use grainflow_components::{Particles, PerParticle, Reorder};

/// Grow or shrink block `R` to the current particle count.
pub fn sync_rows<R: Resource<Mutability = Mutable> + PerParticle>(
    particles: Res<Particles>,
    mut block: ResMut<R>,
) {
    let _span = tracing::info_span!("sync_rows").entered();
    block.resize_rows(particles.len());
}

/// Apply this step's particle re-sort to block `R`.
pub fn permute_rows<R: Resource<Mutability = Mutable> + PerParticle>(
    reorder: Res<Reorder>,
    mut block: ResMut<R>,
) {
    if let Some(perm) = &reorder.perm {
        let _span = tracing::info_span!("permute_rows").entered();
        block.permute_rows(perm);
    }
}
