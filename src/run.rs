//! A simulation: the world built from a scene, its start-up and step schedules, the run
//! loop with progress reporting, and the run report (`summary.json`).
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicI32, Ordering};
use std::time::Instant;

use bevy_ecs::prelude::*;
use grainflow_components::{
    Clamped, ContactHistory, EnergyBalance, GearState, Materials, Particles, PerParticle,
    PredictAhead, Rotation, RunHealth, SimClock, VerletList, VerletState, WallHistory,
};
use grainflow_systems::fluid::FluidFlow;

use crate::checkpoint::{write_checkpoint, Checkpoint, SavedScene, CHECKPOINT_FILE};
use grainflow_systems::monitor::kinetic_energy;
use grainflow_systems::schedule::{build_startup, corrector_may_predict_ahead, Slot};
use grainflow_systems::{CoupledStep, Phase, StepSet, SystemEntry};

use crate::observables::{observables, record_coupling, CouplingLog};
use crate::output::{write_particles, ParticleOutput};
use crate::scene::{Scene, SceneError};
use crate::stability::{self, StepEstimate};

/// Writers and recorders registered by the application into the `Output` set.
const OUTPUT_ENTRIES: &[SystemEntry] = &[
    SystemEntry {
        name: "record_coupling",
        set: StepSet::Output,
        phase: Phase::Step,
        wanted: |w| w.contains_resource::<CouplingLog>(),
        add: |s, slot: Slot| {
            s.add_systems(record_coupling.in_set(slot));
        },
    },
    SystemEntry {
        name: "write_particles",
        set: StepSet::Output,
        phase: Phase::Step,
        wanted: |w| w.contains_resource::<ParticleOutput>(),
        add: |s, slot: Slot| {
            s.add_systems(write_particles.in_set(slot));
        },
    },
];

pub struct Simulation {
    pub scene: Scene,
    pub world: World,
    /// The time step: one fluid step, the coupling, then n_s DEM substeps, run one DEM
    /// substep at a time.
    pub coupled_step: CoupledStep,
    pub startup_schedule: Schedule,
    pub estimate: Option<StepEstimate>,
    started: bool,
}

/// Checkpoints and interruption of a run ([`Simulation::run_with`]).
#[derive(Default)]
pub struct RunControl {
    /// Checkpoint at every multiple of this simulated time, s.
    pub every_time: Option<f64>,
    /// Checkpoint after this much wall-clock time since the last, s.
    pub every_wall: Option<f64>,
    /// Where checkpoints go (the run directory), and the scene they record.
    pub dir: Option<PathBuf>,
    pub scene: Option<SavedScene>,
    /// Set (to the signal number) by a signal handler: the run stops after a checkpoint.
    pub interrupt: Option<&'static AtomicI32>,
    /// The signal that stopped the run, if one did.
    pub interrupted: Option<i32>,
    /// Checkpoints written, their total write time and the size of the last.
    pub checkpoints: u32,
    pub checkpoint_seconds: f64,
    pub checkpoint_bytes: usize,
}

/// How a run ended.
#[derive(Debug, Clone)]
pub struct RunReport {
    pub steps: u64,
    pub wall_seconds: f64,
    pub particle_steps: f64,
    pub failure: Option<String>,
    /// The signal that stopped the run after its checkpoint, if one did.
    pub interrupted: Option<i32>,
    /// Checkpoints written, their total write time (s) and the bytes of state of the last.
    pub checkpoints: u32,
    pub checkpoint_seconds: f64,
    pub checkpoint_bytes: usize,
}

