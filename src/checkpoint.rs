//! Checkpoints: the complete mutable state of a run (DEM, flow and coupling) in
//! `checkpoint.h5`, from which `grainflow resume` continues bitwise as if never stopped.
//!
//! Every resource that changes during a run is saved whole, in its current row order
//! (particles are re-sorted in cell order, and sums depend on that order): particles,
//! integrator derivatives, rotation, Verlet list with its reference positions and
//! narrowing state, wall list, contact store and wall-contact history (tangential
//! springs, rolling displacements, JKR flags), inflow progress and random state, wall
//! removal flags, sinks, the clump bodies, the health and energy monitors, the flow's time levels with its
//! prescribed and penalised faces, the coupling's markers, held forces and log, the clock
//! and the output timetable.
//! What the scene defines and the run never changes (materials, contact laws, wall
//! shapes, settings) is rebuilt from the scene text stored beside them. Each resource is
//! one `u8` dataset (`/state/<Resource>`, its fields in order, little-endian); the
//! attributes `version`, `step` and `time` of the root and the datasets `scene`
//! (the scene file's text), `scene_path` and `overrides` (the `--set` values, one per
//! line) describe it. A checkpoint is written to `checkpoint.h5.tmp` and renamed over
//! `checkpoint.h5`, so a run killed while writing keeps the previous one.
use std::path::{Path, PathBuf};

use bevy_ecs::prelude::*;
use grainflow_components::*;

use grainflow_fluid::{FaceLoad, FlowLevels, PenaltyFace};
use grainflow_systems::fluid::{FluidFlow, FluidStats};

use crate::cloud::CloudState;
use crate::observables::CouplingLog;
use crate::output::ParticleOutput;

/// Format of the state blobs; a checkpoint of another version is refused.
pub const CHECKPOINT_VERSION: u32 = 4;

/// The checkpoint file of a run directory.
pub const CHECKPOINT_FILE: &str = "checkpoint.h5";

/// A value saved as bytes and read back into an existing value of the same shape.
pub trait State: Sized {
    fn save(&self, out: &mut Vec<u8>);
    fn load(&mut self, input: &mut Reader) -> Result<(), String>;
    /// The values of a slice, one after another (numbers: their bytes in one copy).
    fn save_slice(values: &[Self], out: &mut Vec<u8>) {
        for x in values {
            x.save(out);
        }
    }
    /// Read back what [`State::save_slice`] wrote into `values`.
    fn load_slice(values: &mut [Self], input: &mut Reader) -> Result<(), String> {
        for x in values {
            x.load(input)?;
        }
        Ok(())
    }
}

/// Reads a state blob front to back.
pub struct Reader<'a> {
    bytes: &'a [u8],
}

impl<'a> Reader<'a> {
    fn take_slice(&mut self, n: usize) -> Result<&'a [u8], String> {
        if self.bytes.len() < n {
            return Err("the state ends early".into());
        }
        let (head, rest) = self.bytes.split_at(n);
        self.bytes = rest;
        Ok(head)
    }

    fn take<const N: usize>(&mut self) -> Result<[u8; N], String> {
        if self.bytes.len() < N {
            return Err("the state ends early".into());
        }
        let (head, rest) = self.bytes.split_at(N);
        self.bytes = rest;
        Ok(head.try_into().expect("N bytes"))
    }
}

macro_rules! number_state {
    ($($t:ty),*) => {$(
        impl State for $t {
            fn save(&self, out: &mut Vec<u8>) {
                out.extend_from_slice(&self.to_le_bytes());
            }
            fn load(&mut self, input: &mut Reader) -> Result<(), String> {
                *self = <$t>::from_le_bytes(input.take()?);
                Ok(())
            }
            fn save_slice(values: &[Self], out: &mut Vec<u8>) {
                out.reserve(std::mem::size_of_val(values));
                for x in values {
                    out.extend_from_slice(&x.to_le_bytes());
                }
            }
            fn load_slice(values: &mut [Self], input: &mut Reader) -> Result<(), String> {
                const N: usize = std::mem::size_of::<$t>();
                let bytes = input.take_slice(N * values.len())?;
                for (x, b) in values.iter_mut().zip(bytes.chunks_exact(N)) {
                    *x = <$t>::from_le_bytes(b.try_into().expect("N bytes"));
                }
                Ok(())
            }
        }
    )*};
}
number_state!(f64, u64, u32, u16, u8, i32);

