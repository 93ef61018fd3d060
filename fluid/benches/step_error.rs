//! Run time against error of the solver settings of a transient step: the seed's
//! sedimentation box as a channel (box 10 x 2 x 2, 25 x 5 x 5 coarse cells, nu = 0.01,
//! parabolic inflow of peak 1 at x = 0, do-nothing outflow at x = 10, no-slip walls;
//! `cases/channel-10x2x2.toml`) from rest to t = 2, at U dt/h = 1 (dt = 0.1 at level 3),
//! on 2 threads. Each row is one time scheme with one pair of momentum / pressure
//! tolerances; it prints the wall seconds per step, the multigrid cycles per step, the
//! largest divergence after a step, and two errors of the velocity at t = 2 (largest
//! difference over all face values, relative to the inflow peak):
//! * `solver`: against the same scheme with both tolerances 1e-10 (what the inexact solves
//!   cost in accuracy);
//! * `total`: against fractional-step theta at dt/4 with tolerances 1e-10 (the time
//!   discretisation error plus the solver error).
//!
//!   cargo bench -p grainflow-fluid --bench step_error            # level 3
//!   cargo bench -p grainflow-fluid --bench step_error -- 2       # level 2 (quick)
use std::time::Instant;

use grainflow_fluid::BoundaryKind::{Dirichlet, DoNothing};
use grainflow_fluid::{Grid, NavierStokes, NsConfig, TimeScheme};

/// Simulated time of every run.
const T_END: f64 = 2.0;

/// Runs: scheme, momentum and pressure tolerance.
const RUNS: [(TimeScheme, f64, f64); 12] = {
    use TimeScheme::{BackwardEuler as Be, CrankNicolson as Cn, FractionalStepTheta as Fs};
    [
        (Fs, 1e-6, 1e-8),
        (Fs, 1e-3, 1e-5),
        (Fs, 1e-2, 1e-4),
        (Cn, 1e-6, 1e-8),
        (Cn, 1e-3, 1e-5),
        (Cn, 1e-2, 1e-5),
        (Cn, 1e-2, 1e-4),
        (Cn, 1e-1, 1e-4),
        (Be, 1e-6, 1e-8),
        (Be, 1e-3, 1e-5),
        (Be, 1e-2, 1e-4),
        (Be, 1e-1, 1e-4),
    ]
};

/// The channel at `level` with time step `dt`, run to [`T_END`]: the velocity, wall
/// seconds per step, momentum and pressure cycles per step and the largest divergence.
fn run(
    level: u32,
    dt: f64,
    scheme: TimeScheme,
    mom: f64,
    pre: f64,
) -> ([Vec<f64>; 3], f64, f64, f64, f64) {
    let bc = [[Dirichlet, DoNothing], [Dirichlet; 2], [Dirichlet; 2]];
    let g = Grid::new([0.0; 3], [10.0, 2.0, 2.0], [25, 5, 5], level, bc).unwrap();
    let mut cfg = NsConfig::new(0.01, dt);
    cfg.scheme = scheme;
    cfg.momentum_rtol = mom;
    cfg.pressure_rtol = pre;
    let mut ns = NavierStokes::new(&g, cfg, g.dirichlet_mask());
    ns.set_side_velocity(0, 0, |x| {
        [x[1] * (2.0 - x[1]) * x[2] * (2.0 - x[2]), 0.0, 0.0]
    });
    let steps = (T_END / dt).round() as usize;
    let (mut mc, mut pc, mut div) = (0, 0, 0.0f64);
    let start = Instant::now();
    for _ in 0..steps {
        let r = ns.step();
        mc += r.momentum_cycles;
        pc += r.pressure_cycles;
        div = div.max(r.max_divergence);
    }
    let s = steps as f64;
    (
        ns.u.clone(),
        start.elapsed().as_secs_f64() / s,
        mc as f64 / s,
        pc as f64 / s,
        div,
    )
}

fn max_diff(a: &[Vec<f64>; 3], b: &[Vec<f64>; 3]) -> f64 {
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| x.iter().zip(y).map(|(p, q)| (p - q).abs()))
        .fold(0.0, f64::max)
}

fn main() {
    let level: u32 = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(3);
    rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build_global()
        .unwrap();
    // U dt/h = 1 with U = 1 and h = 0.4 / 2^(level-1)
    let dt = 0.4 / f64::from(1u32 << (level - 1));
    let (fine, ..) = run(
        level,
        dt / 4.0,
        TimeScheme::FractionalStepTheta,
        1e-10,
        1e-10,
    );
    println!("level {level}, dt {dt}, t = {T_END}; errors: max |u - u_ref| (inflow peak 1)");
    println!("| scheme | momentum rtol | pressure rtol | s/step | momentum cycles/step | pressure cycles/step | max div | error (solver) | error (total) |");
    println!("|---|---|---|---|---|---|---|---|---|");
    let mut tight = None;
    for (scheme, mom, pre) in RUNS {
        if tight.as_ref().is_none_or(|(s, _)| *s != scheme) {
            tight = Some((scheme, run(level, dt, scheme, 1e-10, 1e-10).0));
        }
        let reference = &tight.as_ref().unwrap().1;
        let (u, sec, mc, pc, div) = run(level, dt, scheme, mom, pre);
        println!(
            "| {scheme:?} | {mom:.0e} | {pre:.0e} | {sec:.3} | {mc:.1} | {pc:.1} | {div:.1e} | {:.2e} | {:.2e} |",
            max_diff(&u, reference),
            max_diff(&u, &fine)
        );
    }
}
