//! Excavation profiles (`src/excavation.rs`, `grainflow plot profile`): a synthetic bed
//! with a known crater. 48,000 grains of r = 0.2 at uniform random centres fill [0,
//! 20]^2 x [0, 8] (solid fraction 0.5); the cratered bed is the same bed less the
//! grains inside a cone about the axis x = y = 10, depth D = 3 and radius R = 5: its
//! surface is h(r) = 8 - D (1 - r / R) for r < R, 8 beyond. The profile must follow it
//! to within a quarter layer plus three standard deviations of the grain count in each
//! annulus (dr = 0.5, dz = 0.5). Against the uncratered bed the crater's depth must be
//! D (its mean over the innermost annulus) and its radius (where the drop is back to D
//! / 10) R (1 - 1/10) = 4.5, both within 0.25; its bulk volume the cone's pi R^2 D / 3
//! = 78.5 within the count's noise (8.8 %) and the removed solid volume over phi_ref
//! within 5 %. Grains carried above the bed (200 in the water over the crater, z =
//! 12-20) change nothing, and a second uncratered bed of other random grains has no
//! crater against the first.
use grainflow::excavation::ProfileGrid;
use grainflow::plot::{FrameInfo, ParticleFrame};

mod common;

fn bed(with_crater: bool, carried: usize, seed: u64) -> ParticleFrame {
    let mut rng = common::Rng(seed);
    let mut position = Vec::new();
    for _ in 0..48_000 {
        let p = [
            20.0 * rng.next_f64(),
            20.0 * rng.next_f64(),
            8.0 * rng.next_f64(),
        ];
        let rho = (p[0] - 10.0).hypot(p[1] - 10.0);
        if with_crater && rho < 5.0 && p[2] > 8.0 - 3.0 * (1.0 - rho / 5.0) {
            continue;
        }
        position.push(p);
    }
    for _ in 0..carried {
        position.push([
            10.0 + 2.0 * (rng.next_f64() - 0.5),
            10.0 + 2.0 * (rng.next_f64() - 0.5),
            12.0 + 8.0 * rng.next_f64(),
        ]);
    }
    let n = position.len();
    ParticleFrame {
        info: FrameInfo { step: 0, time: 0.0 },
        id: (0..n as u32).collect(),
        velocity: vec![[0.0; 3]; n],
        radius: vec![0.2; n],
        position,
    }
}

const GRID: ProfileGrid = ProfileGrid {
    axis: [10.0, 10.0],
    dr: 0.5,
    dz: 0.5,
    r_max: 9.5,
};

#[test]
fn the_profile_finds_a_conical_crater_and_ignores_carried_grains() {
    let flat = bed(false, 0, 0x5eed_cafe_f00d);
    let phi_ref = GRID.reference_fraction(&flat);
    // 48,000 x 4/3 pi 0.2^3 / (400 x 8) = 0.503
    assert!((phi_ref - 0.503).abs() < 0.02, "phi_ref {phi_ref}");
    let initial = GRID.profile(&flat, phi_ref);
    let profile = GRID.profile(&bed(true, 200, 0x5eed_cafe_f00d), phi_ref);
    for &(r, h) in &profile {
        let exact = if r < 5.0 {
            8.0 - 3.0 * (1.0 - r / 5.0)
        } else {
            8.0
        };
        // A quarter layer, plus three standard deviations of the count of grains in the
        // annulus's column (Poisson: h / sqrt(N)), plus, for the annulus straddling the
        // cone's rim, the half-step of the surface across it.
        let area = std::f64::consts::PI * ((r + 0.25).powi(2) - (r - 0.25).powi(2));
        let count = phi_ref * area * exact / (4.0 / 3.0 * std::f64::consts::PI * 0.008);
        let rim = if (r - 5.0).abs() < 0.5 { 0.15 } else { 0.0 };
        let tol = 0.25 + 3.0 * exact / count.sqrt() + rim;
        assert!((h - exact).abs() < tol, "h({r}) = {h}, surface {exact}");
    }
    let c = GRID.crater(&initial, &profile);
    eprintln!("{c:?}");
    // The deepest annulus, [0, 0.5), averages the cone's drop D (1 - r / R) over its
    // area: D (1 - 1/15) = 2.8, within 0.25 of which the grains' size smooths it.
    assert!((c.depth - 2.8).abs() < 0.25, "depth {}", c.depth);
    assert!((c.radius - 4.5).abs() < 0.25, "radius {}", c.radius);
    // The cone holds about 1,170 grains: three standard deviations of that count are
    // 8.8 % of its volume.
    let cone = std::f64::consts::PI * 25.0 * 3.0 / 3.0;
    assert!((c.volume / cone - 1.0).abs() < 0.09, "volume {}", c.volume);
    // The removed grains over phi_ref are the same volume, but for the drops beyond
    // the crater's radius (the cone's rim straddles an annulus).
    let lost =
        (GRID.solid_volume(&flat) - GRID.solid_volume(&bed(true, 0, 0x5eed_cafe_f00d))) / phi_ref;
    assert!(
        (c.volume / lost - 1.0).abs() < 0.05,
        "volume {}, lost {lost}",
        c.volume
    );
    let other = GRID.profile(&bed(false, 0, 0x0dd_beef_1234), phi_ref);
    let none = GRID.crater(&initial, &other);
    assert!(
        none.depth < 0.3,
        "a flat bed has a crater {} deep",
        none.depth
    );
}