impl State for usize {
    fn save(&self, out: &mut Vec<u8>) {
        (*self as u64).save(out);
    }
    fn load(&mut self, input: &mut Reader) -> Result<(), String> {
        let mut v = 0u64;
        v.load(input)?;
        *self = usize::try_from(v).map_err(|_| "a count beyond this machine's range")?;
        Ok(())
    }
}

impl State for bool {
    fn save(&self, out: &mut Vec<u8>) {
        out.push(u8::from(*self));
    }
    fn load(&mut self, input: &mut Reader) -> Result<(), String> {
        let [b] = input.take::<1>()?;
        *self = b != 0;
        Ok(())
    }
}

impl<T: State + Default> State for Vec<T> {
    fn save(&self, out: &mut Vec<u8>) {
        self.len().save(out);
        T::save_slice(self, out);
    }
    fn load(&mut self, input: &mut Reader) -> Result<(), String> {
        let mut n = 0usize;
        n.load(input)?;
        if n > input.bytes.len() {
            return Err("a length beyond the state's size".into());
        }
        self.clear();
        self.resize_with(n, T::default);
        T::load_slice(self, input)
    }
}

impl<T: State, const N: usize> State for [T; N] {
    fn save(&self, out: &mut Vec<u8>) {
        for x in self {
            x.save(out);
        }
    }
    fn load(&mut self, input: &mut Reader) -> Result<(), String> {
        for x in self.iter_mut() {
            x.load(input)?;
        }
        Ok(())
    }
}

impl<T: State + Default> State for Option<T> {
    fn save(&self, out: &mut Vec<u8>) {
        self.is_some().save(out);
        if let Some(x) = self {
            x.save(out);
        }
    }
    fn load(&mut self, input: &mut Reader) -> Result<(), String> {
        let mut some = false;
        some.load(input)?;
        *self = if some {
            let mut x = T::default();
            x.load(input)?;
            Some(x)
        } else {
            None
        };
        Ok(())
    }
}

impl<A: State, B: State> State for (A, B) {
    fn save(&self, out: &mut Vec<u8>) {
        self.0.save(out);
        self.1.save(out);
    }
    fn load(&mut self, input: &mut Reader) -> Result<(), String> {
        self.0.load(input)?;
        self.1.load(input)
    }
}

impl State for String {
    fn save(&self, out: &mut Vec<u8>) {
        self.as_bytes().to_vec().save(out);
    }
    fn load(&mut self, input: &mut Reader) -> Result<(), String> {
        let mut bytes: Vec<u8> = Vec::new();
        bytes.load(input)?;
        *self = String::from_utf8(bytes).map_err(|_| "a text that is not UTF-8")?;
        Ok(())
    }
}

/// `State` of a struct: its listed fields, in order.
macro_rules! fields_state {
    ($t:ty { $($f:ident),* $(,)? }) => {
        impl State for $t {
            fn save(&self, out: &mut Vec<u8>) {
                $(self.$f.save(out);)*
            }
            fn load(&mut self, input: &mut Reader) -> Result<(), String> {
                $(self.$f.load(input)?;)*
                Ok(())
            }
        }
    };
}

impl State for glam::DVec3 {
    fn save(&self, out: &mut Vec<u8>) {
        self.to_array().save(out);
    }
    fn load(&mut self, input: &mut Reader) -> Result<(), String> {
        let mut v = [0.0; 3];
        v.load(input)?;
        *self = glam::DVec3::from_array(v);
        Ok(())
    }
}

impl State for glam::DQuat {
    fn save(&self, out: &mut Vec<u8>) {
        self.to_array().save(out);
    }
    fn load(&mut self, input: &mut Reader) -> Result<(), String> {
        let mut v = [0.0; 4];
        v.load(input)?;
        *self = glam::DQuat::from_array(v);
        Ok(())
    }
}