impl Simulation {
    /// Build the world and schedules of `scene`; with `output` the particle writer joins
    /// the `Output` set.
    pub fn new(
        scene: Scene,
        path: &Path,
        output: Option<(&Path, f64)>,
    ) -> Result<Self, SceneError> {
        let mut world = crate::build::world_from_scene(&scene, path)?;
        let estimate = {
            let particles = world.resource::<Particles>();
            stability::estimate(&scene, particles, &world.resource::<Materials>().list)
        };
        if let Some(est) = &estimate {
            if scene.simulation.dt > est.limit && !scene.simulation.allow_unstable_dt {
                return Err(SceneError {
                    file: path.to_path_buf(),
                    field: "simulation.dt".into(),
                    message: format!(
                        "dt = {:.3e} s exceeds the stable estimate {:.3e} s (min of 0.4 x Rayleigh {:.3e} s and Hertz contact time / 10 = {:.3e} s at {:.3} m/s); \
                         expected dt <= {:.3e}, or set simulation.allow_unstable_dt = true",
                        scene.simulation.dt, est.limit, est.rayleigh, est.contact_time / 10.0, est.impact_speed, est.limit
                    ),
                });
            }
        }
        if let Some((dir, interval)) = output {
            let out = ParticleOutput::create(dir, interval).map_err(|m| SceneError {
                file: path.to_path_buf(),
                field: "--out".into(),
                message: m,
            })?;
            world.insert_resource(out);
        }
        if world.contains_resource::<grainflow_components::Coupling>() {
            let log = match output {
                Some((dir, _)) => {
                    CouplingLog::writing_to(dir.join("coupling.csv")).map_err(|m| SceneError {
                        file: path.to_path_buf(),
                        field: "--out".into(),
                        message: m,
                    })?
                }
                None => CouplingLog::default(),
            };
            world.insert_resource(log);
        }
        Ok(Self::assemble(scene, world, estimate, false))
    }

    /// The simulation of `world` with its schedules; `started` skips the start-up (a
    /// resumed run).
    fn assemble(
        scene: Scene,
        mut world: World,
        estimate: Option<StepEstimate>,
        started: bool,
    ) -> Self {
        if corrector_may_predict_ahead(&world) {
            world.insert_resource(PredictAhead::default());
        }
        let coupled_step = CoupledStep::new(&world, OUTPUT_ENTRIES);
        let startup_schedule = build_startup(&world);
        Self {
            scene,
            world,
            coupled_step,
            startup_schedule,
            estimate,
            started,
        }
    }

    /// The run of `dir` at its checkpoint: the world built from the saved scene, the
    /// saved state put in, the particle writer appending to `dir/particles.h5` after the
    /// frames written before the checkpoint.
    pub fn resume(dir: &Path, checkpoint: &Checkpoint) -> Result<Self, SceneError> {
        let saved = &checkpoint.scene;
        let bad = |message: String| SceneError {
            file: dir.join(CHECKPOINT_FILE),
            field: String::new(),
            message,
        };
        let scene = crate::scene::parse(&saved.text, &saved.path, &saved.overrides)?;
        let mut world = crate::build::world_from_scene(&scene, &saved.path)?;
        let out = ParticleOutput::reopen(dir, scene.simulation.output_interval).map_err(bad)?;
        world.insert_resource(out);
        if world.contains_resource::<grainflow_components::Coupling>() {
            // its records up to the checkpoint are written again when it is restored
            world.insert_resource(CouplingLog {
                csv: Some(dir.join("coupling.csv")),
                ..CouplingLog::default()
            });
        }
        let mut sim = Self::assemble(scene, world, None, true);
        checkpoint.restore(&mut sim.world).map_err(bad)?;
        let world = &sim.world;
        if let (Some(out), Some(flow)) = (
            world.get_resource::<ParticleOutput>(),
            world.get_resource::<FluidFlow>(),
        ) {
            out.write_fluid_xdmf(flow.solver.grid()).map_err(bad)?;
        }
        let estimate = stability::estimate(
            &sim.scene,
            sim.world.resource::<Particles>(),
            &sim.world.resource::<Materials>().list,
        );
        sim.estimate = estimate;
        Ok(sim)
    }

    /// Forces at t = 0 and integrator start values; writes the first frame.
    pub fn start(&mut self) {
        if self.started {
            return;
        }
        self.startup_schedule.run(&mut self.world);
        self.started = true;
        let clock = *self.world.resource::<SimClock>();
        if let Some(mut out) = self.world.remove_resource::<ParticleOutput>() {
            out.next_time = out.interval;
            if let Err(e) = out.write_frame(
                self.world.resource::<Particles>(),
                self.world.get_resource::<grainflow_components::Clumps>(),
                self.world.get_resource::<FluidFlow>(),
                &clock,
            ) {
                out.error = Some(e);
            }
            self.world.insert_resource(out);
        }
    }

