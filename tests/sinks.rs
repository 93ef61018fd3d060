//! Particle sinks (`systems/src/sinks.rs`, `src/sinks.rs`): a frictional bin discharging
//! through its outlet into a sink. Every particle is accounted for (removed + left = the
//! particles placed, removed mass = count x particle mass, `sinks.csv` sums to the
//! totals, no particle past the sink in any frame, ids unique and never reused), the
//! energy balance holds with the removed particles' energy taken out, and the steady mass
//! flow rate agrees with the Beverloo correlation
//!
//!   W = C rho_b sqrt(g) (D - k d)^(5/2),  C = 0.58, k = 1.4
//!
//! (Beverloo, Leniger & van de Velde 1961, Chem. Eng. Sci. 15:260; the values of C and k
//! are those of their fit, which later measurements place between 0.55 and 0.65 for C,
//! Nedderman 1992, Statics and Kinematics of Granular Materials, ch. 10), with
//! rho_b = 0.6 rho (random loose packing of frictional spheres, Onoda & Liniger 1990,
//! Phys. Rev. Lett. 64:2727, phi about 0.55-0.60). Tolerance 25 %: the spread of C, of
//! the bulk density of a bed poured from a loose lattice, and a 45-degree cone, which
//! discharges somewhat faster than Beverloo's flat-bottomed bins.
mod common;

use std::path::Path;

use common::run_cli;

fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

#[test]
fn a_bin_discharges_at_the_beverloo_rate_and_every_particle_is_counted() {
    let root = env!("CARGO_MANIFEST_DIR");
    let scene = format!("{root}/cases/hopper-discharge-small.toml");
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("out");
    let total = 2000u64;
    let (code, stdout, stderr) = run_cli(&[
        "run",
        &scene,
        "--out",
        out.to_str().unwrap(),
        "--set",
        &format!("blocks.0.count={total}"),
        "--set",
        "walls.2.remove_at=0.1",
        "--set",
        "simulation.end_time=0.6",
        "--set",
        "simulation.output_interval=0.05",
    ]);
    assert_eq!(code, 0, "{stdout}\n{stderr}");
    let s = summary(&out);
    let sink = &s["sinks"][0];
    let removed = sink["removed"].as_u64().unwrap();
    let left = s["particles"].as_u64().unwrap();
    assert_eq!(removed + left, total, "particles lost or made");
    assert!(removed > 100, "only {removed} removed");
    // r = 0.02 m, rho = 10 kg/m^3 (the scene's material)
    let m = 10.0 * 4.0 / 3.0 * std::f64::consts::PI * 0.02f64.powi(3);
    let mass = sink["removed_mass"].as_f64().unwrap();
    assert!(
        (mass - removed as f64 * m).abs() < 1e-12 * mass,
        "removed mass {mass} for {removed} particles of {m} kg"
    );

    // sinks.csv: one line per check, counts and masses adding up to the totals.
    let csv = std::fs::read_to_string(out.join("sinks.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    let counted: u64 = rows.iter().map(|r| r[3].parse::<u64>().unwrap()).sum();
    assert_eq!(counted, removed, "sinks.csv counts");
    let last = rows.last().unwrap();
    assert_eq!(last[5].parse::<u64>().unwrap(), removed);

    // Every frame: ids unique and among those placed, nobody past the sink (z = -0.3).
    let file = hdf5::File::open(out.join("particles.h5")).unwrap();
    let mut names = file.member_names().unwrap();
    names.sort();
    let mut previous = total as usize + 1;
    for name in &names {
        let g = file.group(name).unwrap();
        let ids = g.dataset("id").unwrap().read_raw::<u32>().unwrap();
        let x = g.dataset("position").unwrap().read_raw::<f64>().unwrap();
        let mut sorted = ids.clone();
        sorted.dedup();
        assert_eq!(sorted.len(), ids.len(), "{name}: ids repeated");
        assert!(
            ids.iter().all(|&i| (i as u64) < total),
            "{name}: an id never placed"
        );
        assert!(ids.len() <= previous, "{name}: particles came back");
        previous = ids.len();
        let lowest = x.chunks(3).map(|p| p[2]).fold(f64::INFINITY, f64::min);
        // At most 64 steps (SINK_CHECK_INTERVAL) of fall below the sink at ~3 m/s.
        assert!(
            lowest > -0.3 - 64.0 * 1e-5 * 3.0,
            "{name}: a particle at z = {lowest}"
        );
    }
    assert_eq!(previous as u64, left);

    // The energy balance with the removed particles' energy taken out.
    let e = &s["energy"];
    assert!(e["removed"].as_f64().unwrap() != 0.0);
    let growth = e["largest_growth"].as_f64().unwrap();
    assert!(growth < 1e-6, "energy grew by {growth} of its scale");

    // Beverloo: D = 2 Ro = 0.294722 m, d = 0.04 m, rho_b = 0.6 x 10 kg/m^3.
    let w_b = 0.58 * 6.0 * 9.81f64.sqrt() * (0.294722 - 1.4 * 0.04f64).powf(2.5);
    let w = sink["discharge_rate"].as_f64().unwrap();
    let spread = sink["discharge_rate_spread"].as_f64().unwrap();
    eprintln!("discharge rate {w:.4} kg/s (spread {spread:.3}), Beverloo {w_b:.4} kg/s");
    // One sink: the run's discharge rate over all sinks is this sink's.
    assert_eq!(s["observables"]["discharge_rate"].as_f64(), Some(w));
    assert_eq!(
        s["observables"]["discharge_rate_spread"].as_f64(),
        Some(spread)
    );
    assert!(
        (w / w_b - 1.0).abs() < 0.25,
        "rate {w} kg/s, Beverloo {w_b} kg/s"
    );
    assert!(spread < 0.3, "not steady: halves differ by {spread}");
}
