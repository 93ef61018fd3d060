//! The Hertz contact system (`grainflow_systems::contact::frictionless::hertz_contact`) against a
//! brute-force sum over all pairs of the seed's normal law (slide "Models for DEM";
//! Hertz 1896): F_ij = (4/3) E* sqrt(R*) delta^(3/2) + d_n delta_dot along the centre
//! line, E* = 1/((1-nu_i^2)/E_i + (1-nu_j^2)/E_j), R* = r_i r_j/(r_i + r_j).
//!
//! The system sums a chunk's pairs particle by particle when its rows hold two or more
//! listed pairs per particle, and in pair order when they hold fewer (a loose cloud). Both
//! orders are checked: a dense random cluster (more than two listed pairs per particle)
//! and a sparse random cloud (fewer), both polydisperse, overlapping at random and moving
//! at random velocities. Every particle's force must match the brute-force sum within
//! 1e-12 of the largest force (round-off of sums of a few terms in another order), and
//! the reported deepest overlap ratio delta/min(r_i, r_j) must match the brute-force
//! maximum within 1e-14 relative.
mod common;

use bevy_ecs::system::RunSystemOnce;
use common::*;
use grainflow_components::{Particles, RunHealth, VerletList};
use grainflow_systems::contact::frictionless::hertz_contact;

const E: f64 = 1e7;
const NU: f64 = 0.3;
const DAMPING: f64 = 2e-3;

/// `n` spheres with radii uniform in [0.8, 1.2] mm, centres uniform in a cube of edge
/// `edge` (overlaps allowed), velocity components uniform in +-0.1 m/s.
fn cloud(seed: u64, n: usize, edge: f64) -> String {
    let mut rng = Rng(seed);
    let mut s = format!(
        "[simulation]\ndt = 1e-12\nend_time = 1.0\ngravity = [0.0, 0.0, 0.0]\n\n\
         [[materials]]\nname = \"m\"\ndensity = 2500.0\nyoungs_modulus = {E:e}\n\
         poisson_ratio = {NU}\nnormal_damping = {DAMPING:e}\n"
    );
    for _ in 0..n {
        let r = rng.uniform(0.8e-3, 1.2e-3);
        let p = [0; 3].map(|_| rng.uniform(0.0, edge));
        let v = [0; 3].map(|_| rng.uniform(-0.1, 0.1));
        s += &format!(
            "\n[[spheres]]\nmaterial = \"m\"\nradius = {r:e}\nposition = [{:e}, {:e}, {:e}]\n\
             velocity = [{:e}, {:e}, {:e}]\n",
            p[0], p[1], p[2], v[0], v[1], v[2]
        );
    }
    s
}

/// Runs one step (to build the list), then the contact system on the current state, and
/// compares with the brute-force sum. Returns the listed pairs per particle and the number
/// of contacts.
fn check(text: &str, name: &str) -> (f64, usize) {
    let mut sim = simulation(text, name);
    sim.step();
    sim.world
        .run_system_once(hertz_contact)
        .expect("the contact system runs");
    let p = sim.world.resource::<Particles>();
    let n = p.len();
    let listed = sim.world.resource::<VerletList>().pairs() as f64 / n as f64;
    let e_star = e_star(E, NU, E, NU);
    let mut f = vec![[0.0f64; 3]; n];
    let (mut deepest, mut contacts) = (0.0f64, 0);
    for i in 0..n {
        for j in i + 1..n {
            let d = [0, 1, 2].map(|k| p.position[k][i] - p.position[k][j]);
            let dist = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let (ri, rj) = (p.radius[i], p.radius[j]);
            let delta = ri + rj - dist;
            if delta <= 0.0 {
                continue;
            }
            contacts += 1;
            let nrm = d.map(|c| c / dist);
            let delta_dot = -(0..3)
                .map(|k| (p.velocity[k][i] - p.velocity[k][j]) * nrm[k])
                .sum::<f64>();
            let r_star = ri * rj / (ri + rj);
            let force = 4.0 / 3.0 * e_star * r_star.sqrt() * delta.powf(1.5) + DAMPING * delta_dot;
            for k in 0..3 {
                f[i][k] += force * nrm[k];
                f[j][k] -= force * nrm[k];
            }
            deepest = deepest.max(delta / ri.min(rj));
        }
    }
    let scale = f.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(scale > 0.0, "{name}: no contact force at all");
    for (i, fi) in f.iter().enumerate() {
        for (k, want) in fi.iter().enumerate() {
            let got = p.force[k][i];
            assert!(
                (got - want).abs() <= 1e-12 * scale,
                "{name}: particle {i} force[{k}] = {got:e}, brute force {want:e} (scale {scale:e})"
            );
        }
    }
    let reported = sim.world.resource::<RunHealth>().max_overlap_ratio;
    assert!(
        (reported - deepest).abs() <= 1e-14 * deepest,
        "{name}: deepest overlap ratio {reported:e}, brute force {deepest:e}"
    );
    (listed, contacts)
}

#[test]
fn dense_cluster_summed_per_particle() {
    let (listed, contacts) = check(&cloud(7, 1500, 0.022), "dense cluster");
    assert!(
        listed > 2.5,
        "the dense cluster lists {listed} pairs per particle"
    );
    assert!(contacts > 1500, "the dense cluster has {contacts} contacts");
}

#[test]
fn sparse_cloud_summed_in_pair_order() {
    let (listed, contacts) = check(&cloud(11, 1500, 0.045), "sparse cloud");
    assert!(
        listed < 1.5,
        "the sparse cloud lists {listed} pairs per particle"
    );
    assert!(contacts > 50, "the sparse cloud has {contacts} contacts");
}
