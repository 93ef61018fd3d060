//! The poured bed of the suction case (`cases/suction-bed.data`, written by
//! `grainflow run cases/suction-bed.toml --write-data cases/suction-bed.data`): 5,000
//! particles with the seed's size distribution, diameters 1.2 / 1.0 / 0.8 / 0.6 at
//! 10 / 40 / 40 / 10 % ("Suction extraction of particles [Feng, Han & Owen, 2009]",
//! shared/seed), drawn one by one by the inflow. The counts per diameter must agree with
//! the fractions within the sampling error of 5,000 draws: Pearson's chi-square with 3
//! degrees of freedom below 16.27, its 0.1 % critical value (Abramowitz & Stegun 1964,
//! table 26.8), and, as the negative control, far above it against equal fractions. The
//! bed is at rest inside the tank (every speed below 1 cm/s, no overlap with a side of
//! the tank above 5 % of the radius: 1.9 % the largest, a grain under a force chain on
//! the floor), and the data file reads
//! back as the scene's particle source bit for bit.
use std::path::Path;

const DIAMETERS: [f64; 4] = [1.2, 1.0, 0.8, 0.6];
const FRACTIONS: [f64; 4] = [0.1, 0.4, 0.4, 0.1];
const CHI2_3DOF_01PCT: f64 = 16.27;

fn chi_square(counts: &[u64; 4], fractions: &[f64; 4]) -> f64 {
    let n: u64 = counts.iter().sum();
    counts
        .iter()
        .zip(fractions)
        .map(|(&c, &f)| {
            let e = f * n as f64;
            (c as f64 - e).powi(2) / e
        })
        .sum()
}

#[test]
fn the_poured_bed_has_the_seeds_size_distribution_and_is_at_rest() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/suction-bed.data");
    let atoms = grainflow::lammps::read_data(&path).expect("the bed reads");
    assert_eq!(atoms.len(), 5000);
    let mut counts = [0u64; 4];
    for a in &atoms {
        let k = DIAMETERS
            .iter()
            .position(|&d| (2.0 * a.radius - d).abs() < 1e-12)
            .unwrap_or_else(|| panic!("atom {} of diameter {}", a.id, 2.0 * a.radius));
        counts[k] += 1;
        let r = a.radius;
        for d in 0..2 {
            assert!(
                a.position[d] > 0.95 * r && a.position[d] < 20.0 - 0.95 * r,
                "atom {} outside the tank",
                a.id
            );
        }
        assert!(a.position[2] > 0.95 * r, "atom {} below the floor", a.id);
        let v = a.velocity.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!(v < 1.0, "atom {} moves at {v} cm/s", a.id);
    }
    let chi2 = chi_square(&counts, &FRACTIONS);
    eprintln!("counts {counts:?}, chi-square {chi2:.2}");
    assert!(chi2 < CHI2_3DOF_01PCT, "chi-square {chi2} for {counts:?}");
    let equal = chi_square(&counts, &[0.25; 4]);
    assert!(
        equal > 10.0 * CHI2_3DOF_01PCT,
        "equal fractions pass: {equal}"
    );
}

#[test]
fn the_bed_file_reads_back_bit_for_bit() {
    let dir = tempfile::tempdir().expect("temp dir");
    let bed = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/suction-bed.data");
    let scene = format!(
        r#"
[simulation]
dt = 2.0e-5
end_time = 1.0
gravity = [0.0, 0.0, -981.0]
[[materials]]
name = "sand"
density = 2.65
youngs_modulus = 1.0e8
poisson_ratio = 0.3
[[lammps]]
file = "{}"
material = "sand"
"#,
        bed.display()
    );
    let path = dir.path().join("bed.toml");
    std::fs::write(&path, scene).unwrap();
    let parsed = grainflow::scene::parse(&std::fs::read_to_string(&path).unwrap(), &path, &[])
        .expect("scene");
    let sim = grainflow::run::Simulation::new(parsed, &path, None).expect("builds");
    let again = dir.path().join("again.data");
    grainflow::lammps::write_data(
        &again,
        sim.world.resource::<grainflow_components::Particles>(),
        sim.world.resource::<grainflow_components::Materials>(),
    )
    .unwrap();
    let (a, b) = (
        grainflow::lammps::read_data(&bed).unwrap(),
        grainflow::lammps::read_data(&again).unwrap(),
    );
    assert_eq!(a.len(), b.len());
    for (p, q) in a.iter().zip(&b) {
        assert_eq!(p.id, q.id);
        assert_eq!(p.radius.to_bits(), q.radius.to_bits());
        for d in 0..3 {
            assert_eq!(p.position[d].to_bits(), q.position[d].to_bits());
            assert_eq!(p.velocity[d].to_bits(), q.velocity[d].to_bits());
            assert_eq!(
                p.angular_velocity[d].to_bits(),
                q.angular_velocity[d].to_bits()
            );
        }
    }
}
