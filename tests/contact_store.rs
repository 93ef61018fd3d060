//! The contact store (`ContactHistory`): per-pair history keyed by the stable ids of both
//! particles survives Verlet-list rebuilds and cell-order re-sorting, and a pair that
//! leaves the list loses it. (What the tangential spring of Cundall & Strack 1979 and the
//! JKR contact state need.)
use std::path::Path;

use grainflow::run::Simulation;
use grainflow::scene;
use grainflow_components::{ContactHistory, PairList, Particles, VerletList};
use grainflow_systems::neighbour::verlet_list::scatter_plan;

const SCENE: &str = r#"
[simulation]
dt = 1.0e-5
end_time = 1.0
gravity = [0.0, 0.0, -9.81]

[neighbour]
skin = 0.0005

[[materials]]
name = "glass"
density = 2500.0
youngs_modulus = 1.0e7
poisson_ratio = 0.25
restitution = 0.5

[[walls]]
type = "box"
material = "glass"
min = [0.0, 0.0, 0.0]
max = [0.03, 0.03, 0.2]

[[blocks]]
material = "glass"
radius = 0.001
min = [0.002, 0.002, 0.002]
max = [0.028, 0.028, 0.012]
spacing = 0.0024
jitter = 0.8
"#;

/// The value a pair's history holds in this test: a function of both stable ids.
fn key(a: u32, b: u32) -> f64 {
    1.0 + a as f64 * 1.0e6 + b as f64
}

#[test]
fn pair_history_follows_the_pair_through_rebuilds_and_resorting() {
    let path = Path::new("contact-store.toml");
    let scene = scene::parse(SCENE, path, &[]).expect("scene");
    let mut sim = Simulation::new(scene, path, None).expect("world");
    // a directed 3-vector (as a tangential spring) in values 0-2, an undirected value in 3
    sim.world.insert_resource(ContactHistory {
        width: 4,
        directed: Some(0),
        ..Default::default()
    });
    sim.start();
    let mut carried = 0usize;
    // row owner of every pair (lower id, higher id) at the last step, and how many pairs
    // kept their history through a rebuild that gave their row to the other particle
    let mut owner = std::collections::HashMap::new();
    let mut turned = 0usize;
    let mut last_builds = sim.world.resource::<VerletList>().builds;
    let mut rebuilds_seen = 0;
    for _ in 0..3000 {
        sim.step();
        assert!(sim.failure().is_none(), "{:?}", sim.failure());
        let builds = sim.world.resource::<VerletList>().builds;
        let rebuilt = builds != last_builds;
        last_builds = builds;
        rebuilds_seen += rebuilt as usize;
        let ids = sim.world.resource::<Particles>().id.clone();
        let mut history = sim.world.resource_mut::<ContactHistory>();
        let list = history.pairs.clone();
        assert_eq!(
            history.values.len(),
            history.len_for(list.pairs()),
            "one history slot per pair of the store"
        );
        for k in 0..list.pairs() {
            let (a, b) = (
                ids[list.owner[k] as usize],
                ids[list.neighbours[k] as usize],
            );
            // The directed values are kept oriented from the row owner to its partner:
            // +key from the lower to the higher id, -key the other way.
            let want = key(a.min(b), a.max(b));
            let directed = if a < b { want } else { -want };
            let slot = [0, 1, 2, 3].map(|v| history.index(k, v));
            if history.values[slot[3]] != 0.0 {
                assert_eq!(
                    history.values[slot[3]], want,
                    "history of pair ({a}, {b}) came from another pair"
                );
                for &s in &slot[..3] {
                    assert_eq!(
                        history.values[s], directed,
                        "directed value of pair ({a}, {b}), owner {a}"
                    );
                }
                carried += rebuilt as usize;
                turned += (owner.get(&(a.min(b), a.max(b))) == Some(&b)) as usize;
            }
            for &s in &slot[..3] {
                history.values[s] = directed;
            }
            history.values[slot[3]] = want;
            owner.insert((a.min(b), a.max(b)), a);
        }
    }
    assert!(
        rebuilds_seen >= 10,
        "the falling block must rebuild its list many times ({rebuilds_seen})"
    );
    assert!(
        carried > 1000,
        "pairs listed before and after a rebuild keep their history ({carried})"
    );
    assert!(
        turned > 10,
        "pairs whose row owner changed at a rebuild keep their history, turned ({turned})"
    );
}