fields_state!(SimClock { step, time, dt });
fields_state!(BodyAux {
    acc,
    torque_rate,
    start_orientation,
    start_momentum,
    half_velocity,
    half_momentum
});
// The clump types are rebuilt from the scene.
fields_state!(Clumps {
    kind,
    position,
    velocity,
    orientation,
    angular_momentum,
    force,
    torque,
    aux,
    first_member,
    body_of_id,
    member_row,
    member_start,
    rows_stale
});
fields_state!(Particles {
    id,
    material,
    radius,
    inv_mass,
    position,
    velocity,
    angular_velocity,
    force
});
fields_state!(GearState {
    acc,
    jerk,
    snap,
    alpha0,
    predicted_rows
});
fields_state!(VerletState {
    half_velocity,
    predicted_rows
});
fields_state!(PredictAhead { allowed });
fields_state!(Rotation {
    torque,
    orientation,
    aux
});
fields_state!(Clamped {
    held,
    origin,
    velocity
});
fields_state!(VerletList {
    start,
    neighbours,
    owner,
    near_end,
    inner_skin,
    inner_bound,
    inner_steps,
    narrowings,
    rev_start,
    rev_pairs,
    rev_owner,
    reference,
    stale,
    builds,
    sorts,
    motion_bound,
});
fields_state!(StepMotion { max_component });
fields_state!(Reorder { perm });
fields_state!(WallList {
    start,
    walls,
    particle,
    built_for
});
fields_state!(ScatterPlan {
    pairs_per_item,
    item_start,
    particle,
    pair_slot,
    gather_start,
    gather
});
fields_state!(PairList {
    ids,
    start,
    neighbours,
    owner,
    scatter
});
fields_state!(ContactHistory {
    width,
    directed,
    values,
    pairs
});
fields_state!(WallHistory {
    width,
    values,
    ids,
    start,
    walls,
    built_for
});
fields_state!(RunHealth {
    max_overlap_ratio,
    max_overlap_particle,
    run_max_overlap_ratio,
    overlap_limit,
    state_found_finite,
    non_finite_particle,
    failure,
});
fields_state!(EnergyBalance {
    enforced,
    tolerance,
    kinetic,
    rotational,
    potential,
    elastic,
    initial,
    inserted,
    removed,
    counted_ids,
    scale,
    largest_growth,
    largest_growth_step,
    checked_step,
    checks,
});

fields_state!(SinkEvent {
    time,
    sink,
    count,
    mass
});
fields_state!(Sinks {
    leaving,
    removed,
    removed_mass,
    events
});

fields_state!(FluidStats {
    steps,
    seconds,
    step_seconds,
    momentum_cycles,
    momentum_log_rate,
    pressure_cycles,
    pressure_log_rate,
    momentum_seconds,
    pressure_seconds,
    max_divergence,
});
fields_state!(PenaltyFace { face, rate, target });
fields_state!(FaceLoad { face, accel });
fields_state!(FlowLevels {
    u,
    p,
    previous,
    previous_dt,
    held,
    penalty,
    loads,
    time,
    steps,
});
fields_state!(ParticleFace {
    face,
    row,
    id,
    start,
    load
});
fields_state!(CellMarkers {
    marker,
    marked,
    rigid_faces,
    particle_faces,
    blend_faces,
    penalty_rows,
});
fields_state!(HydroForces {
    force,
    torque,
    exchange_force,
    exchange_torque,
    inside_force,
    sampled_steps,
});
fields_state!(CloudState {
    time,
    mean_velocity,
    max_speed,
    clusters,
    all_on_side,
});

/// Of the flow its time levels (velocity, pressure, the earlier level and the prescribed
/// and penalised faces: [`FlowLevels`]), the time of its next step and its step figures.
impl State for FluidFlow {
    fn save(&self, out: &mut Vec<u8>) {
        self.solver.levels().save(out);
        self.next_time.save(out);
        self.stats.save(out);
    }
    fn load(&mut self, input: &mut Reader) -> Result<(), String> {
        let mut levels = FlowLevels::default();
        levels.load(input)?;
        self.solver.set_levels(levels)?;
        self.next_time.load(input)?;
        self.stats.load(input)
    }
}

/// Of the coupling log its records and the cloud states; loading writes `coupling.csv`
/// again with the records taken up to the checkpoint.
impl State for CouplingLog {
    fn save(&self, out: &mut Vec<u8>) {
        self.time.save(out);
        self.state.save(out);
        self.ids.save(out);
        self.recorded_steps.save(out);
        self.cloud.save(out);
    }
    fn load(&mut self, input: &mut Reader) -> Result<(), String> {
        self.time.load(input)?;
        self.state.load(input)?;
        self.ids.load(input)?;
        self.recorded_steps.load(input)?;
        self.cloud.load(input)?;
        if self.state.len() != self.time.len()
            || self.state.iter().any(|s| s.len() != self.ids.len())
        {
            return Err("records of differing lengths".into());
        }
        self.rewrite_csv()
    }
}

/// Of the walls only whether each is still there changes.
impl State for Walls {
    fn save(&self, out: &mut Vec<u8>) {
        let active: Vec<bool> = self.list.iter().map(|w| w.active).collect();
        active.save(out);
    }
    fn load(&mut self, input: &mut Reader) -> Result<(), String> {
        let mut active: Vec<bool> = Vec::new();
        active.load(input)?;
        if active.len() != self.list.len() {
            return Err(format!(
                "{} walls saved, the scene has {}",
                active.len(),
                self.list.len()
            ));
        }
        for (w, a) in self.list.iter_mut().zip(active) {
            w.active = a;
        }
        Ok(())
    }
}

