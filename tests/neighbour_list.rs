//! The Verlet neighbour list (Verlet 1967) built with the cell index method (Quentrec &
//! Brot 1973), as on the seed's "Contact detection" slide, against a brute-force search
//! over all pairs.
//!
//! The list (`grainflow_components::VerletList`, compressed rows `start`/`neighbours`, full:
//! every pair in both rows) must hold, for the positions at its last rebuild (kept in
//! `VerletList::reference`), exactly the pairs with |x_i - x_j| < r_i + r_j + skin. Between
//! rebuilds it is a superset of the pairs that can touch: the list is rebuilt once a
//! particle has moved half the skin, so with the largest displacement s <= skin/2 since the
//! rebuild every pair closer than r_i + r_j + skin - 2 s now was listed (triangle
//! inequality); in particular every pair in contact (|x_i - x_j| < r_i + r_j) is.
//!
//! Checked on random polydisperse sets (dense, sparse and tall: the large-cell path of the
//! grid), and at every step of a few thousand steps of a loose polydisperse block falling
//! in a box with random velocities, through many rebuilds and particle re-sorts. The
//! stable ids must stay a permutation of 0..n and keep their radii through the re-sorts.
//! No tolerance: set equality (with the same floating-point cut-off expression as the
//! list; pairs within 1e-12 relative of the cut-off are exempt from the superset checks).
mod common;

use common::*;
use grainflow::run::Simulation;
use grainflow_components::{NeighbourSettings, Particles, VerletList};
use grainflow_systems::neighbour::verlet_list::CellGrid;

struct Sphere {
    radius: f64,
    position: [f64; 3],
    velocity: [f64; 3],
}

/// `n` non-overlapping spheres with radii uniform in `radii`, centres uniform in the box
/// `lo`..`hi` shrunk by the radius, velocity components uniform in +-`speed`.
fn random_spheres(
    rng: &mut Rng,
    n: usize,
    radii: (f64, f64),
    lo: [f64; 3],
    hi: [f64; 3],
    speed: f64,
) -> Vec<Sphere> {
    let mut out: Vec<Sphere> = Vec::with_capacity(n);
    let mut tries = 0;
    while out.len() < n {
        tries += 1;
        assert!(tries < 1000 * n, "cannot place {n} spheres");
        let r = rng.uniform(radii.0, radii.1);
        let p = [0, 1, 2].map(|d| rng.uniform(lo[d] + r, hi[d] - r));
        if out
            .iter()
            .all(|s| distance(s.position, p) > 1.001 * (s.radius + r))
        {
            out.push(Sphere {
                radius: r,
                position: p,
                velocity: [0, 1, 2].map(|_| rng.uniform(-speed, speed)),
            });
        }
    }
    out
}

/// Scene of `spheres`, optionally in a box, with the default skin (0.2 x the largest
/// radius) or `skin`.
fn scene(
    spheres: &[Sphere],
    walls: Option<([f64; 3], [f64; 3])>,
    gravity: f64,
    skin: Option<f64>,
    dt: f64,
) -> String {
    let skin = skin.map_or(String::new(), |s| format!("[neighbour]\nskin = {s:e}\n\n"));
    let mut s = format!(
        "[simulation]\ndt = {dt:e}\nend_time = 1.0\ngravity = [0.0, 0.0, {gravity}]\n\n{skin}\
         [[materials]]\nname = \"m\"\ndensity = 2500.0\nyoungs_modulus = 1e7\n\
         poisson_ratio = 0.3\nrestitution = 0.5\n"
    );
    if let Some((lo, hi)) = walls {
        s +=
            &format!("\n[[walls]]\ntype = \"box\"\nmaterial = \"m\"\nmin = {lo:?}\nmax = {hi:?}\n");
    }
    for p in spheres {
        s += &format!(
            "\n[[spheres]]\nmaterial = \"m\"\nradius = {:e}\nposition = [{:e}, {:e}, {:e}]\n\
             velocity = [{:e}, {:e}, {:e}]\n",
            p.radius,
            p.position[0],
            p.position[1],
            p.position[2],
            p.velocity[0],
            p.velocity[1],
            p.velocity[2]
        );
    }
    s
}