    /// One DEM step; afterwards the particles hold the corrected state of its end.
    pub fn step(&mut self) {
        self.step_predicting_ahead(false);
    }

    /// One DEM step in which, with `ahead` and a world that has [`PredictAhead`], the
    /// corrector also predicts the next step, unless the particle writer reads the state
    /// at the end of this one.
    pub fn step_predicting_ahead(&mut self, ahead: bool) {
        self.start();
        let clock = *self.world.resource::<SimClock>();
        let end = (clock.step + 1) as f64 * clock.dt;
        let written = self
            .world
            .get_resource::<ParticleOutput>()
            .is_some_and(|out| out.due(end, clock.dt));
        if let Some(mut predict) = self.world.get_resource_mut::<PredictAhead>() {
            predict.allowed = ahead && !written;
        }
        self.coupled_step.run_substep(&mut self.world);
    }

    pub fn failure(&self) -> Option<String> {
        let health = self.world.resource::<RunHealth>();
        health
            .failure
            .clone()
            .or_else(|| {
                self.world
                    .get_resource::<ParticleOutput>()
                    .and_then(|o| o.error.clone())
            })
            .or_else(|| {
                self.world
                    .get_resource::<CouplingLog>()
                    .and_then(|l| l.error.clone())
            })
    }

    /// Run `steps` steps (stopping early on failure), showing progress on a terminal
    /// and plain log lines otherwise.
    pub fn run(&mut self, steps: u64) -> RunReport {
        self.run_with(steps, &mut RunControl::default())
    }

