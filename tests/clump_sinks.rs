//! Sinks with clumps (`systems/src/sinks.rs`): a clump leaves as a whole body when its
//! centre of mass passes a sink. Clumps of two types, spinning and tumbling, and free
//! spheres fall without contact through a sink plane; after every step:
//!
//! - no orphan: every body's members are rows, with the ids and the rows the bodies
//!   hold, and every member row belongs to a body present;
//! - a body with a member already past the plane but its centre not is kept whole (seen
//!   at least once);
//! - the sink's count is bodies plus spheres gone, its mass the bodies' masses (the
//!   union's, not the member rows' own) plus the spheres';
//! - the energy balance closes: in free fall the mechanical energy at every check is
//!   `initial + inserted - removed` to round-off, so a body's energy taken out per member
//!   (twice) or not at all shows.
mod common;

use std::collections::BTreeSet;

use common::simulation;
use grainflow::run::Simulation;
use grainflow_components::{Clumps, EnergyBalance, Particles, SimClock, Sinks};

const SPHERE_R: f64 = 1.0e-3;
const RHO: f64 = 2500.0;

/// Eight clumps (two types, randomly oriented, spinning) and three spheres in a row along
/// x, 6 mm apart (no contact), falling from 2 to 12 mm through the sink plane z = 0.
fn scene() -> String {
    let mut text = format!(
        "[simulation]\ndt = 2.0e-6\nend_time = 1.0\nintegrator = \"gear\"\ngravity = [0.0, 0.0, -9.81]\n\
         output_interval = 0.0\n\
         [[materials]]\nname = \"m\"\ndensity = {RHO}\nyoungs_modulus = 1.0e7\npoisson_ratio = 0.3\n\
         restitution = 0.5\nfriction = 0.3\n\
         [[clump_types]]\nname = \"pair\"\nmaterial = \"m\"\n\
         spheres = [{{ offset = [-0.5e-3, 0.0, 0.0], radius = 1.0e-3 }}, {{ offset = [0.5e-3, 0.0, 0.0], radius = 1.0e-3 }}]\n\
         [[clump_types]]\nname = \"big pair\"\nmaterial = \"m\"\n\
         spheres = [{{ offset = [0.0, 0.0, 0.0], radius = 1.5e-3 }}, {{ offset = [0.0, 1.2e-3, 0.0], radius = 1.0e-3 }}]\n\
         [[sinks]]\nname = \"floor\"\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\n"
    );
    for k in 0..8 {
        let kind = if k % 2 == 0 { "pair" } else { "big pair" };
        let (x, z) = (6.0e-3 * k as f64, 2.0e-3 + 1.3e-3 * k as f64);
        let w = [40.0 - 10.0 * k as f64, 25.0, -30.0 + 7.0 * k as f64];
        text += &format!(
            "[[clumps]]\ntype = \"{kind}\"\nposition = [{x:e}, 0.0, {z:e}]\nrandom_orientation = true\n\
             velocity = [0.0, 0.0, -0.2]\nangular_velocity = {w:?}\n"
        );
    }
    for k in 0..3 {
        let x = 6.0e-3 * (8 + k) as f64;
        text += &format!(
            "[[spheres]]\nmaterial = \"m\"\nradius = {SPHERE_R:e}\nposition = [{x:e}, 0.0, {:e}]\n\
             angular_velocity = [10.0, 0.0, 0.0]\n",
            3.0e-3 + 2.0e-3 * k as f64
        );
    }
    text
}

/// Members of the bodies present, checked against the rows: each body's ids are rows, its
/// `member_row` entries hold them, and every member row's body is present and owns it.
/// Returns the number of free spheres.
fn check_members(sim: &Simulation) -> usize {
    let p = sim.world.resource::<Particles>();
    let c = sim.world.resource::<Clumps>();
    let ids: BTreeSet<u32> = p.id.iter().copied().collect();
    let mut members = 0;
    for b in 0..c.len() {
        let n = c.types[c.kind[b] as usize].members.len() as u32;
        let first = c.first_member[b];
        for (k, id) in (first..first + n).enumerate() {
            assert!(
                ids.contains(&id),
                "body {b}: member id {id} has no row (orphaned)"
            );
            assert_eq!(c.body_of_id[id as usize], b as u32, "body of id {id}");
            if !c.rows_stale {
                let slot = c.member_start[b] as usize + k;
                assert_eq!(
                    p.id[c.member_row[slot] as usize], id,
                    "body {b}: member row"
                );
            }
        }
        members += n as usize;
    }
    assert_eq!(c.member_start.len(), c.len() + 1, "member_start");
    for &id in &p.id {
        if let Some(&b) = c.body_of_id.get(id as usize).filter(|&&b| b != u32::MAX) {
            let b = b as usize;
            assert!(b < c.len(), "row of id {id} names the removed body {b}");
            let n = c.types[c.kind[b] as usize].members.len() as u32;
            assert!(
                (c.first_member[b]..c.first_member[b] + n).contains(&id),
                "row of id {id} is no member of body {b}"
            );
        }
    }
    p.len() - members
}