/// All partners of every particle (its own row and the pairs it is partner in), sorted,
/// from the rows alone.
fn all_partners(list: &VerletList, n: usize) -> Vec<Vec<u32>> {
    let mut rows = vec![Vec::new(); n];
    for i in 0..n {
        for &j in &list.neighbours[list.start[i] as usize..list.start[i + 1] as usize] {
            rows[i].push(j);
            rows[j as usize].push(i as u32);
        }
    }
    for r in &mut rows {
        r.sort_unstable();
    }
    rows
}

/// The near partners of particle `i` through the list's own accessor (near row prefix and
/// reverse index), sorted.
fn near_partners(list: &VerletList, i: usize) -> Vec<u32> {
    let mut r: Vec<u32> = list.partners(i).collect();
    r.sort_unstable();
    r
}

/// Check the list of the current state against brute force. Returns the number of list
/// pairs and of pairs in contact.
fn check_list(sim: &Simulation, radius_of_id: &[f64]) -> (usize, usize) {
    let p = sim.world.resource::<Particles>();
    let list = sim.world.resource::<VerletList>();
    let skin = sim.world.resource::<NeighbourSettings>().skin;
    let n = p.len();
    assert_eq!(list.start.len(), n + 1, "one row per particle");
    assert_eq!(list.start[n] as usize, list.neighbours.len());
    // A half list: each pair once, in the row of its lower row index; owner and reverse
    // index consistent with the rows.
    // Narrowed rows (two-level list): the near pairs of row i are
    // start[i]..near_end[i], and the reverse index lists exactly the near pairs.
    assert_eq!(list.owner.len(), list.pairs());
    assert_eq!(list.rev_start.len(), n + 1);
    assert_eq!(list.near_end.len(), n);
    let near_pairs: usize = (0..n)
        .map(|i| (list.near_end[i] - list.start[i]) as usize)
        .sum();
    assert_eq!(list.rev_pairs.len(), near_pairs);
    for i in 0..n {
        assert!(
            list.start[i] <= list.near_end[i] && list.near_end[i] <= list.start[i + 1],
            "near end of row {i} outside its row"
        );
        for k in list.start[i] as usize..list.start[i + 1] as usize {
            assert_eq!(list.owner[k] as usize, i, "owner of pair {k}");
            assert!(
                list.neighbours[k] as usize > i,
                "pair {k} is stored in the row of its lower index"
            );
        }
        for (&k, &o) in list.rev_pairs[list.rev_start[i] as usize..list.rev_start[i + 1] as usize]
            .iter()
            .zip(&list.rev_owner[list.rev_start[i] as usize..list.rev_start[i + 1] as usize])
        {
            assert_eq!(
                list.neighbours[k as usize] as usize, i,
                "reverse index of particle {i}"
            );
            assert_eq!(list.owner[k as usize], o, "reverse owner of pair {k}");
            assert!(
                (k as usize) < list.near_end[o as usize] as usize,
                "reverse index of particle {i} lists pair {k}, beyond the near end of its row"
            );
        }
    }
    // Ids: a permutation of 0..n, each keeping its radius.
    let mut ids = p.id.clone();
    ids.sort_unstable();
    assert!(
        ids.iter().enumerate().all(|(k, &id)| id as usize == k),
        "ids are not a permutation of 0..{n}"
    );
    for i in 0..n {
        assert_eq!(
            p.radius[i], radius_of_id[p.id[i] as usize],
            "particle {} lost its radius in a re-sort",
            p.id[i]
        );
    }
    let [rx, ry, rz] = &list.reference;
    let [x, y, z] = &p.position;
    let r = &p.radius;
    let max_disp = (0..n)
        .map(|i| ((x[i] - rx[i]).powi(2) + (y[i] - ry[i]).powi(2) + (z[i] - rz[i]).powi(2)).sqrt())
        .fold(0.0, f64::max);
    let mut contacts = 0;
    assert!(
        max_disp <= 0.5 * skin * (1.0 + 1e-9) + 1e-15,
        "a particle moved {max_disp:e} m since the last rebuild, more than skin/2 = {:e} m",
        0.5 * skin
    );
    let rows = all_partners(list, n);
    for i in 0..n {
        let listed = &rows[i];
        let near = near_partners(list, i);
        // (b) Exactly the pairs within r_i + r_j + skin at the rebuild positions, with
        // the list's own expression for the cut-off.
        let (xi, yi, zi, ri) = (rx[i], ry[i], rz[i], r[i] + skin);
        let brute: Vec<u32> = (0..n)
            .filter(|&j| {
                let (dx, dy, dz) = (xi - rx[j], yi - ry[j], zi - rz[j]);
                let cut = ri + r[j];
                j != i && dx * dx + dy * dy + dz * dz < cut * cut
            })
            .map(|j| j as u32)
            .collect();
        assert_eq!(
            listed, &brute,
            "row {i} (id {}) differs from the brute-force search at the rebuild positions",
            p.id[i]
        );
        // (a) Superset now: every pair closer than r_i + r_j + skin - 2 s is listed, in
        // particular every pair in contact.
        for j in 0..n {
            if j == i {
                continue;
            }
            let d = distance([x[i], y[i], z[i]], [x[j], y[j], z[j]]);
            if j < i && d < r[i] + r[j] {
                contacts += 1;
            }
            let reach = r[i] + r[j] + skin - 2.0 * max_disp;
            if d < reach * (1.0 - 1e-12) || d < r[i] + r[j] {
                assert!(
                    listed.binary_search(&(j as u32)).is_ok(),
                    "pair ids {} and {} at distance {d:e} (contact at {:e}) is missing from \
                     the list",
                    p.id[i],
                    p.id[j],
                    r[i] + r[j]
                );
            }
            // (c) Every pair in contact is among the near pairs the contact passes read.
            if d < r[i] + r[j] {
                assert!(
                    near.binary_search(&(j as u32)).is_ok(),
                    "pair ids {} and {} in contact (distance {d:e}) is not among the near \
                     pairs (inner skin {:e} m)",
                    p.id[i],
                    p.id[j],
                    list.inner_skin
                );
            }
        }
    }
    (list.neighbours.len(), contacts)
}

