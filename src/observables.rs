//! The observables of a run (`summary.json` → `observables`): with sinks, the discharge
//! rate through all of them together (`discharge_rate`, `discharge_rate_spread`,
//! `src/sinks.rs`); for coupled runs, the history of the
//! particles over the fluid steps, and from it and the final flow
//! * drag case (a fixed sphere in a flow with an inflow): `drag_coefficient`
//!   `C_D = F . e / (1/2 rho_f U^2 pi r^2)` with the inflow velocity `U = U e`,
//!   `wake_length_over_d` (recirculation length behind the sphere over its diameter) and
//!   `separation_angle_deg` (from the front stagnation point), and the drag coefficient of
//!   both force methods on the final flow (`drag_coefficient_volume_integral`,
//!   `drag_coefficient_surface_points`; the blending momentum, if any, not included; not
//!   under the distance penalty);
//! * one free sphere (sedimentation): `terminal_velocity` (the speed of the mean velocity
//!   over the last tenth of the run, with the spread of the speed over it as
//!   `terminal_velocity_spread`) and `particle_reynolds` `2 r |U| / nu`;
//! * two free spheres (drafting, kissing, tumbling): `kiss_time` (first time the gap falls
//!   below half a fluid cell, the grid-scale kiss, [`pair_events`]), `contact_time` (below
//!   1 % of the mean radius); null if it never does, with `smallest_gap` telling how
//!   close they came) and
//!   `tumble_time` (first time after the kiss at which the trailing sphere passes the
//!   leading one along gravity);
//! * more than one free particle (a settling cloud, `src/cloud.rs`, recorded after every
//!   fluid step whatever the particle count): `settling_velocity_peak` (the largest mean
//!   velocity along gravity of the cloud) and `settling_velocity_peak_time`,
//!   `settling_velocity_final`, `landing_time` (first time every sphere rests on the
//!   floor or on spheres that do; null if it never does), `clusters_final` and
//!   `clusters_max` (groups of spheres with gaps below a tenth of the radius).
use bevy_ecs::prelude::*;
use grainflow_components::{
    BoundaryRule, Clamped, Coupling, HydroForces, Particles, RunHealth, SimClock, Sinks,
};
use grainflow_fluid::sample::velocity_at;
use grainflow_systems::coupling::surface_points::surface_point_force;
use grainflow_systems::coupling::volume_integral::volume_integral_force;
use grainflow_systems::fluid::FluidFlow;
use serde_json::json;
use std::io::Write;
use std::path::PathBuf;

use crate::cloud::{self, CloudState};
use crate::scene::{FluidBoundary, Scene};

/// One record per fluid step of every particle (by stable id order).
#[derive(Resource, Debug, Clone, Default)]
pub struct CouplingLog {
    pub time: Vec<f64>,
    /// Per record, per particle (sorted by id): position, velocity, hydrodynamic force.
    pub state: Vec<Vec<[[f64; 3]; 3]>>,
    pub ids: Vec<u32>,
    pub(crate) recorded_steps: u64,
    /// `coupling.csv` of the run directory, if any: every record is appended to it as it
    /// is taken, so a run that stops early (a failure, a kill) keeps its history.
    pub csv: Option<PathBuf>,
    /// Why appending to `csv` failed (the run stops).
    pub error: Option<String>,
    /// The cloud of free particles after every fluid step (any particle count).
    pub cloud: Vec<CloudState>,
}

/// Header line of `coupling.csv` ([`CouplingLog::record_csv`]).
pub const COUPLING_CSV_HEADER: &str = "time,id,x,y,z,vx,vy,vz,fx,fy,fz\n";

/// Most particles a log follows (the seed's single- and two-sphere cases; a larger scene
/// keeps no history).
pub const LOGGED_PARTICLES: usize = 16;

