//! The flow step: one time step of the incompressible Navier-Stokes solver
//! (`grainflow-fluid`: Q1~/Q0 elements, discrete projection, multigrid), and the flow it
//! advances ([`FluidFlow`]). `schedule.rs` runs it whenever the simulated time reaches the
//! next fluid time, so that the DEM steps between two fluid steps (the seed's subcycling,
//! dt_F = n_s dt_D) see one flow field.
use bevy_ecs::prelude::*;
use grainflow_components::{Particles, RunHealth, SimClock};
use grainflow_fluid::{NavierStokes, StepReport};
use rayon::prelude::*;

/// The flow of a scene with a fluid grid: the Navier-Stokes solver of `grainflow-fluid`
/// (its grid, velocity on faces and pressure on cells, multigrid hierarchies), the time
/// of its next step, and the run figures of its steps. Present only when the scene has a
/// fluid grid.
#[derive(Resource)]
pub struct FluidFlow {
    pub solver: NavierStokes,
    /// Fluid time step dt_F.
    pub dt: f64,
    /// Simulated time at which the next fluid step starts.
    pub next_time: f64,
    pub stats: FluidStats,
    /// Velocity scale of the scene (its units): the largest of the boundary speeds,
    /// sqrt(|f| L) of the body force f, sqrt(|g| L) of gravity and the viscous speed
    /// nu / L (L the domain's diagonal). A flow faster than [`RUNAWAY_FACTOR`] times it
    /// (or than that multiple of the fastest particle) has run away.
    pub velocity_scale: f64,
}

/// Sums over the fluid steps of a run, for the run report.
#[derive(Debug, Clone, Default)]
pub struct FluidStats {
    pub steps: u64,
    pub seconds: f64,
    /// Wall seconds of each step, in order: the first steps also pay for allocating the
    /// solver's work vectors, so the median is the cost of a step in a long run.
    pub step_seconds: Vec<f64>,
    pub momentum_cycles: u64,
    /// Sum of ln(reduction per cycle) over the steps (their geometric mean is reported).
    pub momentum_log_rate: f64,
    pub pressure_cycles: u64,
    pub pressure_log_rate: f64,
    /// Wall seconds of the momentum solves and of the pressure solves.
    pub momentum_seconds: f64,
    pub pressure_seconds: f64,
    pub max_divergence: f64,
}

impl FluidStats {
    /// Add one step's report.
    pub fn add(&mut self, r: &StepReport) {
        self.steps += 1;
        self.seconds += r.seconds;
        self.step_seconds.push(r.seconds);
        self.momentum_cycles += r.momentum_cycles as u64;
        self.momentum_log_rate += r.momentum_reduction.max(1e-300).ln();
        self.pressure_cycles += r.pressure_cycles as u64;
        self.pressure_log_rate += r.pressure_reduction.max(1e-300).ln();
        self.momentum_seconds += r.momentum_seconds;
        self.pressure_seconds += r.pressure_seconds;
        self.max_divergence = self.max_divergence.max(r.max_divergence);
    }

    /// Median wall seconds of a step (the mean of the middle two for an even count; 0
    /// without steps).
    pub fn median_step_seconds(&self) -> f64 {
        let mut s = self.step_seconds.clone();
        s.sort_by(f64::total_cmp);
        match s.len() {
            0 => 0.0,
            n if n % 2 == 1 => s[n / 2],
            n => 0.5 * (s[n / 2 - 1] + s[n / 2]),
        }
    }
}

/// A flow faster than this multiple of the scene's velocity scale
/// ([`FluidFlow::velocity_scale`], or of the fastest particle) has run away: the flows of
/// the seed's cases stay within a few times it.
pub const RUNAWAY_FACTOR: f64 = 100.0;

pub fn has_fluid(w: &World) -> bool {
    w.contains_resource::<FluidFlow>()
}