/// Of the inflows their progress, next time and random state change, and the next id.
impl State for Inflows {
    fn save(&self, out: &mut Vec<u8>) {
        self.next_id.save(out);
        self.list.len().save(out);
        for i in &self.list {
            i.inserted.save(out);
            i.next_time.save(out);
            i.rng_state.save(out);
        }
    }
    fn load(&mut self, input: &mut Reader) -> Result<(), String> {
        self.next_id.load(input)?;
        let mut n = 0usize;
        n.load(input)?;
        if n != self.list.len() {
            return Err(format!(
                "{n} inflows saved, the scene has {}",
                self.list.len()
            ));
        }
        for i in &mut self.list {
            i.inserted.load(input)?;
            i.next_time.load(input)?;
            i.rng_state.load(input)?;
        }
        Ok(())
    }
}

/// Of the particle writer the time of the next frame and the frames written so far:
/// loading drops the frames written after them (the interrupted run's last state).
impl State for ParticleOutput {
    fn save(&self, out: &mut Vec<u8>) {
        self.next_time.save(out);
        self.frames.len().save(out);
    }
    fn load(&mut self, input: &mut Reader) -> Result<(), String> {
        self.next_time.load(input)?;
        let mut frames = 0usize;
        frames.load(input)?;
        self.keep_frames(frames)
    }
}

type ResourceFn = fn(&mut World, Mode) -> Result<(), String>;