fn static_set(spheres: &[Sphere], skin: Option<f64>) {
    let radius_of_id: Vec<f64> = spheres.iter().map(|s| s.radius).collect();
    let mut sim = simulation(&scene(spheres, None, 0.0, skin, 2e-6), "static.toml");
    sim.step();
    let (pairs, _) = check_list(&sim, &radius_of_id);
    // At least one neighbour per particle on average, for a meaningful comparison.
    assert!(
        2 * pairs >= spheres.len(),
        "too few pairs ({pairs}) for a meaningful check"
    );
}

#[test]
fn dense_polydisperse_sets() {
    // Size ratios 3 and 10, default and wide skins; seeds chosen arbitrarily.
    let cube = |a: f64| ([0.0; 3], [a, a, a]);
    for (seed, skin) in [(1, None), (2, Some(0.5e-3)), (3, Some(1.5e-3))] {
        let (lo, hi) = cube(0.018);
        static_set(
            &random_spheres(&mut Rng(seed), 450, (0.5e-3, 1.5e-3), lo, hi, 0.0),
            skin,
        );
    }
    let (lo, hi) = cube(0.02);
    static_set(
        &random_spheres(&mut Rng(7), 300, (0.2e-3, 2.0e-3), lo, hi, 0.0),
        Some(1e-3),
    );
}

