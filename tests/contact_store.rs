//! The contact store (`ContactHistory`): per-pair history keyed by the stable ids of both
//! particles survives Verlet-list rebuilds and cell-order re-sorting, and a pair that
//! leaves the list loses it. (What the tangential spring of Cundall & Strack 1979 and the
//! JKR contact state need.)
use std::path::Path;

use grainflow::run::Simulation;
use grainflow::scene;
use grainflow_components::{ContactHistory, Particles, VerletList};

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
        values: Vec::new(),
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
        let list = sim.world.resource::<VerletList>().clone();
        let mut history = sim.world.resource_mut::<ContactHistory>();
        assert_eq!(
            history.values.len(),
            history.len_for(list.pairs()),
            "one history slot per listed pair"
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
