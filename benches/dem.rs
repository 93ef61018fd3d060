//! Criterion benchmarks of the DEM hot loops, per particle, on a dense packing of
//! 50,000 spheres, the hopper-fill material: a simple-cubic lattice of touching spheres
//! (spacing 2 r, the least a lattice block allows). Every sphere lists its six lattice
//! neighbours (three per row of the half list, about the five to six contacts of a
//! settled hopper bed), and the contact kernel computes every lane of a dense chunk,
//! touching or not, as in a bed; but the overlaps are at rounding level (1e-14 of a
//! radius), so the friction entries hold tangential history only for the pairs that touch
//! by rounding. (A block squeezed to a real overlap flies apart within the thousands of
//! steps of the integrator and full-step entries.) `neighbour_rebuild_loose_lattice`
//! rebuilds on the lattice of the benchmark's loose state instead.
//!
//!   cargo bench --bench dem
//!
//! Figures are particles per second (criterion's "elements"); the whole-step throughput
//! against LAMMPS is measured by `scripts/bench-vs-lammps.sh`. The `friction_rolling`
//! entries run the same packing with Coulomb friction (mu_s = 0.5) and rolling
//! resistance (mu_r = 0.1): the contact system with history (`granular_contact`) and the
//! rotation integrator, against the frictionless `hertz_contact` path. The
//! `predicting_ahead` entries run the integrators as the run loop does (`PredictAhead`):
//! the corrector also predicts the next step, in the same pass.
use std::path::Path;

use bevy_ecs::system::RunSystemOnce;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use grainflow::run::Simulation;
use grainflow_components::{IntegratorKind, Particles, PredictAhead, VerletList};
use grainflow_systems::contact::{frictionless, with_history};
use grainflow_systems::integrate::{gear, verlet};
use grainflow_systems::neighbour::verlet_list;

/// The material lines that turn friction and rolling resistance on.
const FRICTION_ROLLING: &str = "friction = 0.5\nrolling_friction = 0.1";

fn dense_block(integrator: &str, surface: &str) -> Simulation {
    lattice_block(integrator, surface, 0.04)
}

/// 50,000 spheres (r = 0.02 m) on a simple-cubic lattice of 37 sites a side at `spacing`.
fn lattice_block(integrator: &str, surface: &str, spacing: f64) -> Simulation {
    let side = 36.5 * spacing;
    let scene = format!(
        r#"
[simulation]
dt = 1.0e-5
end_time = 1.0
integrator = "{integrator}"
[neighbour]
skin = 0.004
[[materials]]
name = "grain"
density = 10.0
youngs_modulus = 1.0e7
normal_damping = 1.0e-5
{surface}
[[blocks]]
material = "grain"
radius = 0.02
spacing = {spacing}
min = [0.0, 0.0, 0.0]
max = [{side}, {side}, {side}]
count = 50000
"#
    );
    let path = Path::new("bench-dense.toml");
    let mut sim = Simulation::new(
        grainflow::scene::parse(&scene, path, &[]).unwrap(),
        path,
        None,
    )
    .unwrap();
    sim.start();
    sim
}

/// One step of the integrator alone as the run loop has it (`PredictAhead` granted): the
/// predictor, which skips the rows the last corrector predicted, and the corrector, which
/// predicts the next step in its own pass.
fn integrate_predicting_ahead(sim: &mut Simulation, integrator: IntegratorKind) {
    sim.world.resource_mut::<PredictAhead>().allowed = true;
    let world = &mut sim.world;
    match integrator {
        IntegratorKind::Gear => {
            world.run_system_once(gear::gear_predict).unwrap();
            world.run_system_once(gear::gear_correct).unwrap();
        }
        IntegratorKind::VelocityVerlet => {
            world.run_system_once(verlet::verlet_predict).unwrap();
            world.run_system_once(verlet::verlet_correct).unwrap();
        }
    }
}

