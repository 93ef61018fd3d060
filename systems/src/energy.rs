//! Energy monitor: the particles' mechanical energy against what they started with and
//! what the inflows brought in ([`EnergyBalance`]). Contacts only dissipate (damping,
//! friction) or store (elastic overlap) energy, and the body acceleration conserves it, so
//! a run whose energy grows is numerically unstable even when no overlap limit is reached:
//! with a time step above the Hertz limit (`allow_unstable_dt`), a sphere dropped at
//! 0.9 m/s rebounds faster than it came. Where the balance holds (no flow, no kinematic
//! particles, no adhesion), a growth beyond the tolerance stops the run, naming the step
//! and the fastest particle.
//!
//! The mechanical energy counted at a check:
//!
//!   E = sum m v^2 / 2 + sum (2/5) m r^2 w^2 / 2 - sum m a_b . x + sum_contacts (2/5) c_n delta^(5/2)
//!
//! with a_b the material's body acceleration (gravity less buoyancy) and the Hertz
//! potential of every overlapping pair and wall contact, c_n = (4/3) E* sqrt(R*) (the
//! integral of F = c_n delta^(3/2); Johnson 1985, Contact Mechanics, eq. 4.22). The
//! tangential springs' and rolling springs' energy is not counted (below a percent of
//! the normal one at the seed's stiffness ratios). A clump body counts as one rigid body,
//! M V^2/2 + L.w/2 - M a_b . X, in place of its member rows (its members' contacts count
//! as any sphere's).
use bevy_ecs::prelude::*;
use grainflow_components::{
    BodyAcceleration, Clumps, EnergyBalance, Materials, Particles, RunHealth, SimClock, VerletList,
    WallList, Walls,
};
use rayon::prelude::*;

use crate::contact::walls::wall_contact;
use crate::CHUNK;

/// Steps between two checks: the passes cost about one contact pass each, so a check
/// every 64 steps costs under 2 % of a step.
pub const ENERGY_CHECK_INTERVAL: u64 = 64;

/// The energies of one check, J.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Energies {
    pub kinetic: f64,
    pub rotational: f64,
    pub potential: f64,
    pub elastic: f64,
    /// The same sums over the particles whose ids are at least the counted bound.
    pub new_particles: f64,
    /// sum m |a_b| r: the energy of lifting every particle by its radius.
    pub lift: f64,
}

/// The energies of `particles` with their pair and wall contacts; the particles with ids
/// `>= counted_ids` also summed apart (kinetic plus potential); clump bodies in place of
/// their members. Per-chunk sums added in chunk order: the same value for any thread
/// count.
#[allow(clippy::too_many_arguments)]
pub fn mechanical_energies(
    particles: &Particles,
    body: &BodyAcceleration,
    materials: &Materials,
    list: &VerletList,
    walls: Option<(&Walls, &WallList)>,
    clumps: Option<&Clumps>,
    counted_ids: u32,
) -> Energies {
    let member = |id: u32| {
        clumps.is_some_and(|c| {
            c.body_of_id
                .get(id as usize)
                .is_some_and(|&b| b != u32::MAX)
        })
    };
    let n = particles.len();
    let [x, y, z] = &particles.position;
    let [vx, vy, vz] = &particles.velocity;
    let [wx, wy, wz] = &particles.angular_velocity;
    let parts: Vec<Energies> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut e = Energies::default();
            for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
                e.elastic += pair_elastic_energy(particles, materials, list, i);
                if let Some((walls, wl)) = walls {
                    e.elastic += wall_elastic_energy(particles, materials, walls, wl, i);
                }
                if member(particles.id[i]) {
                    continue;
                }
                let m = particles.mass(i);
                let r = particles.radius[i];
                let a = body.per_material[particles.material[i] as usize];
                let kinetic = 0.5 * m * (vx[i] * vx[i] + vy[i] * vy[i] + vz[i] * vz[i]);
                let rotational = 0.2 * m * r * r * (wx[i] * wx[i] + wy[i] * wy[i] + wz[i] * wz[i]);
                let potential = -m * (a[0] * x[i] + a[1] * y[i] + a[2] * z[i]);
                e.kinetic += kinetic;
                e.rotational += rotational;
                e.potential += potential;
                e.lift += m * r * (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
                if particles.id[i] >= counted_ids {
                    e.new_particles += kinetic + rotational + potential;
                }
            }
            e
        })
        .collect();
    let bodies = clumps.map_or(Energies::default(), |c| body_energies(c, body, counted_ids));
    parts
        .iter()
        .chain([&bodies])
        .fold(Energies::default(), |s, e| Energies {
            kinetic: s.kinetic + e.kinetic,
            rotational: s.rotational + e.rotational,
            potential: s.potential + e.potential,
            elastic: s.elastic + e.elastic,
            new_particles: s.new_particles + e.new_particles,
            lift: s.lift + e.lift,
        })
}