/// `record_coupling`: after every fluid step, the particles' state and hydrodynamic force
/// (at most [`LOGGED_PARTICLES`]) and the state of the cloud of free particles.
pub fn record_coupling(
    clock: Res<SimClock>,
    particles: Res<Particles>,
    hydro: Res<HydroForces>,
    health: Res<RunHealth>,
    flow: Option<Res<FluidFlow>>,
    mut log: ResMut<CouplingLog>,
) {
    // a step that failed is not recorded: the history ends at the last good fluid step
    if hydro.sampled_steps == log.recorded_steps || health.failure.is_some() {
        return;
    }
    if let Some(flow) = &flow {
        let grid = flow.solver.grid();
        let free: Vec<usize> = (0..particles.len())
            .filter(|&i| particles.inv_mass[i] > 0.0)
            .collect();
        let col = |c: &[Vec<f64>; 3], i: usize| [c[0][i], c[1][i], c[2][i]];
        let position: Vec<[f64; 3]> = free.iter().map(|&i| col(&particles.position, i)).collect();
        let velocity: Vec<[f64; 3]> = free.iter().map(|&i| col(&particles.velocity, i)).collect();
        let radius: Vec<f64> = free.iter().map(|&i| particles.radius[i]).collect();
        let state = CloudState::of(
            clock.time,
            &position,
            &radius,
            &velocity,
            (grid.lower, grid.upper),
        );
        log.cloud.push(state);
    }
    if particles.len() > LOGGED_PARTICLES {
        log.recorded_steps = hydro.sampled_steps;
        return;
    }
    log.recorded_steps = hydro.sampled_steps;
    let mut rows: Vec<usize> = (0..particles.len()).collect();
    rows.sort_by_key(|&i| particles.id[i]);
    log.ids = rows.iter().map(|&i| particles.id[i]).collect();
    let col = |c: &[Vec<f64>; 3], i: usize| [c[0][i], c[1][i], c[2][i]];
    let state = rows
        .iter()
        .map(|&i| {
            [
                col(&particles.position, i),
                col(&particles.velocity, i),
                col(&hydro.force, i),
            ]
        })
        .collect();
    log.time.push(clock.time);
    log.state.push(state);
    if let (Some(path), None) = (&log.csv, &log.error) {
        let lines = log.record_csv(log.time.len() - 1);
        let appended = std::fs::OpenOptions::new()
            .append(true)
            .open(path)
            .and_then(|mut f| f.write_all(lines.as_bytes()));
        if let Err(e) = appended {
            log.error = Some(format!("cannot append to {}: {e}", path.display()));
        }
    }
}

/// The shortest response time of a free particle to the hydrodynamic force, the Stokes
/// relaxation time with the added mass of a sphere,
/// `tau = (m + rho_f V / 2) / (6 pi mu r)` (e.g. Crowe et al., Multiphase Flows with
/// Droplets and Particles, 2011, sec. 4.3); the explicit coupling (force held over a
/// fluid step) needs `dt_F` well below it. `None` without free particles (`held`: the
/// fixed ones, if any).
pub fn shortest_response_time(
    particles: &Particles,
    held: Option<&Clamped>,
    coupling: &Coupling,
) -> Option<f64> {
    let mu = coupling.fluid_density * coupling.viscosity;
    (0..particles.len())
        .filter(|&i| particles.inv_mass[i] > 0.0 && !held.is_some_and(|c| c.held[i]))
        .map(|i| {
            let r = particles.radius[i];
            let added = 0.5 * coupling.fluid_density * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
            (1.0 / particles.inv_mass[i] + added) / (6.0 * std::f64::consts::PI * mu * r)
        })
        .reduce(f64::min)
}

impl CouplingLog {
    /// A log that appends its records to `path` (`coupling.csv` of a run directory),
    /// created now with its header ([`COUPLING_CSV_HEADER`]).
    pub fn writing_to(path: PathBuf) -> Result<Self, String> {
        let log = Self {
            csv: Some(path),
            ..Self::default()
        };
        log.rewrite_csv()?;
        Ok(log)
    }

