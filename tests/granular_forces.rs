//! The contact system with history (`grainflow_systems::contact::with_history::granular_contact`)
//! against a brute-force sum over all pairs of the same models, evaluated one contact at
//! a time: Hertz normal force with constant damping (seed slide "Models for DEM"),
//! Coulomb friction with a tangential spring (seed slide "Tangential contact with static
//! / dynamic friction"; Cundall & Strack 1979) and rolling resistance (seed slide
//! "Rolling resistance"; Ai, Chen, Rotter & Ooi 2011, model type C).
//!
//! The models themselves are checked against physics elsewhere (tests/friction.rs,
//! tests/rolling.rs, tests/chung_ooi.rs); this test checks what the kernel adds around
//! them: the pairs in lanes of four, the per-work-item records of the scatter plan
//! (`ScatterPlan`, several work items here), the sums of every particle's records, and
//! the torque arms of both particles of a pair. A dense polydisperse cluster with random
//! overlaps, velocities and spins, so that some contacts stick and some slide, starts
//! from zero history; every particle's force and torque must match the brute-force sum
//! within 1e-12 of the largest (round-off of sums of a few terms in another order).
mod common;

use bevy_ecs::system::RunSystemOnce;
use common::*;
use grainflow_components::{ContactHistory, Particles, Rotation};
use grainflow_systems::contact::laws::friction::coulomb_tangential_force;
use grainflow_systems::contact::laws::hertz::{hertz_normal_force, ConstantDamping};
use grainflow_systems::contact::laws::rolling::{rolling_resistance_force, rolling_velocity};
use grainflow_systems::contact::with_history::granular_contact;
use grainflow_systems::real::V3;

const E: f64 = 1e7;
const NU: f64 = 0.3;
const DAMPING: f64 = 2e-3;
const MU_S: f64 = 0.5;
const MU_D: f64 = 0.4;
const TANGENTIAL_STIFFNESS: f64 = 2e4;
const TANGENTIAL_DAMPING: f64 = 1e-3;
const MU_R: f64 = 0.1;
const ROLLING_STIFFNESS: f64 = 5e3;
const ROLLING_DAMPING: f64 = 2e-4;
const DT: f64 = 1e-6;

/// `n` spheres with radii uniform in [0.8, 1.2] mm, centres uniform in a cube of edge
/// `edge` (overlaps allowed), velocity components uniform in +-0.1 m/s, angular velocity
/// components uniform in +-100 rad/s.
fn cluster(seed: u64, n: usize, edge: f64) -> String {
    let mut rng = Rng(seed);
    let mut s = format!(
        "[simulation]\ndt = {DT:e}\nend_time = 1.0\ngravity = [0.0, 0.0, 0.0]\n\n\
         [[materials]]\nname = \"m\"\ndensity = 2500.0\nyoungs_modulus = {E:e}\n\
         poisson_ratio = {NU}\nnormal_damping = {DAMPING:e}\nfriction = {MU_S}\n\
         dynamic_friction = {MU_D}\ntangential_stiffness = {TANGENTIAL_STIFFNESS:e}\n\
         tangential_damping = {TANGENTIAL_DAMPING:e}\nrolling_friction = {MU_R}\n\
         rolling_stiffness = {ROLLING_STIFFNESS:e}\nrolling_damping = {ROLLING_DAMPING:e}\n"
    );
    for _ in 0..n {
        let r = rng.uniform(0.8e-3, 1.2e-3);
        let p = [0; 3].map(|_| rng.uniform(0.0, edge));
        let v = [0; 3].map(|_| rng.uniform(-0.1, 0.1));
        let w = [0; 3].map(|_| rng.uniform(-100.0, 100.0));
        s += &format!(
            "\n[[spheres]]\nmaterial = \"m\"\nradius = {r:e}\nposition = {}\n\
             velocity = {}\nangular_velocity = {}\n",
            toml_v(p),
            toml_v(v),
            toml_v(w)
        );
    }
    s
}

fn v3(c: &[Vec<f64>; 3], i: usize) -> V3<f64> {
    V3::new(c[0][i], c[1][i], c[2][i])
}