/// The energies of the clump bodies (in body order), as [`mechanical_energies`] counts
/// them.
fn body_energies(clumps: &Clumps, body: &BodyAcceleration, counted_ids: u32) -> Energies {
    let mut e = Energies::default();
    for b in 0..clumps.len() {
        let ty = &clumps.types[clumps.kind[b] as usize];
        let a = glam::DVec3::from_array(body.per_material[ty.material as usize]);
        let [kinetic, rotational, potential] = body_energy(clumps, body, b);
        let reach = ty.bounding_radius();
        e.kinetic += kinetic;
        e.rotational += rotational;
        e.potential += potential;
        e.lift += ty.mass * reach * a.length();
        if clumps.first_member[b] >= counted_ids {
            e.new_particles += kinetic + rotational + potential;
        }
    }
    e
}

/// [kinetic, rotational, potential] energy of clump body `b`: M V^2/2, L.w/2 (w = R I^-1
/// R^T L, so L.w/2 = w.I w/2) and -M a_b . X with a_b its material's body acceleration.
pub fn body_energy(clumps: &Clumps, body: &BodyAcceleration, b: usize) -> [f64; 3] {
    let ty = &clumps.types[clumps.kind[b] as usize];
    let a = glam::DVec3::from_array(body.per_material[ty.material as usize]);
    [
        0.5 * ty.mass * clumps.velocity[b].length_squared(),
        0.5 * clumps.angular_momentum[b].dot(clumps.angular_velocity(b)),
        -ty.mass * a.dot(clumps.position[b]),
    ]
}

/// Hertz potential (2/5) c_n delta^(5/2) of a contact with overlap `delta`, elastic
/// factor (4/3) E* `hertz_factor` and effective radius `r_eff`.
#[inline]
pub fn hertz_elastic_energy(hertz_factor: f64, r_eff: f64, delta: f64) -> f64 {
    0.4 * hertz_factor * r_eff.sqrt() * delta * delta * delta.sqrt()
}

/// The Hertz potential of row `i`'s overlapping partners in the Verlet list (each pair
/// once, with its lower row).
fn pair_elastic_energy(p: &Particles, materials: &Materials, list: &VerletList, i: usize) -> f64 {
    let Some(range) = list.start.get(i..i + 2) else {
        return 0.0;
    };
    let xi = [p.position[0][i], p.position[1][i], p.position[2][i]];
    let ri = p.radius[i];
    list.neighbours[range[0] as usize..range[1] as usize]
        .iter()
        .map(|&j| {
            let j = j as usize;
            let rj = p.radius[j];
            let d2: f64 = (0..3).map(|d| (p.position[d][j] - xi[d]).powi(2)).sum();
            let delta = ri + rj - d2.sqrt();
            if delta <= 0.0 {
                return 0.0;
            }
            let params = materials.pair(p.material[i], p.material[j]);
            hertz_elastic_energy(params.hertz_factor, ri * rj / (ri + rj), delta)
        })
        .sum()
}