    /// [`Simulation::run`] with checkpoints and an interruption flag (`control`): a step
    /// that ends at a checkpoint time, or follows a wall-clock interval or a signal, runs
    /// without predicting ahead and is followed by a checkpoint; after a signal the run
    /// then stops.
    pub fn run_with(&mut self, steps: u64, control: &mut RunControl) -> RunReport {
        let t0 = Instant::now();
        // The pool's other threads spin between the passes of the steps instead of
        // sleeping (systems/src/team.rs).
        let awake = grainflow_systems::team::KeepAwake::start();
        self.start();
        let start_step = self.world.resource::<SimClock>().step;
        let bar = std::io::stderr().is_terminal().then(|| {
            let bar = indicatif::ProgressBar::new(steps);
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "{bar:30} {pos}/{len} steps  {msg}  ETA {eta}",
                )
                .expect("valid template"),
            );
            bar
        });
        let mut last_log = Instant::now();
        let mut particle_steps = 0.0;
        // A state the start-up already found unphysical (particles placed overlapping)
        // fails at step 0, before any step.
        let mut failure = self.failure();
        let checkpoints = control.dir.is_some();
        let dt = self.world.resource::<SimClock>().dt;
        // The next checkpoint time: the first multiple of the interval after now.
        let next_after = |t: f64, every: f64| ((t + 0.5 * dt) / every).floor() * every + every;
        let mut next_checkpoint = control
            .every_time
            .map(|every| next_after(self.world.resource::<SimClock>().time, every));
        let mut last_checkpoint = Instant::now();
        let mut pending = false;
        let mut signal = 0;
        for k in 0..steps {
            if failure.is_some() {
                break;
            }
            awake.rearm();
            particle_steps += self.world.resource::<Particles>().len() as f64;
            let end = (self.world.resource::<SimClock>().step + 1) as f64 * dt;
            let by_time = next_checkpoint.is_some_and(|t| end + 0.5 * dt >= t);
            let checkpoint = checkpoints && (by_time || pending);
            // The last step, and a step before a checkpoint, leave the corrected state.
            self.step_predicting_ahead(k + 1 < steps && !checkpoint);
            if let Some(f) = self.failure() {
                failure = Some(f);
                break;
            }
            if checkpoint {
                if let Err(e) = self.checkpoint(control) {
                    failure = Some(e);
                    break;
                }
                pending = false;
                last_checkpoint = Instant::now();
                if let (true, Some(every)) = (by_time, control.every_time) {
                    next_checkpoint = Some(next_after(end, every));
                }
            }
            if signal != 0 && (checkpoint || !checkpoints) {
                control.interrupted = Some(signal);
                break;
            }
            if control
                .every_wall
                .is_some_and(|w| last_checkpoint.elapsed().as_secs_f64() >= w)
            {
                pending = true;
            }
            if let Some(s) = control
                .interrupt
                .map(|f| f.load(Ordering::SeqCst))
                .filter(|&s| s != 0)
            {
                if signal == 0 {
                    tracing::info!("signal {s}: stopping after the next step's checkpoint");
                }
                signal = s;
                pending = true;
                if !checkpoints || k + 1 == steps {
                    control.interrupted = Some(s);
                    break;
                }
            }
            // The bar moves every second; a plain log line every ten seconds. The
            // message is made only when shown.
            let interval = if bar.is_some() { 1.0 } else { 10.0 };
            if last_log.elapsed().as_secs_f64() > interval || k + 1 == steps {
                let elapsed = t0.elapsed().as_secs_f64();
                let rate = (k + 1) as f64 / elapsed;
                let clock = self.world.resource::<SimClock>();
                let msg = format!(
                    "t = {:.4} s  {:.0} steps/s  {:.3e} particle-steps/s  {} particles",
                    clock.time,
                    rate,
                    particle_steps / elapsed,
                    self.world.resource::<Particles>().len()
                );
                if let Some(bar) = &bar {
                    bar.set_position(k + 1);
                    bar.set_message(msg);
                } else {
                    let eta = (steps - k - 1) as f64 / rate;
                    tracing::info!("step {}/{steps} {msg} ETA {eta:.0} s", k + 1);
                }
                last_log = Instant::now();
            }
        }
        if let Some(bar) = bar {
            bar.finish();
        }
        // A checkpoint of the end, from which the run can be extended (before the frame of
        // the last state, which a longer run would not write).
        if failure.is_none()
            && control.interrupted.is_none()
            && checkpoints
            && control.every_time.or(control.every_wall).is_some()
        {
            if let Err(e) = self.checkpoint(control) {
                failure = Some(e);
            }
        }
        // Last state (unless unhealthy: output stops at the last good frame).
        if failure.is_none() {
            let clock = *self.world.resource::<SimClock>();
            if let Some(mut out) = self.world.remove_resource::<ParticleOutput>() {
                if let Err(e) = out.write_frame(
                    self.world.resource::<Particles>(),
                    self.world.get_resource::<grainflow_components::Clumps>(),
                    self.world.get_resource::<FluidFlow>(),
                    &clock,
                ) {
                    failure = Some(e);
                }
                self.world.insert_resource(out);
            }
        }
        RunReport {
            steps: self.world.resource::<SimClock>().step - start_step,
            wall_seconds: t0.elapsed().as_secs_f64(),
            particle_steps,
            failure,
            interrupted: control.interrupted,
            checkpoints: control.checkpoints,
            checkpoint_seconds: control.checkpoint_seconds,
            checkpoint_bytes: control.checkpoint_bytes,
        }
    }

    /// Write a checkpoint into the control's directory, timed in the control.
    fn checkpoint(&mut self, control: &mut RunControl) -> Result<(), String> {
        let (Some(dir), Some(scene)) = (&control.dir, &control.scene) else {
            return Ok(());
        };
        let t = Instant::now();
        let bytes = write_checkpoint(&mut self.world, scene, dir)?;
        control.checkpoint_seconds += t.elapsed().as_secs_f64();
        control.checkpoints += 1;
        control.checkpoint_bytes = bytes;
        Ok(())
    }

    /// Particle-steps from now to simulated time `end`, with `n_now` particles present and
    /// the scene's inflows adding theirs on schedule.
    pub fn particle_steps_until(&self, end: f64, n_now: usize) -> f64 {
        let clock = self.world.resource::<SimClock>();
        let steps = ((end - clock.time) / clock.dt).max(0.0);
        let inserted_at = |t: f64| -> f64 {
            self.scene
                .inflows
                .iter()
                .map(|f| {
                    let t_in = t.min(f.stop.unwrap_or(f64::INFINITY)) - f.start;
                    if t_in < 0.0 {
                        0.0
                    } else {
                        (f.rate * (t_in + f.interval.unwrap_or(0.01))).min(f.total as f64)
                    }
                })
                .sum()
        };
        // Midpoint rule over 1,000 slices of the remaining time.
        let slices = 1000;
        let now = inserted_at(clock.time);
        (0..slices)
            .map(|k| {
                let t = clock.time + (k as f64 + 0.5) / slices as f64 * (end - clock.time);
                n_now as f64 + (inserted_at(t) - now).max(0.0)
            })
            .sum::<f64>()
            * steps
            / slices as f64
    }

    /// Memory held per particle by the per-particle blocks and the neighbour list, bytes.
    pub fn bytes_per_particle(&self) -> f64 {
        let p = self.world.resource::<Particles>();
        let n = p.len().max(1) as f64;
        let mut rows = p.bytes_per_row() as f64;
        if let Some(g) = self.world.get_resource::<GearState>() {
            rows += g.bytes_per_row() as f64;
        }
        if let Some(v) = self.world.get_resource::<VerletState>() {
            rows += v.bytes_per_row() as f64;
        }
        if let Some(r) = self.world.get_resource::<Rotation>() {
            rows += r.bytes_per_row() as f64;
        }
        if let Some(c) = self.world.get_resource::<Clamped>() {
            rows += c.bytes_per_row() as f64;
        }
        let list = self.world.resource::<VerletList>();
        let list_bytes = [
            &list.start,
            &list.neighbours,
            &list.owner,
            &list.near_end,
            &list.rev_start,
            &list.rev_pairs,
            &list.rev_owner,
        ]
        .iter()
        .map(|v| v.capacity() * 4)
        .sum::<usize>() as f64
            + list
                .reference
                .iter()
                .map(|c| c.capacity() * 8)
                .sum::<usize>() as f64;
        rows + (list_bytes + self.contact_store_bytes()) / n
    }

    /// The `fluid` object of the run report: level, degrees of freedom, steps, wall seconds
    /// per fluid step (mean, median and the first step's), and per sub-problem the multigrid cycles per step, the mean
    /// (geometric) residual reduction per cycle and the wall seconds per step. Null without a fluid grid.
    pub fn fluid_summary(&self) -> serde_json::Value {
        let Some(flow) = self.world.get_resource::<FluidFlow>() else {
            return serde_json::Value::Null;
        };
        let s = &flow.stats;
        let steps = s.steps.max(1) as f64;
        serde_json::json!({
            "level": flow.solver.grid().level,
            "dofs": flow.solver.grid().dofs(),
            "steps": s.steps,
            "dt": flow.dt,
            "mean_step_s": s.seconds / steps,
            "median_step_s": s.median_step_seconds(),
            "first_step_s": s.step_seconds.first().copied().unwrap_or(0.0),
            "momentum": {
                "cycles_per_step": s.momentum_cycles as f64 / steps,
                "mean_reduction_per_cycle": (s.momentum_log_rate / steps).exp(),
                "seconds_per_step": s.momentum_seconds / steps,
            },
            "pressure": {
                "cycles_per_step": s.pressure_cycles as f64 / steps,
                "mean_reduction_per_cycle": (s.pressure_log_rate / steps).exp(),
                "seconds_per_step": s.pressure_seconds / steps,
            },
            "max_divergence": s.max_divergence,
        })
    }

    /// Memory of the contact store (per-pair and per-wall-contact history), bytes.
    pub fn contact_store_bytes(&self) -> f64 {
        let pairs = self
            .world
            .get_resource::<ContactHistory>()
            .map_or(0, |h| h.values.capacity() * 8 + h.pairs.bytes());
        let walls = self.world.get_resource::<WallHistory>().map_or(0, |h| {
            h.values.capacity() * 8
                + h.ids.capacity() * 4
                + h.start.capacity() * 4
                + h.walls.capacity() * 2
        });
        (pairs + walls) as f64
    }

    /// The energy balance of the last check (`energy_monitor`), J; `null` without
    /// particles.
    fn energy_summary(&self) -> serde_json::Value {
        let Some(e) = self.world.get_resource::<EnergyBalance>() else {
            return serde_json::Value::Null;
        };
        serde_json::json!({
            "initial": e.initial,
            "inserted": e.inserted,
            "removed": e.removed,
            "total": e.total(),
            "kinetic": e.kinetic,
            "rotational": e.rotational,
            "potential": e.potential,
            "elastic": e.elastic,
            "dissipated": e.dissipated(),
            "largest_growth": e.largest_growth,
            "largest_growth_step": e.largest_growth_step,
            "scale": e.scale,
            "growth_limit": e.tolerance,
            "enforced": e.enforced,
            "checks": e.checks,
            "checked_step": e.checked_step,
        })
    }

    /// The run report as JSON (`summary.json`).
    pub fn summary(&self, report: &RunReport, threads: usize) -> serde_json::Value {
        let clock = self.world.resource::<SimClock>();
        let health = self.world.resource::<RunHealth>();
        let list = self.world.resource::<VerletList>();
        let n = self.world.resource::<Particles>().len();
        let rate = report.particle_steps / report.wall_seconds.max(1e-12);
        let peak = peak_memory_bytes();
        serde_json::json!({
            "status": match (&report.failure, report.interrupted) {
                (Some(_), _) => "failed",
                (None, Some(_)) => "interrupted",
                (None, None) => "completed",
            },
            "checkpoints": {
                "written": report.checkpoints,
                "write_seconds": report.checkpoint_seconds,
                "state_bytes": report.checkpoint_bytes,
            },
            "failure": report.failure,
            "steps": report.steps,
            "total_steps": clock.step,
            "simulated_time": clock.time,
            "dt": clock.dt,
            "wall_seconds": report.wall_seconds,
            "particles": n,
            "particle_steps_per_s": rate,
            "particle_steps_per_s_per_core": rate / threads as f64,
            "threads": threads,
            "peak_memory_bytes": peak,
            "peak_memory_per_particle_bytes": peak.map(|p| p as f64 / n.max(1) as f64),
            "state_bytes_per_particle": self.bytes_per_particle(),
            "kinetic_energy": kinetic_energy(self.world.resource::<Particles>()),
            "max_overlap_ratio": health.run_max_overlap_ratio,
            "neighbour_list_builds": list.builds,
            "neighbour_pairs_per_particle": list.pairs() as f64 / n.max(1) as f64,
            "neighbour_list_narrowings": list.narrowings,
            "near_pairs_per_particle": self
                .world
                .get_resource::<ContactHistory>()
                .map_or(list.rev_pairs.len(), |h| h.pairs.pairs()) as f64
                / n.max(1) as f64,
            "contact_store_bytes_per_pair": self
                .world
                .contains_resource::<ContactHistory>()
                .then(|| self.contact_store_bytes() / list.pairs().max(1) as f64),
            "integrator": match self.scene.simulation.integrator {
                crate::scene::IntegratorName::Gear => "gear",
                crate::scene::IntegratorName::VelocityVerlet => "velocity_verlet",
            },
            "schedule": self.coupled_step.systems.iter().map(|(s, n)| format!("{s:?}/{n}")).collect::<Vec<_>>(),
            "energy": self.energy_summary(),
            "sinks": self.world.get_resource::<grainflow_components::Sinks>().map(crate::sinks::summary),
            "fluid": self.fluid_summary(),
            "observables": observables(&self.world, &self.scene),
        })
    }
}

/// Peak resident memory of this process (VmHWM), bytes.
pub fn peak_memory_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// The default output directory of a scene: `out/<scene file stem>`.
pub fn default_out_dir(scene_path: &Path) -> PathBuf {
    PathBuf::from("out").join(scene_path.file_stem().unwrap_or_default())
}