fn bench(c: &mut Criterion) {
    for threads in [1, 2] {
        // The work runs inside the pool; criterion's timer stays on this thread.
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mut group = c.benchmark_group(format!("dem_{threads}_thread"));
        group.sample_size(20);
        let mut sim = pool.install(|| dense_block("gear", ""));
        let n = sim.world.resource::<Particles>().len() as u64;
        group.throughput(Throughput::Elements(n));
        group.bench_function(BenchmarkId::new("neighbour_rebuild", n), |b| {
            b.iter(|| {
                pool.install(|| {
                    sim.world.resource_mut::<VerletList>().stale = true;
                    sim.world.run_system_once(verlet_list::verlet_list).unwrap();
                })
            })
        });
        // The lattice of the benchmark's loose state (spacing 1.25 d, no contacts, about
        // 0.7 particles per cell), on a block of its own: the rebuild that dominates
        // falling and filling runs.
        let mut loose = pool.install(|| lattice_block("gear", "", 0.05));
        group.bench_function(
            BenchmarkId::new("neighbour_rebuild_loose_lattice", n),
            |b| {
                b.iter(|| {
                    pool.install(|| {
                        loose.world.resource_mut::<VerletList>().stale = true;
                        loose
                            .world
                            .run_system_once(verlet_list::verlet_list)
                            .unwrap();
                    })
                })
            },
        );
        drop(loose);
        group.bench_function(BenchmarkId::new("contact_forces", n), |b| {
            b.iter(|| {
                pool.install(|| {
                    sim.world
                        .run_system_once(frictionless::hertz_contact)
                        .unwrap()
                })
            })
        });
        group.bench_function(BenchmarkId::new("gear_predict_correct", n), |b| {
            b.iter(|| {
                pool.install(|| {
                    sim.world.run_system_once(gear::gear_predict).unwrap();
                    sim.world.run_system_once(gear::gear_correct).unwrap();
                })
            })
        });
        group.bench_function(BenchmarkId::new("gear_correct_predicting_ahead", n), |b| {
            b.iter(|| pool.install(|| integrate_predicting_ahead(&mut sim, IntegratorKind::Gear)))
        });
        group.bench_function(BenchmarkId::new("full_step_gear", n), |b| {
            b.iter(|| pool.install(|| sim.step()))
        });
        group.bench_function(
            BenchmarkId::new("full_step_gear_predicting_ahead", n),
            |b| b.iter(|| pool.install(|| sim.step_predicting_ahead(true))),
        );
        let mut sim = pool.install(|| dense_block("gear", FRICTION_ROLLING));
        group.bench_function(
            BenchmarkId::new("contact_forces_friction_rolling", n),
            |b| {
                b.iter(|| {
                    pool.install(|| {
                        sim.world
                            .run_system_once(with_history::granular_contact)
                            .unwrap()
                    })
                })
            },
        );
        group.bench_function(
            BenchmarkId::new("full_step_gear_friction_rolling", n),
            |b| b.iter(|| pool.install(|| sim.step())),
        );
        let mut sim = pool.install(|| dense_block("velocity_verlet", ""));
        group.bench_function(BenchmarkId::new("verlet_predict_correct", n), |b| {
            b.iter(|| {
                pool.install(|| {
                    sim.world.run_system_once(verlet::verlet_predict).unwrap();
                    sim.world.run_system_once(verlet::verlet_correct).unwrap();
                })
            })
        });
        group.bench_function(
            BenchmarkId::new("verlet_correct_predicting_ahead", n),
            |b| {
                b.iter(|| {
                    pool.install(|| {
                        integrate_predicting_ahead(&mut sim, IntegratorKind::VelocityVerlet)
                    })
                })
            },
        );
        group.bench_function(BenchmarkId::new("full_step_verlet", n), |b| {
            b.iter(|| pool.install(|| sim.step()))
        });
        group.bench_function(
            BenchmarkId::new("full_step_verlet_predicting_ahead", n),
            |b| b.iter(|| pool.install(|| sim.step_predicting_ahead(true))),
        );
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
