//! Continuous particle inflow: batches of particles placed on free sites of a jittered
//! lattice inside the inflow region, at the scene's rate.
use bevy_ecs::prelude::*;
use grainflow_components::{
    BodyState, Clumps, Inflow, InflowRegion, Inflows, Materials, NewParticle, Particles,
    VerletList, Walls,
};

use crate::contact::walls::{wall_contains, wall_distance};

pub fn has_inflow(w: &World) -> bool {
    w.get_resource::<Inflows>()
        .is_some_and(|f| !f.list.is_empty())
}

/// SplitMix64 (Steele, Lea & Flood 2014): a small deterministic generator for placement.
pub fn next_u64(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Uniform in [0, 1).
pub fn next_f64(state: &mut u64) -> f64 {
    (next_u64(state) >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Insert the particles owed by each inflow at this time.
pub fn inflow_insertion(
    clock: Res<grainflow_components::SimClock>,
    mut inflows: ResMut<Inflows>,
    mut particles: ResMut<Particles>,
    materials: Res<Materials>,
    mut list: ResMut<VerletList>,
    walls: Option<Res<Walls>>,
    mut clumps: Option<ResMut<Clumps>>,
) {
    let t = clock.time;
    let Inflows {
        list: flows,
        next_id,
    } = &mut *inflows;
    for flow in flows.iter_mut() {
        if t < flow.next_time || t < flow.start || t > flow.stop || flow.inserted >= flow.total {
            continue;
        }
        let _span = tracing::info_span!("inflow_insertion").entered();
        flow.next_time = t + flow.interval;
        let target =
            ((flow.rate * (t - flow.start + flow.interval)).round() as u64).min(flow.total);
        let want = target.saturating_sub(flow.inserted) as usize;
        if want == 0 {
            continue;
        }
        let sites = free_sites(flow, &particles, walls.as_deref());
        let density = materials.list[flow.material as usize].density;
        let before = flow.inserted;
        for site in sites.into_iter().take(want) {
            let radius = draw_radius(flow);
            let j = flow.velocity_jitter;
            let mut vel = flow.velocity;
            for v in vel.iter_mut() {
                *v += j * (2.0 * next_f64(&mut flow.rng_state) - 1.0);
            }
            if let (Some(kind), Some(clumps)) = (flow.clump, clumps.as_deref_mut()) {
                // A clump of the type, randomly oriented, its centre on the site.
                let q = crate::integrate::rigid_body::random_rotation(&mut flow.rng_state);
                let state = BodyState {
                    position: glam::DVec3::from_array(site),
                    velocity: glam::DVec3::from_array(vel),
                    orientation: glam::DQuat::IDENTITY,
                    angular_velocity: glam::DVec3::ZERO,
                };
                crate::integrate::rigid_body::insert_clump(
                    clumps,
                    &mut particles,
                    kind,
                    q,
                    state,
                    next_id,
                );
                flow.inserted += 1;
                continue;
            }
            particles.push(NewParticle {
                id: *next_id,
                material: flow.material,
                radius,
                density,
                position: site,
                velocity: vel,
                angular_velocity: [0.0; 3],
            });
            *next_id += 1;
            flow.inserted += 1;
        }
        // New particles are in no list yet.
        list.stale |= flow.inserted > before;
    }
}

fn draw_radius(flow: &mut Inflow) -> f64 {
    let u = next_f64(&mut flow.rng_state);
    let mut acc = 0.0;
    for (r, f) in flow.radii.iter().zip(&flow.fractions) {
        acc += f;
        if u < acc {
            return *r;
        }
    }
    *flow.radii.last().expect("inflow has radii")
}

/// Sites of a lattice with spacing 2.1 r_max in the region, jittered by +-0.04 r_max,
/// that no present particle overlaps and that keep clear of the walls, in random order. Sites are 2.02 r_max apart at
/// least, so particles placed on them never overlap each other.
fn free_sites(flow: &mut Inflow, particles: &Particles, walls: Option<&Walls>) -> Vec<[f64; 3]> {
    let r_max = flow.radii.iter().copied().fold(0.0, f64::max);
    let a = 2.1 * r_max;
    let (lo, hi) = match flow.region {
        InflowRegion::Box { min, max } => (min, max),
        InflowRegion::CylinderZ {
            center,
            radius,
            z_min,
            z_max,
        } => (
            [center[0] - radius, center[1] - radius, z_min],
            [center[0] + radius, center[1] + radius, z_max],
        ),
    };
    let dims = [0, 1, 2].map(|d| (((hi[d] - lo[d]) / a).floor() as usize).max(1));
    let idx = |i: [usize; 3]| i[0] + dims[0] * (i[1] + dims[1] * i[2]);
    let mut blocked = vec![false; dims[0] * dims[1] * dims[2]];
    // Sites covered by present particles (with the largest inflow radius as margin).
    for p in 0..particles.len() {
        let pos = [
            particles.position[0][p],
            particles.position[1][p],
            particles.position[2][p],
        ];
        let reach = particles.radius[p] + r_max + 0.04 * r_max;
        if (0..3).any(|d| pos[d] < lo[d] - reach || pos[d] > lo[d] + dims[d] as f64 * a + reach) {
            continue;
        }
        let range = |d: usize| {
            let s0 = ((pos[d] - reach - lo[d]) / a - 0.5).floor().max(0.0) as usize;
            let s1 =
                (((pos[d] + reach - lo[d]) / a - 0.5).ceil().max(0.0) as usize).min(dims[d] - 1);
            s0..=s1
        };
        for iz in range(2) {
            for iy in range(1) {
                for ix in range(0) {
                    let c = [0, 1, 2].map(|d| lo[d] + ([ix, iy, iz][d] as f64 + 0.5) * a);
                    let d2: f64 = (0..3).map(|d| (c[d] - pos[d]).powi(2)).sum();
                    if d2 < reach * reach {
                        blocked[idx([ix, iy, iz])] = true;
                    }
                }
            }
        }
    }
    let mut sites = Vec::new();
    for iz in 0..dims[2] {
        for iy in 0..dims[1] {
            for ix in 0..dims[0] {
                if blocked[idx([ix, iy, iz])] {
                    continue;
                }
                let c = [0, 1, 2].map(|d| lo[d] + ([ix, iy, iz][d] as f64 + 0.5) * a);
                if let InflowRegion::CylinderZ { center, radius, .. } = flow.region {
                    let (dx, dy) = (c[0] - center[0], c[1] - center[1]);
                    if (dx * dx + dy * dy).sqrt() > radius - r_max {
                        continue;
                    }
                }
                // Inside every active wall, clear of it by the largest radius.
                let clear = walls.is_none_or(|w| {
                    w.list.iter().filter(|w| w.active).all(|w| {
                        wall_contains(&w.shape, c) != Some(false)
                            && wall_distance(&w.shape, c).0 > 1.05 * r_max
                    })
                });
                if clear {
                    sites.push(c);
                }
            }
        }
    }
    // Fisher-Yates shuffle, then jitter.
    for k in (1..sites.len()).rev() {
        let m = (next_u64(&mut flow.rng_state) % (k as u64 + 1)) as usize;
        sites.swap(k, m);
    }
    for s in sites.iter_mut() {
        for c in s.iter_mut() {
            *c += 0.04 * r_max * (2.0 * next_f64(&mut flow.rng_state) - 1.0);
        }
    }
    sites
}
