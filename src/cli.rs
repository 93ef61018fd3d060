//! The `grainflow` command line: `run`, `check` and `plot` (`src/plot.rs`).
use std::fmt::Write as _;
use std::io::IsTerminal as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};

use grainflow_systems::schedule::{DEM_FIRST_HALF, FLUID_STEP};
use grainflow_systems::CoupledStep;

use std::sync::atomic::{AtomicI32, Ordering};

use crate::checkpoint::SavedScene;
use crate::run::{default_out_dir, RunControl, Simulation};
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
    /// Continue a run from its last checkpoint, appending to its output.
    Resume(ResumeArgs),
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
    /// fluid.xdmf, coupling.csv, sinks.csv, summary.json) are removed first; other files are kept.
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
    /// Write checkpoint.h5 at every multiple of this simulated time (a number, s) or
    /// after this much wall-clock time (with a unit: 90s, 30min, 2h); may be repeated.
    #[arg(long = "checkpoint-every", value_name = "T")]
    pub checkpoint_every: Vec<String>,
    /// At the end, write the particles to FILE as a LAMMPS `atom_style sphere` data file
    /// (a prepared bed, read back by a scene's `[[lammps]]` source).
    #[arg(long = "write-data", value_name = "FILE")]
    pub write_data: Option<PathBuf>,
}

