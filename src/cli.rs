//! The `grainflow` command line: `run`, `check` and `plot` (`src/plot.rs`).
use std::fmt::Write as _;
use std::io::IsTerminal as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};

use grainflow_systems::schedule::{DEM_FIRST_HALF, FLUID_STEP};
use grainflow_systems::CoupledStep;

use crate::run::{default_out_dir, Simulation};
use crate::scene::{self, SceneError};

#[derive(Parser, Debug)]
#[command(
    name = "grainflow",
    version,
    about = "Particles in viscous fluid: DEM + FEM fictitious-domain simulator"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Run a scene and write particles.h5, particles.xdmf and summary.json.
    Run(RunArgs),
    /// Validate a scene; print its schedule, particle count and stable time steps.
    Check(CheckArgs),
    /// Write PNG plots of a run: flow contour slices, particle time series, side views.
    Plot(crate::plot::PlotArgs),
}

#[derive(Args, Debug)]
pub struct RunArgs {
    pub scene: PathBuf,
    /// Output directory (default `out/SCENE`, SCENE the scene file name without extension).
    /// The files of an earlier run in it (particles.h5, particles.xdmf, fluid.h5,
    /// fluid.xdmf, coupling.csv, summary.json) are removed first; other files are kept.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Run until this simulated time, s (default: the scene's end_time).
    #[arg(long, conflicts_with = "steps")]
    pub until: Option<f64>,
    /// Run this many steps (at most 1e12, as the steps --until or end_time imply).
    #[arg(long)]
    pub steps: Option<u64>,
    /// Worker threads, 1 to 4 x the cores (default: all cores). More threads than cores
    /// only take turns: the pool's threads spin between the passes of a step.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Write a Chrome/Perfetto trace of every system to FILE.
    #[arg(long)]
    pub trace: Option<PathBuf>,
    /// Override a scene field, e.g. --set simulation.dt=2e-6 --set walls.0.remove_at=1.0
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

#[derive(Args, Debug)]
pub struct CheckArgs {
    pub scene: PathBuf,
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

/// The most steps one run takes: days of wall time at the fastest step rates; a time
/// or step count beyond it is a typo, not a run.
const MAX_RUN_STEPS: f64 = 1e12;

/// `--threads` at most this many times the cores.
const MAX_THREADS_PER_CORE: usize = 4;

/// Exit codes: 0 ok, 1 failure during a run, 2 bad input.
pub fn main_with(cli: Cli) -> ExitCode {
    match cli.command {
        Command::Run(args) => run(args),
        Command::Check(args) => check(args),
        Command::Plot(args) => crate::plot::main(args),
    }
}

fn bad_input(e: SceneError) -> ExitCode {
    eprintln!("error: {e}");
    ExitCode::from(2)
}

/// Print without panicking when the reader has gone (`grainflow check SCENE | head`).
fn emit(text: &str) {
    use std::io::Write;
    let _ = std::io::stdout().write_all(text.as_bytes());
}

/// The `grainflow check` block of the time step: the systems by set, in order; with a
/// flow, in the three parts of the coupled step: the first half of every step, the fluid
/// step (with its coupling when the scene has particles) and the second half.
fn schedule_report(step: &CoupledStep, coupled: bool) -> String {
    let mut out = String::new();
    let with_flow = step.systems.iter().any(|(set, _)| FLUID_STEP.contains(set));
    let n_s = step.substeps;
    let (header, parts) = match (with_flow, coupled) {
        (false, _) => ("schedule (one step, in order):".to_string(), None),
        (true, false) => (
            "schedule (one step, in order; the fluid step runs in the steps that reach the next fluid time):".to_string(),
            Some([
                "every step, first half",
                "fluid step, in the steps that reach the next fluid time",
                "every step, second half",
            ]),
        ),
        (true, true) => (
            format!("schedule (one fluid step, in order: the fluid step and its coupling, then n_s = {n_s} DEM substeps; the first substep runs the fluid step between its two halves):"),
            Some([
                "every DEM substep, first half",
                "fluid step and its coupling, in the first DEM substep of each fluid step",
                "every DEM substep, second half",
            ]),
        ),
    };
    let _ = writeln!(out, "{header}");
    let (mut last_set, mut last_part) = (None, None);
    for (set, name) in &step.systems {
        if let Some([first, fluid, second]) = parts {
            let part = if DEM_FIRST_HALF.contains(set) {
                first
            } else if FLUID_STEP.contains(set) {
                fluid
            } else {
                second
            };
            if last_part != Some(part) {
                let _ = writeln!(out, "  [{part}]");
                last_part = Some(part);
            }
        }
        if last_set != Some(*set) {
            let _ = writeln!(out, "  {set:?}");
            last_set = Some(*set);
        }
        let _ = writeln!(out, "    {name}");
    }
    out
}

fn check(args: CheckArgs) -> ExitCode {
    let mut out = String::new();
    let scene = match scene::load(&args.scene, &args.set) {
        Ok(s) => s,
        Err(e) => return bad_input(e),
    };
    let dt = scene.simulation.dt;
    let allowed = scene.simulation.allow_unstable_dt;
    let mut probe = scene.clone();
    probe.simulation.allow_unstable_dt = true;
    let sim = match Simulation::new(probe, &args.scene, None) {
        Ok(s) => s,
        Err(e) => return bad_input(e),
    };
    let p = sim.world.resource::<grainflow_components::Particles>();
    let _ = writeln!(out, "scene      {}", args.scene.display());
    let _ = writeln!(
        out,
        "particles  {} placed, {} by inflow",
        p.len(),
        scene.inflows.iter().map(|i| i.total).sum::<u64>()
    );
    let _ = writeln!(
        out,
        "materials  {}",
        scene
            .materials
            .iter()
            .map(|m| m.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    );
    let _ = writeln!(out, "walls      {}", scene.walls.len());
    let needed = crate::memory::total_bytes(&crate::memory::scene_memory(&scene));
    let _ = writeln!(
        out,
        "memory     at least {} for the particles and the fluid grid{}",
        crate::memory::gigabytes(needed),
        crate::memory::available_memory().map_or(String::new(), |a| format!(
            " ({} available)",
            crate::memory::gigabytes(a)
        ))
    );
    let _ = writeln!(
        out,
        "integrator {:?}, dt = {dt:.3e} s, end_time = {} s ({} steps)",
        scene.simulation.integrator,
        scene.simulation.end_time,
        (scene.simulation.end_time / dt).round()
    );
    if sim
        .world
        .contains_resource::<grainflow_components::PredictAhead>()
    {
        let _ = writeln!(
            out,
            "           the corrector also predicts the next step in its pass (not in the last step, nor in steps whose end is written)"
        );
    }
    out.push_str(&schedule_report(
        &sim.coupled_step,
        sim.world
            .contains_resource::<grainflow_components::Coupling>(),
    ));
    if let Some(f) = &scene.fluid {
        match crate::fluid::fluid_grid(f, &args.scene) {
            Ok(Some(grid)) => {
                out.push_str(&crate::fluid::check_report(f, &grid));
                if let Some(flow) = sim
                    .world
                    .get_resource::<grainflow_systems::fluid::FluidFlow>()
                {
                    let _ = writeln!(
                        out,
                        "  runaway bound: a flow velocity above {} x {:.3e} stops the run (the scene's velocity scale: boundary speeds, sqrt(|f| L) of the body force, sqrt(|g| L), nu / L; or that multiple of the fastest particle surface)",
                        grainflow_systems::fluid::RUNAWAY_FACTOR,
                        flow.velocity_scale
                    );
                }
                if let Some(c) = sim.world.get_resource::<grainflow_components::Coupling>() {
                    let (n_s, dt_d) = scene.subcycling.expect("coupled scene");
                    let _ = writeln!(
                        out,
                        "coupling   force {:?} ({} Lebedev points), blending alpha = {}; subcycles n_s = int(dt_F / dt_D) + 1 = {n_s} (dt_D = {dt_d:e} s asked, dt_D' = dt_F / n_s = {:e} s)",
                        c.method,
                        c.rule.weight.len(),
                        c.alpha.map_or("off".to_string(), |a| a.to_string()),
                        scene.simulation.dt
                    );
                    let p = sim.world.resource::<grainflow_components::Particles>();
                    let h = grid.h();
                    let cell = h[0].max(h[1]).max(h[2]);
                    let d_min = 2.0 * p.radius.iter().copied().fold(f64::INFINITY, f64::min);
                    let _ = writeln!(
                        out,
                        "  particle update {:?}; smallest diameter {:.2} cells",
                        c.update,
                        d_min / cell
                    );
                    if d_min < 2.0 * cell {
                        // measured: the cavity case at 0.5 cells per diameter loses its
                        // contacts within 0.015 s; at 1 cell it runs (docs/seed-cases.md)
                        let _ = writeln!(
                            out,
                            "warning: the smallest particle spans {:.2} fluid cells: below about 2 the fluid grid hardly sees it, and below 1 coupled runs have failed (raise fluid.level)",
                            d_min / cell
                        );
                    }
                    let held = sim.world.get_resource::<grainflow_components::Clamped>();
                    if let Some(tau) = crate::observables::shortest_response_time(p, held, c) {
                        let dt_f = f.dt.unwrap_or(0.0);
                        let _ = writeln!(
                            out,
                            "  explicit coupling: shortest particle response time tau = (m + rho_f V / 2) / (6 pi mu r) = {tau:.3e} s, dt_F / tau = {:.3} (the held force overshoots near 1: a settling sphere with rho / rho_f = 2 ran away at dt_F / tau = 0.45 and is stable at 0.045, tests/coupling.rs)",
                            dt_f / tau
                        );
                    }
                    if let Some(lub) = sim
                        .world
                        .get_resource::<grainflow_components::Lubrication>()
                    {
                        // the smallest sphere at the roughness gap damps the fastest
                        let rate = (0..p.len())
                            .map(|i| {
                                grainflow_systems::coupling::lubrication::largest_damping_rate(
                                    lub,
                                    p.radius[i],
                                    p.mass(i),
                                )
                            })
                            .fold(0.0, f64::max);
                        let _ = writeln!(
                            out,
                            "  lubrication below a gap of {:.3e} m (roughness {:.3e} m): damping rate up to 6 pi mu R*^2 / (s_r m*) = {rate:.3e} /s, DEM dt x rate = {:.3} (explicit: stable below 2)",
                            lub.range,
                            lub.roughness,
                            scene.simulation.dt * rate
                        );
                    }
                }
            }
            Ok(None) => {
                let _ = writeln!(
                    out,
                    "fluid      rho_f = {} (buoyancy only, no flow grid)",
                    f.density
                );
            }
            Err(e) => return bad_input(e),
        }
    }
    let mut verdict = ExitCode::SUCCESS;
    match &sim.estimate {
        Some(est) => {
            let _ = writeln!(out, "stable time step:");
            let _ = writeln!(out, "  Rayleigh time step          {:.3e} s", est.rayleigh);
            let _ = writeln!(
                out,
                "  Hertz contact time          {:.3e} s (impact speed {:.3} m/s)",
                est.contact_time, est.impact_speed
            );
            let _ = writeln!(out, "  limit min(0.4 dt_R, t_c/10) {:.3e} s", est.limit);
            let _ = writeln!(
                out,
                "  recommended (0.2 dt_R, t_c/20) {:.3e} s",
                est.recommended
            );
            if dt > est.limit {
                if allowed {
                    let _ = writeln!(out, "warning: dt = {dt:.3e} s exceeds the stable limit {:.3e} s (allowed by simulation.allow_unstable_dt)", est.limit);
                } else {
                    eprintln!(
                        "error: {}: field `simulation.dt`: dt = {dt:.3e} s exceeds the stable limit {:.3e} s; expected dt <= {:.3e} or simulation.allow_unstable_dt = true",
                        args.scene.display(),
                        est.limit,
                        est.limit
                    );
                    verdict = ExitCode::from(2);
                }
            } else if dt > est.recommended {
                let _ = writeln!(out, "warning: dt = {dt:.3e} s is above the recommended {:.3e} s: contacts are resolved with few steps", est.recommended);
            } else {
                let _ = writeln!(out, "  dt = {dt:.3e} s is within the recommended step");
            }
        }
        None => {
            let _ = writeln!(out, "stable time step: no particles");
        }
    }
    emit(&out);
    verdict
}

/// The file of `--trace`, created before the run starts: a path in a missing directory,
/// or a directory, is bad input.
fn create_trace_file(scene: &Path, trace: &Path) -> Result<std::fs::File, SceneError> {
    std::fs::File::create(trace).map_err(|e| SceneError {
        file: scene.to_path_buf(),
        field: "--trace".into(),
        message: format!(
            "cannot create the trace file {}: {e}; expected a file path in an existing directory",
            trace.display()
        ),
    })
}

fn init_tracing(trace: Option<std::fs::File>) -> Option<tracing_chrome::FlushGuard> {
    use tracing_subscriber::filter::{filter_fn, FilterExt};
    use tracing_subscriber::prelude::*;
    let filter =
        tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| "info".into());
    // The log lines take events only: with no layer asking for spans (no `--trace`), the
    // systems' spans are disabled at their call sites and cost nothing per step.
    // Colour only on a terminal: a log redirected to a file or a pipe stays plain text.
    let fmt = tracing_subscriber::fmt::layer()
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .with_target(false)
        .with_filter(filter.and(filter_fn(|meta| meta.is_event())));
    match trace {
        Some(file) => {
            let (chrome, guard) = tracing_chrome::ChromeLayerBuilder::new()
                .writer(file)
                .include_args(true)
                .build();
            tracing_subscriber::registry().with(fmt).with(chrome).init();
            Some(guard)
        }
        None => {
            tracing_subscriber::registry().with(fmt).init();
            None
        }
    }
}

fn run(args: RunArgs) -> ExitCode {
    let trace = match args.trace.as_deref() {
        Some(path) => match create_trace_file(&args.scene, path) {
            Ok(file) => Some(file),
            Err(e) => return bad_input(e),
        },
        None => None,
    };
    let _guard = init_tracing(trace);
    let scene = match scene::load(&args.scene, &args.set) {
        Ok(s) => s,
        Err(e) => return bad_input(e),
    };
    let dt = scene.simulation.dt;
    let (steps, steps_from) = match (args.steps, args.until) {
        (Some(n), _) => (n as f64, "--steps"),
        (None, Some(t)) if t.is_finite() && t >= 0.0 => ((t / dt).round(), "--until"),
        (None, Some(t)) => {
            return bad_input(SceneError {
                file: args.scene.clone(),
                field: "--until".into(),
                message: format!("expected a time >= 0, got {t}"),
            })
        }
        (None, None) => (
            (scene.simulation.end_time / dt).round(),
            "simulation.end_time",
        ),
    };
    if steps > MAX_RUN_STEPS {
        return bad_input(SceneError {
            file: args.scene.clone(),
            field: steps_from.into(),
            message: format!(
                "{steps:.3e} steps of dt = {dt:.3e} s; expected at most {MAX_RUN_STEPS:e} steps in one run"
            ),
        });
    }
    let steps = steps as u64;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let max_threads = MAX_THREADS_PER_CORE * cores;
    let threads = args.threads.unwrap_or(cores);
    if !(1..=max_threads).contains(&threads) {
        return bad_input(SceneError {
            file: args.scene.clone(),
            field: "--threads".into(),
            message: format!(
                "expected 1 to {max_threads} ({MAX_THREADS_PER_CORE} x the {cores} cores of this machine), got {threads}"
            ),
        });
    }
    let out_dir = args
        .out
        .clone()
        .unwrap_or_else(|| default_out_dir(&args.scene));
    let interval = scene.simulation.output_interval;
    let pool = match rayon::ThreadPoolBuilder::new().num_threads(threads).build() {
        Ok(p) => p,
        Err(e) => {
            eprintln!("error: cannot start {threads} threads: {e}");
            return ExitCode::from(1);
        }
    };
    pool.install(|| {
        let mut sim = match Simulation::new(scene, &args.scene, Some((&out_dir, interval))) {
            Ok(s) => s,
            Err(e) => return bad_input(e),
        };
        tracing::info!(
            "{}: {} particles, {} steps of {:.3e} s on {threads} threads -> {}",
            args.scene.display(),
            sim.world.resource::<grainflow_components::Particles>().len(),
            steps,
            dt,
            out_dir.display()
        );
        let report = sim.run(steps);
        let summary = sim.summary(&report, threads);
        let summary_path = out_dir.join("summary.json");
        if let Err(e) = std::fs::write(&summary_path, serde_json::to_string_pretty(&summary).expect("json") + "\n") {
            eprintln!("error: cannot write {}: {e}", summary_path.display());
            return ExitCode::from(1);
        }
        let mut out = String::new();
        let rate = report.particle_steps / report.wall_seconds.max(1e-12);
        let sim_time = sim.world.resource::<grainflow_components::SimClock>().time;
        let _ = writeln!(
            out,
            "{} steps in {:.2} s: {:.3e} particle-steps/s ({:.3e} per core); {:.1} bytes/particle of state",
            report.steps,
            report.wall_seconds,
            rate,
            rate / threads as f64,
            sim.bytes_per_particle()
        );
        let end = sim.scene.simulation.end_time;
        let dt = sim.scene.simulation.dt;
        if sim_time + 0.5 * dt < end && report.failure.is_none() {
            let n_now = sim.world.resource::<grainflow_components::Particles>().len();
            let ahead = sim.particle_steps_until(end, n_now);
            if ahead > 0.0 && rate > 0.0 {
                let _ = writeln!(
                    out,
                    "projected wall time to end_time = {end} s: {:.0} s more ({:.3e} particle-steps, inflows included, at the measured rate)",
                    ahead / rate,
                    ahead
                );
            } else {
                // No particles (a flow only): project by steps.
                let steps = ((end - sim_time) / dt).round();
                let _ = writeln!(
                    out,
                    "projected wall time to end_time = {end} s: {:.0} s more ({steps} steps at the measured rate)",
                    steps * report.wall_seconds / report.steps.max(1) as f64
                );
            }
        }
        emit(&out);
        match report.failure {
            Some(f) => {
                eprintln!("error: {f}; output up to the last good frame kept in {}", out_dir.display());
                ExitCode::from(1)
            }
            None => ExitCode::SUCCESS,
        }
    })
}