/// The scatter plan of the store's pairs (`ScatterPlan`) against the pairs: every pair's
/// two slots hold its owner and its partner in the pair's own work item; every slot of an
/// item holds a particle of its pairs, each once, ascending; every particle's records are
/// exactly its slots, in item order. A slot or record missing or doubled would lose or
/// double a force.
fn check_scatter_plan(store: &PairList, n: usize) {
    let plan = &store.scatter;
    let per_item = plan.pairs_per_item;
    assert!(per_item > 0 && per_item % 4 == 0, "items of whole blocks");
    let items = store.pairs().div_ceil(per_item);
    assert_eq!(plan.item_start.len(), items + 1, "slot ranges of the items");
    assert_eq!(plan.pair_slot.len(), store.pairs(), "two slots per pair");
    let mut records = vec![Vec::new(); n];
    for g in 0..items {
        let slots = plan.item_start[g] as usize..plan.item_start[g + 1] as usize;
        let held = &plan.particle[slots.clone()];
        assert!(
            held.windows(2).all(|w| w[0] < w[1]),
            "item {g}: slots ascending"
        );
        let pairs = g * per_item..((g + 1) * per_item).min(store.pairs());
        let mut used = vec![false; held.len()];
        for k in pairs {
            let [so, sp] = plan.pair_slot[k].map(usize::from);
            assert_eq!(held[so], store.owner[k], "pair {k}: owner slot");
            assert_eq!(held[sp], store.neighbours[k], "pair {k}: partner slot");
            used[so] = true;
            used[sp] = true;
        }
        assert!(
            used.iter().all(|&u| u),
            "item {g}: every slot is a particle of its pairs"
        );
        for (s, &p) in slots.zip(held) {
            records[p as usize].push(s as u32);
        }
    }
    assert_eq!(plan.gather_start.len(), n + 1, "records of every particle");
    for (i, want) in records.iter().enumerate() {
        let got = &plan.gather[plan.gather_start[i] as usize..plan.gather_start[i + 1] as usize];
        assert_eq!(got, &want[..], "records of particle {i}");
    }
}

/// The store keeps its own compact list of pairs (a two-level Verlet list): the listed
/// pairs within r_i + r_j + inner skin and every pair that holds history. Checked at
/// every step of a block settling with friction against a brute-force search: every pair
/// in contact is among the store's pairs (else its spring would be lost), every pair of
/// the store is listed, and the scatter plan of the kernel's sums fits the pairs.
#[test]
fn store_pairs_hold_every_contact_while_a_block_settles() {
    let path = Path::new("contact-store-friction.toml");
    let text = SCENE.replace("restitution = 0.5", "restitution = 0.5\nfriction = 0.5");
    let scene = scene::parse(&text, path, &[]).expect("scene");
    let mut sim = Simulation::new(scene, path, None).expect("world");
    sim.start();
    let (mut most_contacts, mut selections) = (0, 0);
    for step in 0..3000 {
        sim.step();
        assert!(sim.failure().is_none(), "{:?}", sim.failure());
        let p = sim.world.resource::<Particles>();
        let list = sim.world.resource::<VerletList>();
        let store = &sim.world.resource::<ContactHistory>().pairs;
        let n = p.len();
        assert_eq!(store.start.len(), n + 1, "one row per particle");
        assert_eq!(store.ids, p.id, "the store's rows are the particles' rows");
        selections = list.narrowings;
        let row =
            |i: usize| &store.neighbours[store.start[i] as usize..store.start[i + 1] as usize];
        for i in 0..n {
            let listed = &list.neighbours[list.start[i] as usize..list.start[i + 1] as usize];
            assert!(row(i).windows(2).all(|w| w[0] < w[1]), "row {i} ascending");
            for (k, &j) in (store.start[i]..store.start[i + 1]).zip(row(i)) {
                assert_eq!(store.owner[k as usize] as usize, i, "owner of pair {k}");
                assert!(listed.contains(&j), "store pair ({i}, {j}) is not listed");
            }
        }
        check_scatter_plan(store, n);
        if step % 50 == 0 {
            // Items of two blocks: pairs of one particle spread over many items.
            let scatter = scatter_plan(n, &store.owner, &store.neighbours, 8);
            let small = PairList {
                scatter,
                ..store.clone()
            };
            check_scatter_plan(&small, n);
        }
        let [x, y, z] = &p.position;
        let mut contacts = 0;
        for i in 0..n {
            for j in i + 1..n {
                let d2 = (x[i] - x[j]).powi(2) + (y[i] - y[j]).powi(2) + (z[i] - z[j]).powi(2);
                if d2.sqrt() < p.radius[i] + p.radius[j] {
                    contacts += 1;
                    assert!(
                        row(i).contains(&(j as u32)),
                        "pair ids {} and {} in contact is not among the store's pairs \
                         (inner skin {:e} m)",
                        p.id[i],
                        p.id[j],
                        list.inner_skin
                    );
                }
            }
        }
        most_contacts = most_contacts.max(contacts);
    }
    eprintln!("up to {most_contacts} contacts, {selections} selections of the store's pairs");
    assert!(
        most_contacts > 100 && selections > 20,
        "the run must settle into many contacts ({most_contacts}) and select the store's \
         pairs many times ({selections})"
    );
}