#[derive(Args, Debug)]
pub struct ResumeArgs {
    /// Run directory holding checkpoint.h5 (and the run's particles.h5).
    pub dir: PathBuf,
    /// Run until this simulated time, s (default: the scene's end_time).
    #[arg(long, conflicts_with = "steps")]
    pub until: Option<f64>,
    /// Run this many more steps.
    #[arg(long)]
    pub steps: Option<u64>,
    /// Worker threads, 1 to 4 x the cores (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Checkpoint interval, as for `run`.
    #[arg(long = "checkpoint-every", value_name = "T")]
    pub checkpoint_every: Vec<String>,
    /// At the end, write the particles to FILE as a LAMMPS `atom_style sphere` data file
    /// (a prepared bed, read back by a scene's `[[lammps]]` source).
    #[arg(long = "write-data", value_name = "FILE")]
    pub write_data: Option<PathBuf>,
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
        Command::Resume(args) => resume(args),
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
    if let Some(clumps) = sim.world.get_resource::<grainflow_components::Clumps>() {
        let by_inflow: u64 = scene
            .inflows
            .iter()
            .filter(|i| i.clump.is_some())
            .map(|i| i.total)
            .sum();
        let members: usize = (0..clumps.len())
            .map(|b| clumps.types[clumps.kind[b] as usize].members.len())
            .sum();
        let _ = writeln!(
            out,
            "clumps     {} placed ({members} of the particles are their members), {by_inflow} by inflow; types: {}",
            clumps.len(),
            clumps
                .types
                .iter()
                .map(|t| format!(
                    "{} ({} members, mass {:.4e} kg, principal inertia [{:.4e}, {:.4e}, {:.4e}] kg m^2)",
                    t.name,
                    t.members.len(),
                    t.mass,
                    t.inertia.x,
                    t.inertia.y,
                    t.inertia.z
                ))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
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
    let target = match run_steps(
        &args.scene,
        dt,
        scene.simulation.end_time,
        0,
        args.steps,
        args.until,
    ) {
        Ok(t) => t,
        Err(e) => return bad_input(e),
    };
    let threads = match thread_count(&args.scene, args.threads) {
        Ok(t) => t,
        Err(e) => return bad_input(e),
    };
    let (every_time, every_wall) = match checkpoint_intervals(&args.scene, &args.checkpoint_every) {
        Ok(e) => e,
        Err(e) => return bad_input(e),
    };
    let out_dir = args
        .out
        .clone()
        .unwrap_or_else(|| default_out_dir(&args.scene));
    let interval = scene.simulation.output_interval;
    let text = std::fs::read_to_string(&args.scene).unwrap_or_default();
    let scene_path = std::fs::canonicalize(&args.scene).unwrap_or_else(|_| args.scene.clone());
    let pool = match rayon::ThreadPoolBuilder::new().num_threads(threads).build() {
        Ok(p) => p,
        Err(e) => {
            eprintln!("error: cannot start {threads} threads: {e}");
            return ExitCode::from(1);
        }
    };
    pool.install(|| {
        let sim = match Simulation::new(scene, &args.scene, Some((&out_dir, interval))) {
            Ok(s) => s,
            Err(e) => return bad_input(e),
        };
        let control = RunControl {
            every_time,
            every_wall,
            dir: Some(out_dir.clone()),
            scene: Some(SavedScene {
                text,
                path: scene_path,
                overrides: args.set.clone(),
            }),
            interrupt: Some(install_signal_handlers()),
            ..Default::default()
        };
        execute(
            sim,
            target,
            threads,
            &out_dir,
            &args.scene,
            control,
            args.write_data.as_deref(),
        )
    })
}

/// Continue the run of `args.dir` from its checkpoint.
fn resume(args: ResumeArgs) -> ExitCode {
    let _guard = init_tracing(None);
    let checkpoint = match crate::checkpoint::read_checkpoint(&args.dir) {
        Ok(c) => c,
        Err(message) => {
            return bad_input(SceneError {
                file: args.dir.join(crate::checkpoint::CHECKPOINT_FILE),
                field: String::new(),
                message,
            })
        }
    };
    let file = args.dir.join(crate::checkpoint::CHECKPOINT_FILE);
    let (every_time, every_wall) = match checkpoint_intervals(&file, &args.checkpoint_every) {
        Ok(e) => e,
        Err(e) => return bad_input(e),
    };
    let threads = match thread_count(&file, args.threads) {
        Ok(t) => t,
        Err(e) => return bad_input(e),
    };
    let pool = match rayon::ThreadPoolBuilder::new().num_threads(threads).build() {
        Ok(p) => p,
        Err(e) => {
            eprintln!("error: cannot start {threads} threads: {e}");
            return ExitCode::from(1);
        }
    };
    pool.install(|| {
        let sim = match Simulation::resume(&args.dir, &checkpoint) {
            Ok(s) => s,
            Err(e) => return bad_input(e),
        };
        let sim_scene = &sim.scene.simulation;
        let target = match run_steps(
            &file,
            sim_scene.dt,
            sim_scene.end_time,
            checkpoint.step,
            args.steps,
            args.until,
        ) {
            Ok(t) => t,
            Err(e) => return bad_input(e),
        };
        tracing::info!(
            "resuming {} at step {} (t = {} s)",
            args.dir.display(),
            checkpoint.step,
            checkpoint.time
        );
        let control = RunControl {
            every_time,
            every_wall,
            dir: Some(args.dir.clone()),
            scene: Some(SavedScene {
                text: checkpoint.scene.text.clone(),
                path: checkpoint.scene.path.clone(),
                overrides: checkpoint.scene.overrides.clone(),
            }),
            interrupt: Some(install_signal_handlers()),
            ..Default::default()
        };
        execute(
            sim,
            target,
            threads,
            &args.dir,
            &file,
            control,
            args.write_data.as_deref(),
        )
    })
}

/// Steps to run from `step_now`: `--steps N`, or up to `--until T`, or to `end_time`;
/// at most `MAX_RUN_STEPS`.
fn run_steps(
    file: &Path,
    dt: f64,
    end_time: f64,
    step_now: u64,
    steps: Option<u64>,
    until: Option<f64>,
) -> Result<u64, SceneError> {
    let err = |field: &str, message: String| SceneError {
        file: file.to_path_buf(),
        field: field.into(),
        message,
    };
    let (steps, steps_from) = match (steps, until) {
        (Some(n), _) => (n as f64, "--steps"),
        (None, Some(t)) if t.is_finite() && t >= 0.0 => {
            (((t / dt).round() - step_now as f64).max(0.0), "--until")
        }
        (None, Some(t)) => return Err(err("--until", format!("expected a time >= 0, got {t}"))),
        (None, None) => (
            ((end_time / dt).round() - step_now as f64).max(0.0),
            "simulation.end_time",
        ),
    };
    if steps > MAX_RUN_STEPS {
        return Err(err(
            steps_from,
            format!("{steps:.3e} steps of dt = {dt:.3e} s; expected at most {MAX_RUN_STEPS:e} steps in one run"),
        ));
    }
    Ok(steps as u64)
}

/// `--threads`, 1 to [`MAX_THREADS_PER_CORE`] x the cores (default: the cores).
fn thread_count(file: &Path, threads: Option<usize>) -> Result<usize, SceneError> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let max_threads = MAX_THREADS_PER_CORE * cores;
    let threads = threads.unwrap_or(cores);
    if (1..=max_threads).contains(&threads) {
        Ok(threads)
    } else {
        Err(SceneError {
            file: file.to_path_buf(),
            field: "--threads".into(),
            message: format!(
                "expected 1 to {max_threads} ({MAX_THREADS_PER_CORE} x the {cores} cores of this machine), got {threads}"
            ),
        })
    }
}

/// The `--checkpoint-every` values: simulated seconds (a plain number) and wall-clock
/// seconds (a number with `s`, `min` or `h`), each finite and > 0; the last of each kind
/// counts.
fn checkpoint_intervals(
    file: &Path,
    values: &[String],
) -> Result<(Option<f64>, Option<f64>), SceneError> {
    let mut sim = None;
    let mut wall = None;
    for v in values.iter().flat_map(|v| v.split(',')) {
        let v = v.trim();
        let (number, unit) = [("min", 60.0), ("h", 3600.0), ("s", 1.0)]
            .iter()
            .find_map(|&(u, f)| v.strip_suffix(u).map(|n| (n, Some(f))))
            .unwrap_or((v, None));
        match number.trim().parse::<f64>() {
            Ok(x) if x.is_finite() && x > 0.0 => match unit {
                Some(f) => wall = Some(x * f),
                None => sim = Some(x),
            },
            _ => {
                return Err(SceneError {
                    file: file.to_path_buf(),
                    field: "--checkpoint-every".into(),
                    message: format!(
                        "expected a simulated time > 0 (e.g. 0.5) or a wall-clock interval > 0 with a unit (90s, 30min, 2h), got `{v}`"
                    ),
                })
            }
        }
    }
    Ok((sim, wall))
}

/// The signal number of the first SIGINT or SIGTERM received, 0 before.
static SIGNAL_RECEIVED: AtomicI32 = AtomicI32::new(0);

extern "C" fn on_signal(signal: i32) {
    SIGNAL_RECEIVED.store(signal, Ordering::SeqCst);
}

extern "C" {
    /// The C library's `signal(2)`.
    fn signal(signum: i32, handler: extern "C" fn(i32)) -> usize;
}

const SIGINT: i32 = 2;
const SIGTERM: i32 = 15;

/// Catch SIGINT and SIGTERM: the run finishes its step, checkpoints and stops
/// (exit 128 + the signal).
fn install_signal_handlers() -> &'static AtomicI32 {
    // SAFETY: the handler only stores into an atomic, which is async-signal-safe.
    unsafe {
        signal(SIGINT, on_signal);
        signal(SIGTERM, on_signal);
    }
    &SIGNAL_RECEIVED
}