#[test]
fn sparse_tall_set_uses_large_cells() {
    // Clusters far apart along a 2 m column: the grid enlarges its cells to keep their
    // number near the particle count, which must not lose pairs.
    let mut rng = Rng(11);
    let mut spheres = Vec::new();
    for k in 0..4 {
        let z0 = 0.6 * k as f64;
        spheres.extend(random_spheres(
            &mut rng,
            60,
            (0.5e-3, 1.5e-3),
            [0.0, 0.0, z0],
            [0.012, 0.012, z0 + 0.012],
            0.0,
        ));
    }
    let skin = 1e-3;
    let sim = simulation(&scene(&spheres, None, 0.0, Some(skin), 2e-6), "tall.toml");
    let grid = CellGrid::new(sim.world.resource::<Particles>(), skin);
    assert!(
        grid.edge > 2.0 * 1.5e-3 + skin,
        "the grid did not take its large-cell path (edge {:e} m)",
        grid.edge
    );
    static_set(&spheres, Some(skin));
}

#[test]
fn falling_block_through_many_rebuilds() {
    falling_block(1, 0.5, -200.0, 300, [0.02, 0.02, 0.04]);
}

/// Re-sorted at every third rebuild only: the builds in between scan cells whose members
/// are not in row order (the list's other path).
#[test]
fn falling_block_sorted_every_third_rebuild() {
    falling_block(3, 0.5, -200.0, 300, [0.02, 0.02, 0.04]);
}

/// A dense block slow enough for narrowed rows (an inner skin below the skin) between
/// rebuilds, and their renewal as the bound on the motion since the last narrowing
/// reaches half the inner skin; contacts form and must all be among the near pairs.
#[test]
fn settling_block_with_narrowed_rows() {
    let (narrowings, contacts) = falling_block(1, 0.02, -20.0, 450, [0.018; 3]);
    assert!(
        narrowings >= 20 && contacts >= 10,
        "the run narrowed the rows {narrowings} times with up to {contacts} contacts"
    );
}

/// A block of `n` spheres with random velocities (components up to +-`speed`) falling in
/// the box 0..`hi` under `gravity`, the list checked at every one of 3,000 steps; returns
/// how many times the rows were narrowed and the most pairs in contact at once.
fn falling_block(
    sort_every: u32,
    speed: f64,
    gravity: f64,
    n: usize,
    hi: [f64; 3],
) -> (u64, usize) {
    let lo = [0.0; 3];
    let mut rng = Rng(2024);
    let spheres = random_spheres(&mut rng, n, (0.5e-3, 1.5e-3), lo, hi, speed);
    let radius_of_id: Vec<f64> = spheres.iter().map(|s| s.radius).collect();
    let text = scene(&spheres, Some((lo, hi)), gravity, None, 4e-6)
        + &format!("\n[neighbour]\nsort_every = {sort_every}\n");
    let mut sim = simulation(&text, "falling.toml");
    let (mut rebuild_steps, mut last_builds, mut most_contacts) = (0, 0, 0);
    for _ in 0..3000 {
        sim.step();
        assert!(sim.failure().is_none(), "{:?}", sim.failure());
        let builds = sim.world.resource::<VerletList>().builds;
        if builds != last_builds {
            rebuild_steps += 1;
            last_builds = builds;
        }
        let (_, contacts) = check_list(&sim, &radius_of_id);
        most_contacts = most_contacts.max(contacts);
    }
    let list = sim.world.resource::<VerletList>();
    eprintln!(
        "3000 steps: {} list builds, {} re-sorts, {} narrowings, {} listed pairs at the \
         end, up to {} contacts",
        list.builds,
        list.sorts,
        list.narrowings,
        list.pairs(),
        most_contacts
    );
    if speed < 0.1 {
        return (list.narrowings, most_contacts);
    }
    let unsorted = list.builds - list.sorts;
    assert!(
        rebuild_steps >= 50
            && list.sorts >= 50 / sort_every as u64
            && (sort_every == 1 || unsorted >= 30)
            && most_contacts >= 20,
        "the run did not exercise rebuilds, re-sorts and contacts ({} builds, {} sorts, up \
         to {most_contacts} contacts)",
        list.builds,
        list.sorts
    );
    (list.narrowings, most_contacts)
}