#[test]
fn dense_cluster_with_friction_and_rolling() {
    let mut sim = simulation(&cluster(5, 3000, 0.029), "granular cluster");
    sim.step();
    let (items, store_pairs) = {
        let mut history = sim.world.resource_mut::<ContactHistory>();
        history.values.fill(0.0);
        let plan = &history.pairs.scatter;
        (plan.item_start.len() - 1, history.pairs.pairs())
    };
    sim.world
        .run_system_once(granular_contact)
        .expect("the contact system runs");
    let p = sim.world.resource::<Particles>();
    let torque = &sim.world.resource::<Rotation>().torque;
    let n = p.len();
    let hertz_factor = 4.0 / 3.0 * e_star(E, NU, E, NU);
    let mut want = vec![[0.0f64; 6]; n];
    let (mut contacts, mut sliding) = (0, 0);
    for i in 0..n {
        for j in i + 1..n {
            let gap = v3(&p.position, i) - v3(&p.position, j);
            let dist = gap.length();
            let (ri, rj) = (p.radius[i], p.radius[j]);
            let delta = ri + rj - dist;
            if delta <= 0.0 {
                continue;
            }
            contacts += 1;
            let nrm = gap.scale(1.0 / dist);
            let (wi, wj) = (v3(&p.angular_velocity, i), v3(&p.angular_velocity, j));
            let velocity = v3(&p.velocity, i) - v3(&p.velocity, j);
            let r_eff = ri * rj / (ri + rj);
            let a = (r_eff * delta).sqrt();
            let inv_mass_sum = p.inv_mass[i] + p.inv_mass[j];
            let f_n = hertz_normal_force::<f64, ConstantDamping>(
                hertz_factor,
                DAMPING,
                a,
                inv_mass_sum,
                delta,
                -velocity.dot(nrm),
            );
            let relative = velocity + nrm.cross(wi).scale(ri) + nrm.cross(wj).scale(rj);
            let u_t = relative - nrm.scale(relative.dot(nrm));
            let load = f_n.max(0.0);
            let (mut spring, mut slides) = (V3::zero(), 0.0);
            let f_t = coulomb_tangential_force(
                &mut spring,
                &mut slides,
                nrm,
                u_t,
                load,
                [MU_S, MU_D],
                TANGENTIAL_STIFFNESS,
                TANGENTIAL_DAMPING,
                DT,
            );
            sliding += (slides > 0.0) as usize;
            let u_r = rolling_velocity(r_eff, wi - wj, nrm, (rj - ri) / (ri + rj), u_t);
            let f_r = rolling_resistance_force(
                &mut V3::zero(),
                nrm,
                u_r,
                load,
                MU_R,
                ROLLING_STIFFNESS,
                ROLLING_DAMPING,
                DT,
            );
            let force = nrm.scale(f_n) + f_t;
            let arm = nrm.cross(f_t);
            let roll = f_r.cross(nrm).scale(r_eff);
            let (ti, tj) = (roll - arm.scale(ri), -(arm.scale(rj) + roll));
            for (k, (f, (a, b))) in [
                (force.x, (ti.x, tj.x)),
                (force.y, (ti.y, tj.y)),
                (force.z, (ti.z, tj.z)),
            ]
            .into_iter()
            .enumerate()
            {
                want[i][k] += f;
                want[j][k] -= f;
                want[i][3 + k] += a;
                want[j][3 + k] += b;
            }
        }
    }
    eprintln!(
        "{contacts} contacts ({sliding} sliding), {store_pairs} store pairs in {items} work items"
    );
    assert!(
        items >= 3,
        "the cluster's {store_pairs} store pairs must fill several work items ({items})"
    );
    assert!(
        contacts > 3000 && sliding > 100 && contacts - sliding > 100,
        "the cluster must have many contacts ({contacts}), sticking and sliding \
         ({sliding} slide)"
    );
    for (what, range) in [("force", 0..3), ("torque", 3..6)] {
        let scale = want
            .iter()
            .flat_map(|w| &w[range.clone()])
            .fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(scale > 0.0, "no {what} at all");
        for (i, w) in want.iter().enumerate() {
            for k in 0..3 {
                let got = if what == "force" {
                    p.force[k][i]
                } else {
                    torque[k][i]
                };
                let expected = w[range.start + k];
                assert!(
                    (got - expected).abs() <= 1e-12 * scale,
                    "particle {i} {what}[{k}] = {got:e}, brute force {expected:e} \
                     (scale {scale:e})"
                );
            }
        }
    }
}