/// Run `sim` for `steps` under `control`, write `summary.json` into `out_dir` (and the
/// particles into the data file `write_data`) and report; `label` names the scene (or
/// checkpoint) in messages.
fn execute(
    mut sim: Simulation,
    steps: u64,
    threads: usize,
    out_dir: &Path,
    label: &Path,
    mut control: RunControl,
    write_data: Option<&Path>,
) -> ExitCode {
    {
        let dt = sim.scene.simulation.dt;
        tracing::info!(
            "{}: {} particles, {} steps of {:.3e} s on {threads} threads -> {}",
            label.display(),
            sim.world
                .resource::<grainflow_components::Particles>()
                .len(),
            steps,
            dt,
            out_dir.display()
        );
        let report = sim.run_with(steps, &mut control);
        let summary = sim.summary(&report, threads);
        let summary_path = out_dir.join("summary.json");
        if let Err(e) = std::fs::write(
            &summary_path,
            serde_json::to_string_pretty(&summary).expect("json") + "\n",
        ) {
            eprintln!("error: cannot write {}: {e}", summary_path.display());
            return ExitCode::from(1);
        }
        if let Some(sinks) = sim.world.get_resource::<grainflow_components::Sinks>() {
            if let Err(e) = crate::sinks::write_csv(sinks, out_dir) {
                eprintln!("error: {e}");
                return ExitCode::from(1);
            }
        }
        if let Some(file) = write_data {
            let written = match (
                sim.world.get_resource::<grainflow_components::Particles>(),
                sim.world.get_resource::<grainflow_components::Materials>(),
            ) {
                (Some(p), Some(m)) => crate::lammps::write_data(file, p, m),
                _ => Err(format!(
                    "cannot write {}: the scene has no particles",
                    file.display()
                )),
            };
            if let Err(e) = written {
                eprintln!("error: {e}");
                return ExitCode::from(1);
            }
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
            let n_now = sim
                .world
                .resource::<grainflow_components::Particles>()
                .len();
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
        if report.checkpoints > 0 {
            let _ = writeln!(
                out,
                "{} checkpoints in {:.3} s ({:.1} MB of state each) -> {}",
                report.checkpoints,
                report.checkpoint_seconds,
                report.checkpoint_bytes as f64 / 1e6,
                out_dir.join(crate::checkpoint::CHECKPOINT_FILE).display()
            );
        }
        emit(&out);
        match (report.failure, report.interrupted) {
            (Some(f), _) => {
                eprintln!(
                    "error: {f}; output up to the last good frame kept in {}",
                    out_dir.display()
                );
                ExitCode::from(1)
            }
            (None, Some(signal)) => {
                eprintln!(
                    "interrupted by signal {signal} at t = {sim_time} s; continue with: grainflow resume {}",
                    out_dir.display()
                );
                ExitCode::from((128 + signal) as u8)
            }
            (None, None) => ExitCode::SUCCESS,
        }
    }
}
