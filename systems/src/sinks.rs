//! Particle sinks: planes through which particles leave the scene (an outlet's catch
//! plane, a suction pipe's upper part). Every [`SINK_CHECK_INTERVAL`] steps the particles
//! past a sink are found, counted per sink (number and mass, with the time) and handed to
//! the neighbour list, which drops their rows at its rebuild in the same step; every
//! other per-particle block follows through the published row map, and the contact and
//! wall histories, carried by particle id, lose the pairs of the removed particles. Ids
//! of the others stay as they are; ids are never reused.
//!
//! A clump leaves as a whole body when its centre of mass passes a sink: all its member
//! rows in the same check (a member past the sink with the centre not yet is kept); the
//! sink counts the body once with the body's mass, and the bodies are compacted
//! ([`Clumps::remove_bodies`]) before the neighbour list drops the rows.
//!
//! The energy balance counts what leaves: the kinetic, rotational and potential energy of
//! every removed particle that the energy monitor has counted in (`EnergyBalance::removed`),
//! so that the growth test measures against `initial + inserted - removed`; for a clump the
//! body's energy, M V^2/2 + L.w/2 - M a_b . X, once (as the monitor counts it).
use bevy_ecs::prelude::*;
use grainflow_components::{
    BodyAcceleration, Clumps, EnergyBalance, Particles, SimClock, Sink, SinkEvent, Sinks,
    VerletList,
};
use rayon::prelude::*;

use crate::CHUNK;

/// Steps between two sink checks. A particle past a sink has left the region where it
/// can touch anything the scene keeps, so a late removal changes nothing but the time
/// stamp (at most 64 steps late); the check is a pass over the positions.
pub const SINK_CHECK_INTERVAL: u64 = 64;

pub fn has_sinks(w: &World) -> bool {
    w.get_resource::<Sinks>()
        .is_some_and(|s| !s.list.is_empty())
}

/// What one chunk of rows found: the leaving rows (ascending), and per sink the count,
/// the mass and the energy counted in the balance.
#[derive(Default)]
struct Found {
    rows: Vec<u32>,
    count: Vec<u64>,
    mass: Vec<f64>,
    energy: f64,
}

/// Find the particles past a sink (the first sink in scene order that a particle has
/// passed takes it) and queue them for removal; with clumps, the members of the bodies
/// whose centre passed a sink, and the bodies removed. Per-chunk results joined in chunk
/// order, then the bodies in body order: the same for any thread count.
#[allow(clippy::too_many_arguments)]
pub fn sink_removal(
    clock: Res<SimClock>,
    mut sinks: ResMut<Sinks>,
    particles: Res<Particles>,
    mut list: ResMut<VerletList>,
    body: Res<BodyAcceleration>,
    balance: Option<ResMut<EnergyBalance>>,
    mut clumps: Option<ResMut<Clumps>>,
) {
    if !clock.step.is_multiple_of(SINK_CHECK_INTERVAL) {
        return;
    }
    let _span = tracing::info_span!("sink_removal").entered();
    let n = particles.len();
    let m = sinks.list.len();
    let counted_ids = balance.as_ref().map_or(0, |b| b.counted_ids);
    // Members leave with their body, never alone.
    let body_of_id = clumps.as_deref().map(|c| &c.body_of_id[..]);
    let member =
        |id: u32| body_of_id.is_some_and(|b| b.get(id as usize).is_some_and(|&b| b != u32::MAX));
    let [x, y, z] = &particles.position;
    let [vx, vy, vz] = &particles.velocity;
    let [wx, wy, wz] = &particles.angular_velocity;
    let list_of_sinks = &sinks.list;
    let parts: Vec<Found> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut found = Found {
                count: vec![0; m],
                mass: vec![0.0; m],
                ..Found::default()
            };
            for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
                let at = [x[i], y[i], z[i]];
                let Some(s) = list_of_sinks.iter().position(|s| s.passed(at)) else {
                    continue;
                };
                if member(particles.id[i]) {
                    continue;
                }
                let mass = particles.mass(i);
                found.rows.push(i as u32);
                found.count[s] += 1;
                found.mass[s] += mass;
                if particles.id[i] < counted_ids {
                    let r = particles.radius[i];
                    let a = body.per_material[particles.material[i] as usize];
                    found.energy += 0.5 * mass * (vx[i] * vx[i] + vy[i] * vy[i] + vz[i] * vz[i])
                        + 0.2 * mass * r * r * (wx[i] * wx[i] + wy[i] * wy[i] + wz[i] * wz[i])
                        - mass * (a[0] * at[0] + a[1] * at[1] + a[2] * at[2]);
                }
            }
            found
        })
        .collect();
    let mut energy = 0.0;
    let mut count = vec![0u64; m];
    let mut mass = vec![0.0; m];
    let Sinks {
        leaving, list: all, ..
    } = &mut *sinks;
    leaving.clear();
    for part in parts {
        leaving.extend_from_slice(&part.rows);
        for s in 0..m {
            count[s] += part.count[s];
            mass[s] += part.mass[s];
        }
        energy += part.energy;
    }
    if let Some(clumps) = clumps.as_deref_mut() {
        let mut found = Found {
            rows: std::mem::take(leaving),
            count,
            mass,
            energy,
        };
        bodies_past_sinks(clumps, &particles, &body, counted_ids, all, &mut found);
        (*leaving, count, mass, energy) = (found.rows, found.count, found.mass, found.energy);
    }
    if leaving.is_empty() {
        return;
    }
    for s in 0..m {
        if count[s] > 0 {
            sinks.removed[s] += count[s];
            sinks.removed_mass[s] += mass[s];
            sinks.events.push(SinkEvent {
                time: clock.time,
                sink: s as u32,
                count: count[s],
                mass: mass[s],
            });
        }
    }
    if let Some(mut balance) = balance {
        balance.removed += energy;
    }
    list.stale = true;
}

/// The clump bodies whose centre passed a sink (the first in scene order), in body order:
/// their member rows added to `found.rows` (kept ascending), each body counted once with
/// its mass and, if the energy monitor counted it in (its first member id below
/// `counted_ids`), its energy; then the bodies removed from `clumps`.
fn bodies_past_sinks(
    clumps: &mut Clumps,
    particles: &Particles,
    body: &BodyAcceleration,
    counted_ids: u32,
    sinks: &[Sink],
    found: &mut Found,
) {
    // Rows of bodies inserted since the last re-sort.
    crate::integrate::rigid_body::follow_rows(clumps, particles, None);
    let mut gone = Vec::new();
    let rows_before = found.rows.len();
    for b in 0..clumps.len() {
        let Some(s) = sinks
            .iter()
            .position(|s| s.passed(clumps.position[b].to_array()))
        else {
            continue;
        };
        gone.push(b as u32);
        let range = clumps.member_start[b] as usize..clumps.member_start[b + 1] as usize;
        found.rows.extend_from_slice(&clumps.member_row[range]);
        found.count[s] += 1;
        found.mass[s] += clumps.types[clumps.kind[b] as usize].mass;
        if clumps.first_member[b] < counted_ids {
            found.energy += crate::energy::body_energy(clumps, body, b)
                .iter()
                .sum::<f64>();
        }
    }
    if found.rows.len() > rows_before {
        found.rows.sort_unstable();
    }
    clumps.remove_bodies(&gone);
}
