//! Excavation profiles (`src/excavation.rs`, `grainflow plot profile`): a synthetic bed
//! with a known crater. 48,000 grains of r = 0.2 at uniform random centres fill
//! [0, 20]^2 x [0, 8] (solid fraction 0.5) except a conical crater about the axis
//! x = y = 10, depth D = 3 and radius R = 5: the surface is h(r) = 8 - D (1 - r / R) for
//! r < R, 8 beyond. The profile must follow it to within a quarter layer plus three
//! standard deviations of the grain count in each annulus (dr = 0.5, dz = 0.5), the crater's depth be D and its radius
//! (where the surface is back to 8 - D / 10) R (1 - 1/10) = 4.5, both within 0.25;
//! grains carried above the bed (200 in the water over the crater, z = 12-20) change
//! nothing; and a bed without a crater has none.
use grainflow::excavation::{crater, ProfileGrid};
use grainflow::plot::{FrameInfo, ParticleFrame};

mod common;

fn bed(with_crater: bool, carried: usize) -> ParticleFrame {
    let mut rng = common::Rng(0x5eed_cafe_f00d);
    let mut position = Vec::new();
    while position.len() < 48_000 {
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
    let flat = bed(false, 0);
    let phi_ref = GRID.reference_fraction(&flat);
    // 48,000 x 4/3 pi 0.2^3 / (400 x 8) = 0.503
    assert!((phi_ref - 0.503).abs() < 0.02, "phi_ref {phi_ref}");
    let profile = GRID.profile(&bed(true, 200), phi_ref);
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
    let (depth, radius, far) = crater(&profile);
    eprintln!("depth {depth:.3}, radius {radius:.3}, far {far:.3}");
    assert!((far - 8.0).abs() < 0.25, "far-field height {far}");
    assert!((depth - 3.0).abs() < 0.25, "depth {depth}");
    assert!((radius - 4.5).abs() < 0.25, "radius {radius}");
    let (depth0, _, _) = crater(&GRID.profile(&flat, phi_ref));
    assert!(depth0 < 0.3, "a flat bed has a crater {depth0} deep");
}