/// What a [`ResourceFn`] does with its resource.
enum Mode<'a> {
    /// Append (name, bytes) if the world has it.
    Save(&'a mut Vec<(String, Vec<u8>)>),
    /// Load from the bytes of that name; the world must have the resource exactly when
    /// the checkpoint does.
    Load(&'a dyn Fn(&str) -> Option<Vec<u8>>),
}

fn apply<T: Resource<Mutability = bevy_ecs::component::Mutable> + State>(
    world: &mut World,
    mode: Mode,
) -> Result<(), String> {
    let name = std::any::type_name::<T>()
        .rsplit("::")
        .next()
        .unwrap_or("?");
    match mode {
        Mode::Save(out) => {
            if let Some(r) = world.get_resource::<T>() {
                let mut bytes = Vec::new();
                r.save(&mut bytes);
                out.push((name.to_string(), bytes));
            }
            Ok(())
        }
        Mode::Load(saved) => match (world.get_resource_mut::<T>(), saved(name)) {
            (None, None) => Ok(()),
            (Some(mut r), Some(bytes)) => {
                let mut input = Reader { bytes: &bytes };
                r.load(&mut input)
                    .map_err(|e| format!("state `{name}`: {e}"))?;
                if input.bytes.is_empty() {
                    Ok(())
                } else {
                    Err(format!(
                        "state `{name}`: {} bytes too many",
                        input.bytes.len()
                    ))
                }
            }
            (Some(_), None) => Err(format!("no state `{name}`, which the scene has")),
            (None, Some(_)) => Err(format!("a state `{name}` the scene does not have")),
        },
    }
}

/// Every saved resource type, in a fixed order.
fn resources() -> [ResourceFn; 24] {
    [
        apply::<SimClock>,
        apply::<Particles>,
        apply::<GearState>,
        apply::<VerletState>,
        apply::<PredictAhead>,
        apply::<Rotation>,
        apply::<Clamped>,
        apply::<Clumps>,
        apply::<VerletList>,
        apply::<StepMotion>,
        apply::<Reorder>,
        apply::<WallList>,
        apply::<ContactHistory>,
        apply::<WallHistory>,
        apply::<RunHealth>,
        apply::<EnergyBalance>,
        apply::<Walls>,
        apply::<Inflows>,
        apply::<Sinks>,
        apply::<FluidFlow>,
        apply::<CellMarkers>,
        apply::<HydroForces>,
        apply::<CouplingLog>,
        apply::<ParticleOutput>,
    ]
}

/// The scene a checkpoint was taken of: its file's text, path and `--set` overrides.
pub struct SavedScene {
    pub text: String,
    pub path: PathBuf,
    pub overrides: Vec<String>,
}

/// Write the state of `world` and its scene into `dir/checkpoint.h5` (through a
/// temporary file renamed over it). Returns the bytes of state written.
pub fn write_checkpoint(
    world: &mut World,
    scene: &SavedScene,
    dir: &Path,
) -> Result<usize, String> {
    let _span = tracing::info_span!("write_checkpoint").entered();
    let mut blobs = Vec::new();
    for f in resources() {
        f(world, Mode::Save(&mut blobs))?;
    }
    let clock = *world.resource::<SimClock>();
    let tmp = dir.join(format!("{CHECKPOINT_FILE}.tmp"));
    let h5 = |e: hdf5::Error| format!("writing {}: {e}", tmp.display());
    {
        let file = hdf5::File::create(&tmp).map_err(h5)?;
        file.new_attr::<u32>()
            .create("version")
            .map_err(h5)?
            .write_scalar(&CHECKPOINT_VERSION)
            .map_err(h5)?;
        file.new_attr::<u64>()
            .create("step")
            .map_err(h5)?
            .write_scalar(&clock.step)
            .map_err(h5)?;
        file.new_attr::<f64>()
            .create("time")
            .map_err(h5)?
            .write_scalar(&clock.time)
            .map_err(h5)?;
        let bytes = |name: &str, data: &[u8]| -> Result<(), String> {
            file.new_dataset::<u8>()
                .shape([data.len()])
                .create(name)
                .map_err(h5)?
                .write_raw(data)
                .map_err(h5)
        };
        bytes("scene", scene.text.as_bytes())?;
        bytes("scene_path", scene.path.to_string_lossy().as_bytes())?;
        bytes("overrides", scene.overrides.join("\n").as_bytes())?;
        let state = file.create_group("state").map_err(h5)?;
        for (name, data) in &blobs {
            state
                .new_dataset::<u8>()
                .shape([data.len()])
                .create(name.as_str())
                .map_err(h5)?
                .write_raw(data)
                .map_err(h5)?;
        }
        file.flush().map_err(h5)?;
    }
    let path = dir.join(CHECKPOINT_FILE);
    std::fs::rename(&tmp, &path)
        .map_err(|e| format!("cannot rename {} to {}: {e}", tmp.display(), path.display()))?;
    Ok(blobs.iter().map(|(_, b)| b.len()).sum())
}

/// An opened checkpoint: its scene and the state blobs, read whole.
pub struct Checkpoint {
    pub scene: SavedScene,
    pub step: u64,
    pub time: f64,
    state: Vec<(String, Vec<u8>)>,
}

/// Read `dir/checkpoint.h5`; the error says what is wrong with it (the caller names the
/// file).
pub fn read_checkpoint(dir: &Path) -> Result<Checkpoint, String> {
    let path = dir.join(CHECKPOINT_FILE);
    if !path.is_file() {
        return Err(
            "no checkpoint; expected a run directory written with --checkpoint-every".into(),
        );
    }
    let bad = |e: hdf5::Error| format!("not a readable grainflow checkpoint ({e})");
    let file = hdf5::File::open(&path).map_err(bad)?;
    let version: u32 = file
        .attr("version")
        .and_then(|a| a.read_scalar())
        .map_err(bad)?;
    if version != CHECKPOINT_VERSION {
        return Err(format!(
            "checkpoint version {version}; expected version {CHECKPOINT_VERSION}"
        ));
    }
    let text = |name: &str| -> Result<String, String> {
        let bytes: Vec<u8> = file.dataset(name).and_then(|d| d.read_raw()).map_err(bad)?;
        String::from_utf8(bytes).map_err(|_| format!("`{name}` is not UTF-8"))
    };
    let overrides = text("overrides")?;
    let scene = SavedScene {
        text: text("scene")?,
        path: PathBuf::from(text("scene_path")?),
        overrides: overrides
            .lines()
            .map(String::from)
            .filter(|l| !l.is_empty())
            .collect(),
    };
    let state_group = file.group("state").map_err(bad)?;
    let mut state = Vec::new();
    for name in state_group.member_names().map_err(bad)? {
        let bytes: Vec<u8> = state_group
            .dataset(&name)
            .and_then(|d| d.read_raw())
            .map_err(bad)?;
        state.push((name, bytes));
    }
    Ok(Checkpoint {
        scene,
        step: file
            .attr("step")
            .and_then(|a| a.read_scalar())
            .map_err(bad)?,
        time: file
            .attr("time")
            .and_then(|a| a.read_scalar())
            .map_err(bad)?,
        state,
    })
}

impl Checkpoint {
    /// Put the saved state into `world`, built from the saved scene.
    pub fn restore(&self, world: &mut World) -> Result<(), String> {
        let saved = |name: &str| {
            self.state
                .iter()
                .find(|(n, _)| n == name)
                .map(|(_, b)| b.clone())
        };
        for f in resources() {
            f(world, Mode::Load(&saved))?;
        }
        Ok(())
    }
}