    /// Write `coupling.csv` afresh: the header and the records held (none for a new
    /// log; those up to the checkpoint for a resumed run).
    pub fn rewrite_csv(&self) -> Result<(), String> {
        let Some(path) = &self.csv else {
            return Ok(());
        };
        let mut text = COUPLING_CSV_HEADER.to_string();
        for k in 0..self.time.len() {
            text.push_str(&self.record_csv(k));
        }
        std::fs::write(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
    }

    /// Record `k` as lines of `coupling.csv`: one per particle,
    /// `time,id,x,y,z,vx,vy,vz,fx,fy,fz` (the hydrodynamic force), in the scene's units.
    pub fn record_csv(&self, k: usize) -> String {
        let mut out = String::new();
        let t = self.time[k];
        for (id, row) in self.ids.iter().zip(&self.state[k]) {
            out.push_str(&format!("{t:e},{id}"));
            for v in row.iter().flatten() {
                out.push_str(&format!(",{v:e}"));
            }
            out.push('\n');
        }
        out
    }
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The observables of a run: those of its sinks, if any, and of its coupling, if coupled.
pub fn observables(world: &World, scene: &Scene) -> serde_json::Value {
    let mut out = world
        .get_resource::<Sinks>()
        .map(crate::sinks::observables)
        .unwrap_or_default();
    out.extend(coupled_observables(world, scene));
    serde_json::Value::Object(out)
}

/// The observables of a coupled run (none otherwise).
fn coupled_observables(world: &World, scene: &Scene) -> serde_json::Map<String, serde_json::Value> {
    let (Some(log), Some(flow)) = (
        world.get_resource::<CouplingLog>(),
        world.get_resource::<FluidFlow>(),
    ) else {
        return serde_json::Map::new();
    };
    let particles = world.resource::<Particles>();
    let mut out = serde_json::Map::new();
    let free_count = particles.inv_mass.iter().filter(|&&m| m > 0.0).count();
    if let (Some(down), true) = (cloud::unit(scene.simulation.gravity), free_count > 1) {
        if !log.cloud.is_empty() {
            out.extend(cloud_observables(&log.cloud, down));
        }
    }
    let Some(last) = log.state.last() else {
        return out;
    };
    let fluid = scene.fluid.as_ref().expect("coupled scene has a fluid");
    let nu = fluid.viscosity.expect("validated");
    let radius_of = |id: u32| {
        let i = particles
            .id
            .iter()
            .position(|&k| k == id)
            .expect("logged id");
        particles.radius[i]
    };
    let held = |id: u32| {
        world.get_resource::<Clamped>().is_some_and(|c| {
            let i = particles
                .id
                .iter()
                .position(|&k| k == id)
                .expect("logged id");
            c.held[i]
        })
    };
    let fixed: Vec<usize> = (0..log.ids.len()).filter(|&k| held(log.ids[k])).collect();
    let free: Vec<usize> = (0..log.ids.len()).filter(|&k| !held(log.ids[k])).collect();
    let inflow = fluid
        .boundaries
        .sides()
        .into_iter()
        .flatten()
        .find_map(|(_, b)| match b {
            FluidBoundary::Inflow { velocity, .. } => Some(*velocity),
            _ => None,
        });
    if let (Some(&k), Some(u)) = (fixed.first(), inflow) {
        let speed = norm(u);
        let e = u.map(|c| c / speed);
        let r = radius_of(log.ids[k]);
        let [xp, _, f] = last[k];
        let area = std::f64::consts::PI * r * r;
        out.insert(
            "drag_coefficient".into(),
            json!(dot(f, e) / (0.5 * fluid.density * speed * speed * area)),
        );
        out.insert("drag_force".into(), json!(f));
        // both force methods on the final flow, for comparison (the flow does not depend
        // on the method around a fixed sphere); not under the distance penalty, whose
        // reaction is part of the force and which the surface points do not combine with
        if let Some(coupling) = world
            .get_resource::<Coupling>()
            .filter(|c| c.boundary == BoundaryRule::FaceCentre)
        {
            let ns = &flow.solver;
            let (grid, u, p) = (ns.grid(), [&ns.u[0][..], &ns.u[1], &ns.u[2]], &ns.p[..]);
            for (name, force) in [
                (
                    "drag_coefficient_volume_integral",
                    volume_integral_force(ns, coupling, xp, r).0,
                ),
                (
                    "drag_coefficient_surface_points",
                    surface_point_force(grid, u, p, coupling, xp, r).0,
                ),
            ] {
                out.insert(
                    name.into(),
                    json!(dot(force, e) / (0.5 * fluid.density * speed * speed * area)),
                );
            }
        }
        out.insert(
            "wake_length_over_d".into(),
            json!(wake_length(flow, xp, r, e) / (2.0 * r)),
        );
        out.insert(
            "separation_angle_deg".into(),
            json!(separation_angle(flow, xp, r, e)),
        );
        out.insert("reynolds".into(), json!(speed * 2.0 * r / nu));
    }
    if free.len() == 1 {
        let k = free[0];
        // mean over the last tenth of the run: a sphere of few cells per diameter moves in
        // steps of the face layers it crosses (a sawtooth of period h / U)
        let t_end = log.time.last().copied().unwrap_or(0.0);
        let window: Vec<[f64; 3]> = log
            .time
            .iter()
            .zip(&log.state)
            .filter(|(t, _)| **t >= 0.9 * t_end)
            .map(|(_, s)| s[k][1])
            .collect();
        let n = window.len().max(1) as f64;
        let v = [0, 1, 2].map(|d| window.iter().map(|w| w[d]).sum::<f64>() / n);
        let speeds = window.iter().map(|w| norm(*w));
        let spread =
            speeds.clone().fold(f64::NEG_INFINITY, f64::max) - speeds.fold(f64::INFINITY, f64::min);
        out.insert("terminal_velocity".into(), json!(norm(v)));
        out.insert("terminal_velocity_vector".into(), json!(v));
        out.insert("terminal_velocity_spread".into(), json!(spread));
        out.insert(
            "particle_reynolds".into(),
            json!(2.0 * radius_of(log.ids[k]) * norm(v) / nu),
        );
    }
    if free.len() == 2 {
        let (a, b) = (free[0], free[1]);
        let mean_r = 0.5 * (radius_of(log.ids[a]) + radius_of(log.ids[b]));
        let g = scene.simulation.gravity;
        let down = g.map(|c| c / norm(g).max(f64::MIN_POSITIVE));
        let gap = |s: &Vec<[[f64; 3]; 3]>| {
            norm([0, 1, 2].map(|d| s[a][0][d] - s[b][0][d])) - 2.0 * mean_r
        };
        let gaps: Vec<f64> = log.state.iter().map(gap).collect();
        let a_leads: Vec<bool> = log
            .state
            .iter()
            .map(|s| dot(s[a][0], down) >= dot(s[b][0], down))
            .collect();
        let h = flow.solver.grid().h().into_iter().fold(0.0, f64::max);
        let events = pair_events(&log.time, &gaps, &a_leads, 0.5 * h, 0.01 * mean_r);
        out.insert("kiss_time".into(), json!(events.kiss_time));
        out.insert("contact_time".into(), json!(events.contact_time));
        out.insert("smallest_gap".into(), json!(events.smallest_gap));
        out.insert("tumble_time".into(), json!(events.tumble_time));
    }
    out
}

/// The cloud observables (module documentation) of the records `states` for gravity
/// along the unit vector `down`.
pub fn cloud_observables(
    states: &[CloudState],
    down: [f64; 3],
) -> serde_json::Map<String, serde_json::Value> {
    let samples: Vec<cloud::CloudSample> = states.iter().map(|s| s.sample(down)).collect();
    let peak = samples
        .iter()
        .max_by(|a, b| a.settling_velocity.total_cmp(&b.settling_velocity));
    let mut out = serde_json::Map::new();
    out.insert(
        "settling_velocity_peak".into(),
        json!(peak.map(|s| s.settling_velocity)),
    );
    out.insert(
        "settling_velocity_peak_time".into(),
        json!(peak.map(|s| s.time)),
    );
    out.insert(
        "settling_velocity_final".into(),
        json!(samples.last().map(|s| s.settling_velocity)),
    );
    out.insert(
        "landing_time".into(),
        json!(cloud::landing_time(samples.iter().copied())),
    );
    out.insert(
        "clusters_final".into(),
        json!(states.last().map(|s| s.clusters)),
    );
    out.insert(
        "clusters_max".into(),
        json!(states.iter().map(|s| s.clusters).max()),
    );
    out
}

/// Drafting, kissing and tumbling of two spheres, from their gap and order along gravity
/// at the logged times.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairEvents {
    /// First time the gap is below the kissing gap.
    pub kiss_time: Option<f64>,
    /// First time the gap is below the touching gap.
    pub contact_time: Option<f64>,
    /// First time after the kiss at which the order along gravity has turned.
    pub tumble_time: Option<f64>,
    pub smallest_gap: f64,
}

/// The [`PairEvents`] of the records `time`, `gaps` (surface gap) and `a_leads` (sphere
/// a further along gravity). The kiss is the grid-scale one, a gap below
/// max(`kiss_gap`, `touch_gap`) with `kiss_gap` half a fluid cell: the grid resolves no
/// thinner film between the two spheres' rigid faces. At level 3 of the DKT case the
/// velocities of the pair meet there and it falls as one with a gap of 0.3 h, so it only
/// reaches the contact proper (`touch_gap`, 1 % of the radius) when it lands; at level 2
/// (2.5 cells per diameter) the gap goes on closing after the kiss, to contact 0.15 s
/// later (docs/coupling.md). Both times are reported.
pub fn pair_events(
    time: &[f64],
    gaps: &[f64],
    a_leads: &[bool],
    kiss_gap: f64,
    touch_gap: f64,
) -> PairEvents {
    let first_below = |limit: f64| gaps.iter().position(|&g| g < limit).map(|k| time[k]);
    let kiss_time = first_below(kiss_gap.max(touch_gap));
    let tumble_time = kiss_time.and_then(|tk| {
        let lead_first = *a_leads.first()?;
        time.iter()
            .zip(a_leads)
            .find_map(|(t, &lead)| (*t > tk && lead != lead_first).then_some(*t))
    });
    PairEvents {
        kiss_time,
        contact_time: first_below(touch_gap),
        tumble_time,
        smallest_gap: gaps.iter().copied().fold(f64::INFINITY, f64::min),
    }
}

/// Length of the recirculation behind a sphere at `xp` (radius `r`) in a flow along `e`:
/// from the rear point to where the velocity along `e` on the axis turns positive again
/// (0 without a reversed flow), sampled every quarter cell.
pub fn wake_length(flow: &FluidFlow, xp: [f64; 3], r: f64, e: [f64; 3]) -> f64 {
    let ns = &flow.solver;
    let g = ns.grid();
    let u = [&ns.u[0][..], &ns.u[1], &ns.u[2]];
    let step = 0.25 * g.h().into_iter().fold(f64::INFINITY, f64::min);
    let inside_box = |x: [f64; 3]| (0..3).all(|d| x[d] > g.lower[d] && x[d] < g.upper[d]);
    let mut s = r;
    let mut prev: Option<(f64, f64)> = None;
    let mut reversed = false;
    loop {
        let x = [0, 1, 2].map(|d| xp[d] + s * e[d]);
        if !inside_box(x) {
            return if reversed { s - r } else { 0.0 };
        }
        let v = dot(velocity_at(g, u, x), e);
        if v < 0.0 {
            reversed = true;
        } else if reversed {
            let (s0, v0) = prev.expect("a reversed sample before");
            return s0 + (s - s0) * v0 / (v0 - v) - r;
        }
        prev = Some((s, v));
        s += step;
    }
}

/// Separation angle (degrees from the front stagnation point) of the flow along `e`
/// around a sphere: the first angle at which the velocity along the surface, sampled
/// one cell off the surface and averaged over four meridian planes, turns against the
/// flow; 180 without separation.
pub fn separation_angle(flow: &FluidFlow, xp: [f64; 3], r: f64, e: [f64; 3]) -> f64 {
    let ns = &flow.solver;
    let g = ns.grid();
    let u = [&ns.u[0][..], &ns.u[1], &ns.u[2]];
    let h = g.h().into_iter().fold(0.0, f64::max);
    let rs = r + h;
    // two directions normal to e
    let a = if e[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let n1 = {
        let t = [0, 1, 2].map(|d| a[d] - dot(a, e) * e[d]);
        t.map(|c| c / norm(t))
    };
    let n2 = [
        e[1] * n1[2] - e[2] * n1[1],
        e[2] * n1[0] - e[0] * n1[2],
        e[0] * n1[1] - e[1] * n1[0],
    ];
    let tangential = |theta: f64| -> f64 {
        let (s, c) = theta.sin_cos();
        let mut sum = 0.0;
        for n in [n1, n2, n1.map(|v| -v), n2.map(|v| -v)] {
            let x = [0, 1, 2].map(|d| xp[d] + rs * (-c * e[d] + s * n[d]));
            let t = [0, 1, 2].map(|d| s * e[d] + c * n[d]);
            sum += dot(velocity_at(g, u, x), t);
        }
        sum / 4.0
    };
    let steps = 360;
    let mut prev = (0.0, tangential(0.0));
    for k in 1..=steps {
        let theta = std::f64::consts::PI * k as f64 / steps as f64;
        let v = tangential(theta);
        if v < 0.0 && theta > 0.25 * std::f64::consts::PI {
            let (t0, v0) = prev;
            return (t0 + (theta - t0) * v0 / (v0 - v)).to_degrees();
        }
        prev = (theta, v);
    }
    180.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A trailing sphere b closing on a leading sphere a at 1 per unit time from a gap of
    /// 3.45, sampled every 0.1 (kissing gap 0.5: first below at t = 3.0; touching gap
    /// 0.01: at t = 3.5), then the pair turning at t = 5: tumbling.
    #[test]
    fn kiss_contact_and_tumble_times_from_the_gap_history() {
        let time: Vec<f64> = (0..70).map(|k| 0.1 * k as f64).collect();
        let gaps: Vec<f64> = time.iter().map(|t| (3.45 - t).max(0.0)).collect();
        let a_leads: Vec<bool> = time.iter().map(|&t| t < 5.0 - 1e-9).collect();
        let e = pair_events(&time, &gaps, &a_leads, 0.5, 0.01);
        let close = |x: Option<f64>, y: f64| x.is_some_and(|x| (x - y).abs() < 1e-9);
        assert!(close(e.kiss_time, 3.0), "{e:?}");
        assert!(close(e.contact_time, 3.5), "{e:?}");
        assert!(close(e.tumble_time, 5.0), "{e:?}");
        assert_eq!(e.smallest_gap, 0.0);
        // a kissing gap below the touching gap: the kiss is the contact
        let e = pair_events(&time, &gaps, &a_leads, 0.001, 0.01);
        assert_eq!(e.kiss_time, e.contact_time);
        // spheres that never come close: no kiss, no tumble (the turn does not count)
        let far: Vec<f64> = gaps.iter().map(|g| g + 1.0).collect();
        let e = pair_events(&time, &far, &a_leads, 0.5, 0.01);
        assert_eq!(
            (e.kiss_time, e.contact_time, e.tumble_time),
            (None, None, None)
        );
        assert_eq!(e.smallest_gap, 1.0);
    }
}