/// The Hertz potential of row `i`'s wall contacts (effective radius the sphere's, as the
/// contact kernels take it).
fn wall_elastic_energy(
    p: &Particles,
    materials: &Materials,
    walls: &Walls,
    wl: &WallList,
    i: usize,
) -> f64 {
    let Some(range) = wl.start.get(i..i + 2) else {
        return 0.0;
    };
    let xi = [p.position[0][i], p.position[1][i], p.position[2][i]];
    let ri = p.radius[i];
    wl.walls[range[0] as usize..range[1] as usize]
        .iter()
        .map(|&w| {
            let wall = &walls.list[w as usize];
            match wall_contact(&wall.shape, xi, ri) {
                Some((dist, _)) if wall.active => {
                    let params = materials.pair(wall.material, p.material[i]);
                    hertz_elastic_energy(params.hertz_factor, ri, ri - dist)
                }
                _ => 0.0,
            }
        })
        .sum()
}

/// The energy check (Monitor set, start-up and every [`ENERGY_CHECK_INTERVAL`] steps):
/// the balance in [`EnergyBalance`], and the failure of an enforced balance whose energy
/// grew by more than its tolerance. The state checked is the corrector's (with velocity
/// Verlet predicting ahead, the next step's predicted positions): a shift of order
/// v dt in the potential energy, far below the tolerance.
#[allow(clippy::too_many_arguments)]
pub fn energy_monitor(
    particles: Res<Particles>,
    body: Res<BodyAcceleration>,
    materials: Res<Materials>,
    list: Res<VerletList>,
    walls: Option<Res<Walls>>,
    wall_list: Option<Res<WallList>>,
    clock: Res<SimClock>,
    clumps: Option<Res<Clumps>>,
    mut balance: ResMut<EnergyBalance>,
    mut health: ResMut<RunHealth>,
) {
    let first = balance.checks == 0;
    if !first && !clock.step.is_multiple_of(ENERGY_CHECK_INTERVAL) {
        return;
    }
    let _span = tracing::info_span!("energy_monitor").entered();
    let walls = walls.as_deref().zip(wall_list.as_deref());
    let e = mechanical_energies(
        &particles,
        &body,
        &materials,
        &list,
        walls,
        clumps.as_deref(),
        balance.counted_ids,
    );
    let top_id = particles.id.iter().max().map_or(0, |&id| id + 1);
    if first {
        balance.initial = e.kinetic + e.rotational + e.potential + e.elastic;
    } else {
        balance.inserted += e.new_particles;
    }
    balance.counted_ids = balance.counted_ids.max(top_id);
    balance.checks += 1;
    balance.checked_step = clock.step;
    balance.kinetic = e.kinetic;
    balance.rotational = e.rotational;
    balance.potential = e.potential;
    balance.elastic = e.elastic;
    balance.scale = balance
        .scale
        .max(e.kinetic + e.rotational)
        .max(e.lift)
        .max(e.elastic);
    let growth = if balance.scale > 0.0 {
        (balance.total() - balance.supplied()) / balance.scale
    } else {
        0.0
    };
    if growth > balance.largest_growth || balance.checks == 1 {
        balance.largest_growth = growth;
        balance.largest_growth_step = clock.step;
    }
    if balance.enforced && growth > balance.tolerance && health.failure.is_none() {
        let (id, speed) = fastest_particle(&particles);
        health.failure = Some(format!(
            "unstable at step {} (t = {:.6e} s): the particles' energy grew from {:.4e} J to {:.4e} J, \
             {:.1} % of its scale {:.4e} J (limit {:.0} %, simulation.energy_growth_limit); \
             fastest particle {id} at {speed:.3e} m/s; the time step is too large for the contact stiffness",
            clock.step,
            clock.time,
            balance.supplied(),
            balance.total(),
            100.0 * growth,
            balance.scale,
            100.0 * balance.tolerance
        ));
    }
}

/// Stable id and speed of the fastest particle (the first of equals in row order).
fn fastest_particle(p: &Particles) -> (u32, f64) {
    let [vx, vy, vz] = &p.velocity;
    let (id, v2) = (0..p.len())
        .map(|i| (p.id[i], vx[i] * vx[i] + vy[i] * vy[i] + vz[i] * vz[i]))
        .fold((0, 0.0), |best, c| if c.1 > best.1 { c } else { best });
    (id, v2.sqrt())
}