/// One flow step; a flow that is no longer physical ([`flow_instability`]) stops the
/// run, naming the step and the place.
pub fn multigrid_fluid(
    clock: Res<SimClock>,
    mut flow: ResMut<FluidFlow>,
    particles: Option<Res<Particles>>,
    mut health: ResMut<RunHealth>,
) {
    let _span = tracing::info_span!("multigrid_fluid").entered();
    let report = flow.solver.step();
    flow.stats.add(&report);
    flow.next_time += flow.dt;
    if health.failure.is_some() {
        return;
    }
    // the fastest surface point of any particle bounds |v| + |w| r
    let fastest_particle = particles.map_or(0.0, |p| {
        let [vx, vy, vz] = &p.velocity;
        let [wx, wy, wz] = &p.angular_velocity;
        (0..p.len())
            .map(|i| {
                (vx[i] * vx[i] + vy[i] * vy[i] + vz[i] * vz[i]).sqrt()
                    + (wx[i] * wx[i] + wy[i] * wy[i] + wz[i] * wz[i]).sqrt() * p.radius[i]
            })
            .fold(0.0, f64::max)
    });
    let scale = flow.velocity_scale.max(fastest_particle);
    if let Some(what) = flow_instability(&flow.solver, scale) {
        // The step under way, counted from 1 as the monitor and summary.json count (the
        // clock advances at the end of the step), and the time at its end.
        health.failure = Some(format!(
            "unstable at step {} (t = {:.6e} s), fluid step {}: {what}",
            clock.step + 1,
            (clock.step + 1) as f64 * clock.dt,
            flow.stats.steps
        ));
    }
}

/// Why the flow is no longer physical, if it is not: a non-finite velocity or pressure,
/// or a velocity component above [`RUNAWAY_FACTOR`] times `scale`. Names the face (or
/// cell) by its centre; of several, the one with the largest speed, then the lowest index.
pub fn flow_instability(ns: &NavierStokes, scale: f64) -> Option<String> {
    let grid = ns.grid();
    let lay = grid.layout();
    // (|u_d| with non-finite as infinite, face index, component)
    let fastest = (0..3)
        .map(|d| {
            ns.u[d]
                .par_iter()
                .enumerate()
                .map(|(k, &v)| {
                    (
                        if v.is_finite() {
                            v.abs()
                        } else {
                            f64::INFINITY
                        },
                        k,
                    )
                })
                .reduce(
                    || (0.0, usize::MAX),
                    |a, b| {
                        if b.0 > a.0 || (b.0 == a.0 && b.1 < a.1) {
                            b
                        } else {
                            a
                        }
                    },
                )
        })
        .enumerate()
        .fold((0.0, usize::MAX, 0), |best, (d, (v, k))| {
            if v > best.0 {
                (v, k, d)
            } else {
                best
            }
        });
    let limit = RUNAWAY_FACTOR * scale;
    if fastest.0 > limit {
        let (_, k, d) = fastest;
        let (a, f) = lay.face_of(k);
        let x = grid.face_centre(a, f);
        let value = ns.u[d][k];
        let what = if value.is_finite() {
            format!(
                "runaway flow: velocity component {} = {value:.3e} exceeds {RUNAWAY_FACTOR} \
                 times the scene's velocity scale {scale:.3e}",
                ["x", "y", "z"][d]
            )
        } else {
            format!("non-finite velocity component {}", ["x", "y", "z"][d])
        };
        return Some(format!(
            "{what} at the face centred at ({:.4e}, {:.4e}, {:.4e}); \
             reduce fluid.dt, or raise fluid.upwind towards 1",
            x[0], x[1], x[2]
        ));
    }
    let bad_cell = ns.p.par_iter().position_first(|v| !v.is_finite())?;
    let x = grid.cell_centre(lay.cell_coords(bad_cell));
    Some(format!(
        "non-finite pressure in the cell centred at ({:.4e}, {:.4e}, {:.4e})",
        x[0], x[1], x[2]
    ))
}