#[test]
fn clumps_leave_a_sink_whole_counted_once_with_their_mass_and_energy() {
    let mut sim = simulation(&scene(), "clump_sinks.toml");
    let (bodies0, type_mass, kinds, first0) = {
        let c = sim.world.resource::<Clumps>();
        let masses: Vec<f64> = c.types.iter().map(|t| t.mass).collect();
        (c.len(), masses, c.kind.clone(), c.first_member.clone())
    };
    assert_eq!(bodies0, 8);
    let sphere_mass = RHO * 4.0 / 3.0 * std::f64::consts::PI * SPHERE_R.powi(3);
    // The union's mass, less than the members' spheres (the pair overlaps): a count by
    // member rows would differ.
    assert!(type_mass[0] < 2.0 * sphere_mass * 0.99);
    let spheres0 = check_members(&sim);
    assert_eq!(spheres0, 3);
    let mut straddling_kept = false;
    let mut last_check = u64::MAX;
    let mut checks = 0;
    for _ in 0..60_000 {
        let step = sim.world.resource::<SimClock>().step;
        sim.step();
        let spheres = check_members(&sim);
        let c = sim.world.resource::<Clumps>();
        let p = sim.world.resource::<Particles>();
        let sinks = sim.world.resource::<Sinks>();
        // The bodies gone, by their first member ids.
        let present: BTreeSet<u32> = c.first_member.iter().copied().collect();
        let gone_mass: f64 = first0
            .iter()
            .zip(&kinds)
            .filter(|(f, _)| !present.contains(f))
            .map(|(_, &k)| type_mass[k as usize])
            .sum::<f64>()
            + (spheres0 - spheres) as f64 * sphere_mass;
        let gone = (bodies0 - c.len()) + (spheres0 - spheres);
        assert_eq!(
            sinks.removed[0], gone as u64,
            "count: bodies and spheres gone"
        );
        assert!(
            (sinks.removed_mass[0] - gone_mass).abs() <= 1e-12 * gone_mass.max(1e-30),
            "removed mass {} for {gone_mass}",
            sinks.removed_mass[0]
        );
        if step.is_multiple_of(grainflow_systems::sinks::SINK_CHECK_INTERVAL) {
            // Checked at the start of this step: every body left had its centre above
            // the plane then (at most one step of fall, 2e-6 s x 1 m/s, ago).
            for b in 0..c.len() {
                assert!(c.position[b].z > -1e-5, "body {b} past the sink kept");
                let range = c.member_start[b] as usize..c.member_start[b + 1] as usize;
                if c.member_row[range]
                    .iter()
                    .any(|&r| p.position[2][r as usize] < -1e-4)
                    && c.position[b].z > 1e-5
                {
                    straddling_kept = true;
                }
            }
        }
        let balance = sim.world.resource::<EnergyBalance>();
        if balance.checked_step != last_check {
            last_check = balance.checked_step;
            checks += 1;
            let off = balance.total() - balance.supplied();
            assert!(
                off.abs() <= 1e-9 * balance.scale,
                "step {step}: energy {} against supplied {} (removed {}): off by {off:e}",
                balance.total(),
                balance.supplied(),
                balance.removed
            );
        }
        if c.is_empty() && spheres == 0 {
            break;
        }
    }
    let c = sim.world.resource::<Clumps>();
    assert!(c.is_empty(), "{} bodies never left", c.len());
    assert_eq!(sim.world.resource::<Particles>().len(), 0);
    assert!(
        straddling_kept,
        "no body seen across the plane: the test missed it"
    );
    assert!(checks > 10, "only {checks} energy checks");
    let balance = sim.world.resource::<EnergyBalance>();
    assert!(balance.removed != 0.0);
    let sinks = sim.world.resource::<Sinks>();
    assert_eq!(sinks.removed[0], 11);
    eprintln!(
        "removed {} bodies+spheres, {:.6e} kg, energy {:.6e} J",
        sinks.removed[0], sinks.removed_mass[0], balance.removed
    );
}

/// cases/hopper-fill-clumps-spheres.toml pours spheres of the volume of the clump of
/// cases/hopper-fill-clumps.toml (the union volume grainflow computes, mass over
/// density), as many, of the same material, through the same region: the same total
/// solid mass. The two files must agree.
#[test]
fn the_sphere_companion_of_the_clump_hopper_has_the_clump_volume() {
    let root = env!("CARGO_MANIFEST_DIR");
    let read = |name: &str| {
        let path = format!("{root}/cases/{name}");
        let text = std::fs::read_to_string(&path).expect("case file");
        (
            grainflow::scene::parse(&text, std::path::Path::new(&path), &[]).expect("parses"),
            text,
        )
    };
    let (clump_scene, clump_text) = read("hopper-fill-clumps.toml");
    let (sphere_scene, _) = read("hopper-fill-clumps-spheres.toml");
    let sim = simulation(&clump_text, "hopper-fill-clumps.toml");
    let c = sim.world.resource::<Clumps>();
    let density = clump_scene.materials[0].density;
    let volume = c.types[0].mass / density;
    let radius = (3.0 * volume / (4.0 * std::f64::consts::PI)).cbrt();
    // Two spheres of r = 0.02 m whose centres are r apart: 9 pi r^3 / 4 (the lens, by
    // the lattice rule of contact/shapes/clump.rs, within 1e-4).
    let exact = 9.0 * std::f64::consts::PI * 0.02f64.powi(3) / 4.0;
    eprintln!(
        "clump union volume {volume:.6e} m^3 (exact {exact:.6e}), sphere radius {radius:.6e} m"
    );
    assert!((volume / exact - 1.0).abs() < 1e-4);
    let (a, b) = (&clump_scene.inflows[0], &sphere_scene.inflows[0]);
    assert_eq!(b.radii.len(), 1);
    assert!(
        (b.radii[0] / radius - 1.0).abs() < 1e-6,
        "companion radius {} against {radius}",
        b.radii[0]
    );
    assert_eq!((a.total, a.rate, a.velocity), (b.total, b.rate, b.velocity));
    assert_eq!(
        format!("{:?}", clump_scene.materials),
        format!("{:?}", sphere_scene.materials),
        "materials"
    );
    assert_eq!(
        format!("{:?}", a.region),
        format!("{:?}", b.region),
        "region"
    );
    assert_eq!(
        format!("{:?}", clump_scene.walls),
        format!("{:?}", sphere_scene.walls),
        "walls"
    );
}
