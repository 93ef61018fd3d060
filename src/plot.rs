//! `grainflow plot`: PNG figures of a run directory.
//!
//! * `contour`: a slice of the cell-centred flow of `fluid.h5` (velocity magnitude or
//!   pressure) on the cell layer that holds a plane `x=`, `y=` or `z=`, in a continuous
//!   colour map with a colour bar; spheres of `particles.h5` that cut the plane are drawn
//!   as their circles of intersection.
//! * `series`: particle velocity or position (one component or the magnitude) against
//!   time, one line per particle id, from `particles.h5`; or an observable of the whole
//!   cloud (`src/cloud.rs`: the mean settling velocity, the number of clusters), one line
//!   per run, with the landing time of each run in the legend.
//! * `particles`: side views of the spheres of `particles.h5` (orthographic projection
//!   along x, y or z, spheres to scale in depth order) at one or several frames, coloured
//!   by speed, id or height.
//!
//! The reading part ([`FluidRun`], [`ParticleRun`], [`FluidGrid`]) does not depend on
//! plotting and can be reused. Text needs a TrueType font: DejaVu Sans at [`DEFAULT_FONT`]
//! (installed by `scripts/setup.sh`), or the file named by `GRAINFLOW_FONT`; it is
//! registered with plotters' `ab_glyph` font table, so no system font library is used.
//!
//! Exit codes as the rest of the CLI: 2 for bad input (the message names the argument or
//! the missing file), 1 when the PNG cannot be written.
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::OnceLock;

use clap::{Args, Subcommand, ValueEnum};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::cloud::CloudState;

/// The font file used for all text unless `GRAINFLOW_FONT` names another.
pub const DEFAULT_FONT: &str = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";

// ---------------------------------------------------------------------------------------
// Command line

#[derive(Args, Debug)]
pub struct PlotArgs {
    #[command(subcommand)]
    pub kind: PlotKind,
}

#[derive(Subcommand, Debug)]
pub enum PlotKind {
    /// Contour slice of the flow (fluid.h5) at a plane x=, y= or z=.
    Contour(ContourArgs),
    /// Particle velocity or position against time (particles.h5), one line per id; or a
    /// cloud observable (settling velocity, clusters), one line per run.
    Series(SeriesArgs),
    /// Side view of the spheres (particles.h5) at one frame or several side by side.
    Particles(ParticlesArgs),
    /// Excavation profiles: bed surface height against distance from a vertical axis at
    /// several times (particles.h5), with the crater's depth and radius.
    Profile(crate::excavation::ProfileArgs),
    /// Extracted (sink-removed) mass against time (sinks.csv), one line per run.
    Extraction(crate::excavation::ExtractionArgs),
}

#[derive(Args, Debug)]
pub struct ContourArgs {
    /// Output directory of a run (holds fluid.h5 and fluid.xdmf).
    pub run_dir: PathBuf,
    /// Field to plot: velocity (magnitude) or pressure.
    #[arg(long, value_enum)]
    pub field: Field,
    /// Slice plane, e.g. z=1.0: the cell layer whose cells contain it is drawn.
    #[arg(long, value_parser = parse_plane)]
    pub plane: Plane,
    /// Frame nearest this simulated time, s (default: the last frame).
    #[arg(long, conflicts_with = "step")]
    pub time: Option<f64>,
    /// Frame of this step number.
    #[arg(long)]
    pub step: Option<u64>,
    /// Output PNG (default `RUN_DIR/FIELD_PLANE_STEP.png`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Image size in pixels, WIDTHxHEIGHT.
    #[arg(long, default_value = "900x700", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Length unit of the scene, for the axis labels (e.g. cm for the seed's cases).
    #[arg(long, default_value = "m")]
    pub length_unit: String,
}

#[derive(Args, Debug)]
pub struct SeriesArgs {
    /// Output directory of a run (holds particles.h5).
    pub run_dir: PathBuf,
    /// Quantity to plot.
    #[arg(long, value_enum)]
    pub quantity: Quantity,
    /// Component (default: magnitude for velocity, z for position; not for the cloud
    /// quantities).
    #[arg(long, value_enum)]
    pub component: Option<Component>,
    /// Particle ids, e.g. 0,1 (default: every particle, at most 12; not for the cloud
    /// quantities, which take every particle).
    #[arg(long, value_delimiter = ',')]
    pub ids: Vec<u32>,
    /// Direction of gravity, for the settling velocity, the floor of the landing time
    /// and the horizontal of the axis angle: -x, x, -y, y, -z or z (as `--down=-z`).
    #[arg(long, default_value = "-z", value_parser = parse_down, allow_hyphen_values = true)]
    pub down: [f64; 3],
    /// Further run directories drawn on the same axes (cloud quantities only), e.g. the
    /// same scene without adhesion.
    #[arg(long = "with", value_name = "RUN_DIR")]
    pub with: Vec<PathBuf>,
    /// Also write the plotted values to this CSV file (`line,time,value`).
    #[arg(long)]
    pub csv: Option<PathBuf>,
    /// Output PNG (default `RUN_DIR/QUANTITY_COMPONENT.png`, `RUN_DIR/QUANTITY.png` for
    /// the cloud quantities).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Image size in pixels, WIDTHxHEIGHT.
    #[arg(long, default_value = "900x600", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Length unit of the scene, for the axis labels (e.g. cm for the seed's cases).
    #[arg(long, default_value = "m")]
    pub length_unit: String,
}

#[derive(Args, Debug)]
#[command(group = clap::ArgGroup::new("frame_choice").args(["step", "time", "times", "frames"]))]
pub struct ParticlesArgs {
    /// Output directory of a run (holds particles.h5; fluid.h5 and fluid.xdmf give the box).
    pub run_dir: PathBuf,
    /// Projection axis: y shows x to the right and z up (seen from -y), x shows y and z
    /// (seen from +x), z shows x and y (seen from above).
    #[arg(long, value_enum, default_value = "y")]
    pub view: View,
    /// Frame of this step number.
    #[arg(long)]
    pub step: Option<u64>,
    /// Frame nearest this simulated time, s (default: the last frame).
    #[arg(long, allow_negative_numbers = true)]
    pub time: Option<f64>,
    /// Panels side by side at the frames nearest these times, s, e.g. 0.1,0.3,0.6.
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
    pub times: Vec<f64>,
    /// Panels side by side at K frames evenly spaced over the run (first to last).
    #[arg(long, value_name = "K")]
    pub frames: Option<usize>,
    /// Sphere colour: speed |v| (colour map and bar), id (cyclic palette) or height z.
    #[arg(long, value_enum, default_value = "speed")]
    pub color: SphereColour,
    /// Output PNG (default `RUN_DIR/particles_VIEW_STEP.png`, or
    /// `RUN_DIR/particles_VIEW_series.png` for `--times`/`--frames`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Image size in pixels, WIDTHxHEIGHT (default 900x700; a series 260 px per panel
    /// + 250 wide, at least 900).
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Length unit of the scene, for the axis labels (e.g. cm for the seed's cases).
    #[arg(long, default_value = "m")]
    pub length_unit: String,
    /// Draw only the spheres whose centres lie in a slab of this thickness across the view
    /// axis (a slice through the scene instead of a projection of all spheres).
    #[arg(long, value_name = "THICKNESS", allow_negative_numbers = true)]
    pub slice: Option<f64>,
    /// Centre of the `--slice` slab on the view axis.
    #[arg(
        long,
        default_value_t = 0.0,
        allow_negative_numbers = true,
        requires = "slice"
    )]
    pub slice_at: f64,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum View {
    X,
    Y,
    Z,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SphereColour {
    Speed,
    Id,
    Z,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Field {
    Velocity,
    Pressure,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quantity {
    Velocity,
    Position,
    /// Mean velocity of the spheres along gravity (`--down`), one line per run.
    SettlingVelocity,
    /// Number of clusters of spheres (gaps below a tenth of the radius), one line per run.
    Clusters,
    /// Angle (degrees) of the long axis of every clump body to the plane perpendicular to
    /// gravity (`--down`), one line per body.
    AxisAngle,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Component {
    X,
    Y,
    Z,
    Magnitude,
}

/// A plane `axis = value` (axis 0, 1, 2 for x, y, z); `text` is the value as given.
#[derive(Clone, Debug, PartialEq)]
pub struct Plane {
    pub axis: usize,
    pub value: f64,
    pub text: String,
}

const AXES: [&str; 3] = ["x", "y", "z"];

fn parse_plane(s: &str) -> Result<Plane, String> {
    let (axis, value) = s
        .split_once('=')
        .ok_or_else(|| format!("expected AXIS=VALUE such as z=1.0, got `{s}`"))?;
    let axis = AXES
        .iter()
        .position(|a| *a == axis.trim())
        .ok_or_else(|| format!("expected the axis x, y or z before `=`, got `{axis}`"))?;
    let text = value.trim().to_string();
    let value: f64 = text
        .parse()
        .ok()
        .filter(|v: &f64| v.is_finite())
        .ok_or_else(|| format!("expected a finite number after `=`, got `{text}`"))?;
    Ok(Plane { axis, value, text })
}

fn parse_down(s: &str) -> Result<[f64; 3], String> {
    let t = s.trim();
    let (sign, axis) = match t.strip_prefix('-') {
        Some(a) => (-1.0, a),
        None => (1.0, t.strip_prefix('+').unwrap_or(t)),
    };
    let axis = AXES
        .iter()
        .position(|a| *a == axis)
        .ok_or_else(|| format!("expected -x, x, -y, y, -z or z, got `{s}`"))?;
    let mut down = [0.0; 3];
    down[axis] = sign;
    Ok(down)
}

pub(crate) fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("expected WIDTHxHEIGHT in pixels, each 200 to 10000, got `{s}`");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    if !(200..=10_000).contains(&w) || !(200..=10_000).contains(&h) {
        return Err(bad());
    }
    Ok((w, h))
}

/// Why a plot was not made.
#[derive(Debug)]
pub enum PlotError {
    /// Bad input (exit 2): the message names the argument or the file.
    Input(String),
    /// The figure could not be drawn or written (exit 1).
    Failed(String),
}

impl std::fmt::Display for PlotError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PlotError::Input(m) | PlotError::Failed(m) => f.write_str(m),
        }
    }
}

pub(crate) fn input<T>(message: impl Into<String>) -> Result<T, PlotError> {
    Err(PlotError::Input(message.into()))
}

/// `grainflow plot ...`: 0 ok, 2 bad input, 1 failure while writing.
pub fn main(args: PlotArgs) -> ExitCode {
    let result = match args.kind {
        PlotKind::Contour(a) => contour(&a),
        PlotKind::Series(a) => series(&a),
        PlotKind::Particles(a) => particles(&a),
        PlotKind::Profile(a) => crate::excavation::profile_plot(&a),
        PlotKind::Extraction(a) => crate::excavation::extraction_plot(&a),
    };
    match result {
        Ok(path) => {
            println!("wrote {}", path.display());
            ExitCode::SUCCESS
        }
        Err(PlotError::Input(m)) => {
            eprintln!("error: {m}");
            ExitCode::from(2)
        }
        Err(PlotError::Failed(m)) => {
            eprintln!("error: {m}");
            ExitCode::from(1)
        }
    }
}

// ---------------------------------------------------------------------------------------
// Reading run directories

/// One frame of an output file: the group `/step_NNNNNNNN` and its `time` attribute.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameInfo {
    pub step: u64,
    pub time: f64,
}

impl FrameInfo {
    pub fn group(&self) -> String {
        format!("step_{:08}", self.step)
    }
}

fn check_run_dir(dir: &Path) -> Result<(), PlotError> {
    if !dir.is_dir() {
        return input(format!(
            "RUN_DIR {}: no such directory (give the output directory of `grainflow run`)",
            dir.display()
        ));
    }
    Ok(())
}

fn open_h5(dir: &Path, name: &str, what: &str) -> Result<hdf5::File, PlotError> {
    check_run_dir(dir)?;
    let path = dir.join(name);
    if !path.is_file() {
        return input(format!("RUN_DIR {}: no {name} ({what})", dir.display()));
    }
    hdf5::File::open(&path)
        .map_err(|e| PlotError::Input(format!("{}: not a readable HDF5 file: {e}", path.display())))
}

/// The frames of an output file, by step.
pub fn list_frames(file: &hdf5::File, path: &Path) -> Result<Vec<FrameInfo>, PlotError> {
    let bad = |e: hdf5::Error| PlotError::Input(format!("{}: {e}", path.display()));
    let mut frames = Vec::new();
    for name in file.member_names().map_err(bad)? {
        let Some(step) = name
            .strip_prefix("step_")
            .and_then(|s| s.parse::<u64>().ok())
        else {
            continue;
        };
        let time: f64 = file
            .group(&name)
            .and_then(|g| g.attr("time"))
            .and_then(|a| a.read_scalar())
            .map_err(bad)?;
        frames.push(FrameInfo { step, time });
    }
    frames.sort_by_key(|f| f.step);
    if frames.is_empty() {
        return input(format!(
            "{}: no frames (groups step_NNNNNNNN)",
            path.display()
        ));
    }
    Ok(frames)
}

/// The structured fluid grid of a run: `n` cells per direction, lower corner, cell size.
#[derive(Clone, Debug, PartialEq)]
pub struct FluidGrid {
    pub n: [usize; 3],
    pub lower: [f64; 3],
    pub h: [f64; 3],
}

impl FluidGrid {
    pub fn upper(&self, axis: usize) -> f64 {
        self.lower[axis] + self.n[axis] as f64 * self.h[axis]
    }
    pub fn cells(&self) -> usize {
        self.n.iter().product()
    }
    /// Lexicographic cell index, x fastest.
    pub fn cell(&self, ijk: [usize; 3]) -> usize {
        ijk[0] + self.n[0] * (ijk[1] + self.n[1] * ijk[2])
    }
    /// Centre coordinate of layer `i` along `axis`.
    pub fn centre(&self, axis: usize, i: usize) -> f64 {
        self.lower[axis] + (i as f64 + 0.5) * self.h[axis]
    }
    /// The cell layer along `axis` that contains `value` (the upper face belongs to the
    /// last layer), or None outside the grid.
    pub fn layer(&self, axis: usize, value: f64) -> Option<usize> {
        let (lo, hi) = (self.lower[axis], self.upper(axis));
        let tol = 1e-9 * (hi - lo);
        if !(value >= lo - tol && value <= hi + tol) {
            return None;
        }
        let k = ((value - lo) / self.h[axis]).floor().max(0.0) as usize;
        Some(k.min(self.n[axis] - 1))
    }

    /// Read the grid from `fluid.xdmf` (`3DCoRectMesh`: node dimensions, origin and
    /// spacing, each in z y x order).
    pub fn from_xdmf(text: &str) -> Result<Self, String> {
        let numbers = |s: &str| -> Option<Vec<f64>> {
            s.split_whitespace().map(|w| w.parse().ok()).collect()
        };
        let dims_at = text
            .find("3DCoRectMesh")
            .ok_or("no 3DCoRectMesh topology")?;
        let rest = &text[dims_at..];
        let dims = rest
            .split_once("Dimensions=\"")
            .and_then(|(_, r)| r.split_once('"'))
            .and_then(|(d, _)| numbers(d))
            .filter(|d| d.len() == 3)
            .ok_or("no topology dimensions")?;
        let geometry = rest
            .split_once("ORIGIN_DXDYDZ")
            .ok_or("no ORIGIN_DXDYDZ geometry")?
            .1;
        let mut items = geometry.split("<DataItem").skip(1).map(|item| {
            item.split_once('>')
                .and_then(|(_, r)| r.split_once("</DataItem>"))
                .and_then(|(v, _)| numbers(v))
                .filter(|v| v.len() == 3)
        });
        let origin = items.next().flatten().ok_or("no grid origin")?;
        let spacing = items.next().flatten().ok_or("no grid spacing")?;
        let mut grid = FluidGrid {
            n: [0; 3],
            lower: [0.0; 3],
            h: [0.0; 3],
        };
        for a in 0..3 {
            // The XDMF lists z, y, x.
            let nodes = dims[2 - a];
            let valid = nodes >= 2.0 && nodes.fract() == 0.0 && spacing[2 - a] > 0.0;
            if !valid {
                return Err("bad grid dimensions or spacing".into());
            }
            grid.n[a] = nodes as usize - 1;
            grid.lower[a] = origin[2 - a];
            grid.h[a] = spacing[2 - a];
        }
        Ok(grid)
    }
}

/// One frame of `fluid.h5`.
#[derive(Clone, Debug)]
pub struct FluidFrame {
    pub info: FrameInfo,
    /// Cell-centre velocity, one `[u, v, w]` per cell.
    pub velocity: Vec<[f64; 3]>,
    pub pressure: Vec<f64>,
}

/// `fluid.h5` and the grid of `fluid.xdmf` of a run directory.
pub struct FluidRun {
    pub dir: PathBuf,
    pub grid: FluidGrid,
    pub frames: Vec<FrameInfo>,
    file: hdf5::File,
}

impl FluidRun {
    pub fn open(dir: &Path) -> Result<Self, PlotError> {
        let file = open_h5(
            dir,
            "fluid.h5",
            "the scene has no fluid grid, or the run wrote no frame",
        )?;
        let xdmf = dir.join("fluid.xdmf");
        let text = std::fs::read_to_string(&xdmf).map_err(|e| {
            PlotError::Input(format!(
                "RUN_DIR {}: cannot read fluid.xdmf (it holds the grid): {e}",
                dir.display()
            ))
        })?;
        let grid = FluidGrid::from_xdmf(&text)
            .map_err(|e| PlotError::Input(format!("{}: {e}", xdmf.display())))?;
        let frames = list_frames(&file, &dir.join("fluid.h5"))?;
        Ok(Self {
            dir: dir.to_path_buf(),
            grid,
            frames,
            file,
        })
    }

    pub fn read(&self, info: FrameInfo) -> Result<FluidFrame, PlotError> {
        let path = self.dir.join("fluid.h5");
        let bad = |e: hdf5::Error| {
            PlotError::Input(format!("{}: frame {}: {e}", path.display(), info.group()))
        };
        let group = self.file.group(&info.group()).map_err(bad)?;
        let v: Vec<f64> = group
            .dataset("velocity")
            .and_then(|d| d.read_raw())
            .map_err(bad)?;
        let pressure: Vec<f64> = group
            .dataset("pressure")
            .and_then(|d| d.read_raw())
            .map_err(bad)?;
        let cells = self.grid.cells();
        if v.len() != 3 * cells || pressure.len() != cells {
            return input(format!(
                "{}: frame {} holds {} velocities and {} pressures; the grid of fluid.xdmf has {cells} cells",
                path.display(),
                info.group(),
                v.len() / 3,
                pressure.len()
            ));
        }
        Ok(FluidFrame {
            info,
            velocity: v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
            pressure,
        })
    }
}

/// One frame of `particles.h5`, rows by ascending id.
#[derive(Clone, Debug)]
pub struct ParticleFrame {
    pub info: FrameInfo,
    pub id: Vec<u32>,
    pub position: Vec<[f64; 3]>,
    pub velocity: Vec<[f64; 3]>,
    pub radius: Vec<f64>,
}

impl ParticleFrame {
    /// Keep the particles whose position satisfies `keep`, in their order.
    pub fn retain(&mut self, keep: impl Fn(&[f64; 3]) -> bool) {
        let rows: Vec<usize> = (0..self.id.len())
            .filter(|&i| keep(&self.position[i]))
            .collect();
        self.id = rows.iter().map(|&i| self.id[i]).collect();
        self.velocity = rows.iter().map(|&i| self.velocity[i]).collect();
        self.radius = rows.iter().map(|&i| self.radius[i]).collect();
        self.position = rows.iter().map(|&i| self.position[i]).collect();
    }
}

/// The history of one particle: the frames in which it exists.
#[derive(Clone, Debug, Default)]
pub struct ParticleSeries {
    pub id: u32,
    pub time: Vec<f64>,
    pub position: Vec<[f64; 3]>,
    pub velocity: Vec<[f64; 3]>,
}

/// `particles.h5` of a run directory.
pub struct ParticleRun {
    pub dir: PathBuf,
    pub frames: Vec<FrameInfo>,
    file: hdf5::File,
}

impl ParticleRun {
    pub fn open(dir: &Path) -> Result<Self, PlotError> {
        let file = open_h5(dir, "particles.h5", "written by every `grainflow run`")?;
        let frames = list_frames(&file, &dir.join("particles.h5"))?;
        Ok(Self {
            dir: dir.to_path_buf(),
            frames,
            file,
        })
    }

    pub fn read(&self, info: FrameInfo) -> Result<ParticleFrame, PlotError> {
        let path = self.dir.join("particles.h5");
        let bad = |e: hdf5::Error| {
            PlotError::Input(format!("{}: frame {}: {e}", path.display(), info.group()))
        };
        let group = self.file.group(&info.group()).map_err(bad)?;
        let id: Vec<u32> = group
            .dataset("id")
            .and_then(|d| d.read_raw())
            .map_err(bad)?;
        let vec3 = |name: &str| -> Result<Vec<[f64; 3]>, PlotError> {
            let raw: Vec<f64> = group
                .dataset(name)
                .and_then(|d| d.read_raw())
                .map_err(bad)?;
            if raw.len() != 3 * id.len() {
                return input(format!(
                    "{}: frame {}: {name} has {} values for {} particles",
                    path.display(),
                    info.group(),
                    raw.len(),
                    id.len()
                ));
            }
            Ok(raw.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
        };
        let position = vec3("position")?;
        let velocity = vec3("velocity")?;
        let radius: Vec<f64> = group
            .dataset("radius")
            .and_then(|d| d.read_raw())
            .map_err(bad)?;
        Ok(ParticleFrame {
            info,
            id,
            position,
            velocity,
            radius,
        })
    }

    /// The frame with this step, if the file has one.
    pub fn frame_at_step(&self, step: u64) -> Option<FrameInfo> {
        self.frames.iter().copied().find(|f| f.step == step)
    }

    /// Histories of `ids` over all frames (in the order of `ids`). An id that no frame
    /// holds is bad input naming `--ids`.
    pub fn series(&self, ids: &[u32]) -> Result<Vec<ParticleSeries>, PlotError> {
        let mut out: Vec<ParticleSeries> = ids
            .iter()
            .map(|&id| ParticleSeries {
                id,
                ..Default::default()
            })
            .collect();
        for &info in &self.frames {
            let frame = self.read(info)?;
            for s in &mut out {
                if let Some(row) = frame_row(&frame.id, s.id) {
                    s.time.push(info.time);
                    s.position.push(frame.position[row]);
                    s.velocity.push(frame.velocity[row]);
                }
            }
        }
        let missing: Vec<String> = out
            .iter()
            .filter(|s| s.time.is_empty())
            .map(|s| s.id.to_string())
            .collect();
        if !missing.is_empty() {
            let last = self.read(*self.frames.last().expect("frames are not empty"))?;
            let known = match (last.id.first(), last.id.last()) {
                (Some(a), Some(b)) => format!("ids {a} to {b} in the last frame"),
                _ => "no particles".to_string(),
            };
            return input(format!(
                "--ids: no particle with id {} in {} ({known})",
                missing.join(", "),
                self.dir.join("particles.h5").display()
            ));
        }
        Ok(out)
    }
}

/// Row of `id` in a frame (rows are sorted by id; fall back to a scan otherwise).
fn frame_row(ids: &[u32], id: u32) -> Option<usize> {
    match ids.binary_search(&id) {
        Ok(r) => Some(r),
        Err(_) => ids.iter().position(|&k| k == id),
    }
}

/// The frame of step `step`, the one nearest `time`, or the last.
fn pick_frame(
    frames: &[FrameInfo],
    time: Option<f64>,
    step: Option<u64>,
    file: &Path,
) -> Result<FrameInfo, PlotError> {
    let last = *frames.last().expect("frames are not empty");
    if let Some(step) = step {
        return frames.iter().copied().find(|f| f.step == step).map_or_else(
            || {
                let list: Vec<String> = frames.iter().take(8).map(|f| f.step.to_string()).collect();
                let more = if frames.len() > 8 {
                    format!(", ... {}", last.step)
                } else {
                    String::new()
                };
                input(format!(
                    "--step: no frame of step {step} in {} (steps {}{more})",
                    file.display(),
                    list.join(", ")
                ))
            },
            Ok,
        );
    }
    match time {
        None => Ok(last),
        Some(t) if !t.is_finite() => input(format!("--time: expected a finite time, got {t}")),
        Some(t) => Ok(nearest_frame(frames, t)),
    }
}

fn nearest_frame(frames: &[FrameInfo], t: f64) -> FrameInfo {
    frames
        .iter()
        .copied()
        .min_by(|a, b| (a.time - t).abs().total_cmp(&(b.time - t).abs()))
        .expect("frames are not empty")
}

/// The frame nearest `t`, which must lie within the run (`arg` names the option).
pub(crate) fn frame_in_run(
    frames: &[FrameInfo],
    t: f64,
    arg: &str,
    file: &Path,
) -> Result<FrameInfo, PlotError> {
    let (first, last) = (frames[0].time, frames[frames.len() - 1].time);
    let tol = 1e-9 * first.abs().max(last.abs()).max(last - first);
    if !(t >= first - tol && t <= last + tol) {
        return input(format!(
            "{arg} {t}: outside the run ({} has frames from t = {} to {} s)",
            file.display(),
            fmt_g(first),
            fmt_g(last)
        ));
    }
    Ok(nearest_frame(frames, t))
}

// ---------------------------------------------------------------------------------------
// Font and colours

static FONT: OnceLock<Result<(), String>> = OnceLock::new();

/// Register DejaVu Sans (or `GRAINFLOW_FONT`) as plotters' `sans-serif` font, once.
pub fn register_font() -> Result<(), PlotError> {
    FONT.get_or_init(|| {
        let path = std::env::var_os("GRAINFLOW_FONT")
            .map(PathBuf::from)
            .unwrap_or_else(|| PathBuf::from(DEFAULT_FONT));
        let bytes = std::fs::read(&path).map_err(|e| {
            format!(
                "font {} not found ({e}): plots need DejaVu Sans; run `bash scripts/setup.sh` \
                 (installs fonts-dejavu-core) or set GRAINFLOW_FONT to a TrueType font file",
                path.display()
            )
        })?;
        // plotters keeps a reference for the life of the process.
        let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
        plotters::style::register_font("sans-serif", FontStyle::Normal, bytes)
            .map_err(|_| format!("font {}: not a TrueType/OpenType font", path.display()))
    })
    .clone()
    .map_err(PlotError::Input)
}

/// Viridis (the default colour map of matplotlib, van der Walt & Smith 2015) at eleven
/// evenly spaced points, interpolated linearly in between.
const VIRIDIS: [[u8; 3]; 11] = [
    [0x44, 0x01, 0x54],
    [0x48, 0x24, 0x75],
    [0x41, 0x44, 0x87],
    [0x35, 0x5f, 0x8d],
    [0x2a, 0x78, 0x8e],
    [0x21, 0x91, 0x8c],
    [0x22, 0xa8, 0x84],
    [0x44, 0xbf, 0x70],
    [0x7a, 0xd1, 0x51],
    [0xbd, 0xdf, 0x26],
    [0xfd, 0xe7, 0x25],
];

/// The colour of `s` in 0..=1 (clamped; NaN is grey).
pub fn colour_map(s: f64) -> RGBColor {
    if s.is_nan() {
        return RGBColor(128, 128, 128);
    }
    let x = s.clamp(0.0, 1.0) * (VIRIDIS.len() - 1) as f64;
    let i = (x.floor() as usize).min(VIRIDIS.len() - 2);
    let t = x - i as f64;
    let mix = |c: usize| {
        let (a, b) = (VIRIDIS[i][c] as f64, VIRIDIS[i + 1][c] as f64);
        (a + t * (b - a)).round() as u8
    };
    RGBColor(mix(0), mix(1), mix(2))
}

/// Distinct line colours (Okabe & Ito 2008, colour-blind safe, plus greys and darks).
const LINE_COLOURS: [RGBColor; 12] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
    RGBColor(240, 228, 66),
    RGBColor(120, 120, 120),
    RGBColor(130, 40, 40),
    RGBColor(40, 40, 130),
    RGBColor(40, 110, 40),
];

/// Tick label with as many digits as the span of the axis needs, trailing zeros cut
/// (ticks fall on round numbers).
fn tick_label(v: f64, span: f64) -> String {
    let big = v.abs().max(span);
    if v == 0.0 || v.abs() < 1e-9 * span {
        return "0".into();
    }
    if !(1e-3..1e5).contains(&big) || span < 1e-4 * big {
        return format!("{v:.2e}");
    }
    let digits = (3.0 - span.log10().floor()).clamp(0.0, 9.0) as usize;
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// Finite min and max of `values`, widened when they coincide.
fn value_range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if lo > hi {
        return None;
    }
    if hi - lo <= 1e-12 * lo.abs().max(hi.abs()) || hi == lo {
        let pad = if lo == 0.0 { 1.0 } else { 0.05 * lo.abs() };
        return Some((lo - pad, hi + pad));
    }
    Some((lo, hi))
}

/// A white PNG canvas of `size` at `out` with `title` on top; returns the area under it.
fn titled_canvas<'a>(
    out: &'a Path,
    size: (u32, u32),
    title: &str,
) -> Result<DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>, PlotError> {
    let fail = draw_err(out);
    let root = BitMapBackend::new(out, size).into_drawing_area();
    root.fill(&WHITE).map_err(&fail)?;
    let title_px = (size.1 as f64 * 0.03).clamp(14.0, 22.0);
    root.titled(title, ("sans-serif", title_px)).map_err(&fail)
}

fn draw_err<E: std::fmt::Display>(out: &Path) -> impl Fn(E) -> PlotError + '_ {
    move |e| PlotError::Failed(format!("cannot draw {}: {e}", out.display()))
}

// ---------------------------------------------------------------------------------------
// Contour slices

/// The horizontal and vertical axes of a figure normal to `axis`: (y, z) for x, (x, z)
/// for y, (x, y) for z.
fn plane_axes(axis: usize) -> [usize; 2] {
    match axis {
        0 => [1, 2],
        1 => [0, 2],
        _ => [0, 1],
    }
}

/// A 2D slice of a cell field: `values[i + nu * j]` at the centres of the in-plane cells,
/// `u` the horizontal and `v` the vertical axis of the figure.
#[derive(Clone, Debug)]
pub struct Slice {
    pub axes: [usize; 2],
    pub n: [usize; 2],
    pub lower: [f64; 2],
    pub upper: [f64; 2],
    pub h: [f64; 2],
    pub layer: usize,
    pub values: Vec<f64>,
}

impl Slice {
    /// Cut `field` (one value per cell) at layer `layer` normal to `axis`. Horizontal and
    /// vertical axes: (x, y) for a z-plane, (x, z) for a y-plane, (y, z) for an x-plane.
    pub fn cut(grid: &FluidGrid, axis: usize, layer: usize, field: impl Fn(usize) -> f64) -> Self {
        let axes = plane_axes(axis);
        let n = [grid.n[axes[0]], grid.n[axes[1]]];
        let mut values = Vec::with_capacity(n[0] * n[1]);
        for j in 0..n[1] {
            for i in 0..n[0] {
                let mut ijk = [0; 3];
                ijk[axis] = layer;
                ijk[axes[0]] = i;
                ijk[axes[1]] = j;
                values.push(field(grid.cell(ijk)));
            }
        }
        Slice {
            axes,
            n,
            lower: [grid.lower[axes[0]], grid.lower[axes[1]]],
            upper: [grid.upper(axes[0]), grid.upper(axes[1])],
            h: [grid.h[axes[0]], grid.h[axes[1]]],
            layer,
            values,
        }
    }

    /// Bilinear interpolation between the cell centres (constant beyond the outer
    /// centres) at in-plane point (u, v).
    pub fn sample(&self, u: f64, v: f64) -> f64 {
        let along = |d: usize, x: f64| -> (usize, usize, f64) {
            let f = ((x - self.lower[d]) / self.h[d] - 0.5).clamp(0.0, (self.n[d] - 1) as f64);
            let i0 = (f.floor() as usize).min(self.n[d] - 1);
            let i1 = (i0 + 1).min(self.n[d] - 1);
            (i0, i1, f - i0 as f64)
        };
        let (i0, i1, s) = along(0, u);
        let (j0, j1, t) = along(1, v);
        let at = |i: usize, j: usize| self.values[i + self.n[0] * j];
        (1.0 - t) * ((1.0 - s) * at(i0, j0) + s * at(i1, j0))
            + t * ((1.0 - s) * at(i0, j1) + s * at(i1, j1))
    }
}

fn contour(a: &ContourArgs) -> Result<PathBuf, PlotError> {
    let run = FluidRun::open(&a.run_dir)?;
    let grid = &run.grid;
    let axis = a.plane.axis;
    let layer = grid.layer(axis, a.plane.value).map_or_else(
        || {
            input(format!(
                "--plane {}={}: outside the fluid domain, {} from {} to {}",
                AXES[axis],
                a.plane.text,
                AXES[axis],
                grid.lower[axis],
                grid.upper(axis)
            ))
        },
        Ok,
    )?;
    let info = pick_frame(&run.frames, a.time, a.step, &run.dir.join("fluid.h5"))?;
    let frame = run.read(info)?;
    let slice = Slice::cut(grid, axis, layer, |c| match a.field {
        Field::Velocity => {
            let u = frame.velocity[c];
            (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt()
        }
        Field::Pressure => frame.pressure[c],
    });
    // Spheres cutting the plane, from the particle frame of the same step.
    let mut circles = Vec::new();
    if let Ok(particles) = ParticleRun::open(&a.run_dir) {
        if let Some(pi) = particles.frame_at_step(info.step) {
            let pf = particles.read(pi)?;
            for (p, &r) in pf.position.iter().zip(&pf.radius) {
                let d = p[axis] - a.plane.value;
                if d.abs() < r {
                    circles.push(([p[slice.axes[0]], p[slice.axes[1]]], (r * r - d * d).sqrt()));
                }
            }
        }
    }
    let out = a.out.clone().unwrap_or_else(|| {
        let field = match a.field {
            Field::Velocity => "velocity",
            Field::Pressure => "pressure",
        };
        a.run_dir.join(format!(
            "{field}_{}{}_{:08}.png",
            AXES[axis], a.plane.text, info.step
        ))
    });
    register_font()?;
    let unit = &a.length_unit;
    let (name, bar_label) = match a.field {
        Field::Velocity => ("velocity magnitude |u|", format!("|u| ({unit}/s)")),
        Field::Pressure => ("pressure p/ρ_f", format!("p/ρ_f ({unit}²/s²)")),
    };
    let title = format!(
        "{name} at {}={} (cell layer {} of {}, centre {}), t = {} s (step {})",
        AXES[axis],
        a.plane.text,
        layer,
        grid.n[axis],
        fmt_g(grid.centre(axis, layer)),
        fmt_g(info.time),
        info.step
    );
    let area = draw_contour(&slice, &circles, &title, &bar_label, unit, a.size, &out)?;
    println!(
        "plot area: x {}..{}, y {}..{} px; {} from {} to {}",
        area.0.start,
        area.0.end,
        area.1.start,
        area.1.end,
        bar_label,
        fmt_g(area.2 .0),
        fmt_g(area.2 .1)
    );
    Ok(out)
}

/// Short number: 4 significant digits, no trailing zeros.
fn fmt_g(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let e = x.abs().log10().floor() as i32;
    if !(-4..6).contains(&e) {
        return format!("{x:.3e}");
    }
    let digits = (3 - e).max(0) as usize;
    let s = format!("{x:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

type PixelRange = (std::ops::Range<i32>, std::ops::Range<i32>, (f64, f64));

/// Draw the slice; returns the pixel ranges of the plot area and the colour range.
/// The axes of a map (a contour or a particle view, equal scales): the two axis titles
/// `descs`, ticks about every 70 pixels across and 45 up the plot area of `pixels`, tick
/// labels to the digits the axis `spans` need, no grid lines.
fn draw_map_axes<DB: DrawingBackend>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    descs: &[String; 2],
    pixels: (u32, u32),
    spans: (f64, f64),
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc(&descs[0])
        .y_desc(&descs[1])
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 16))
        .x_labels((pixels.0 as usize / 70).clamp(2, 10))
        .y_labels((pixels.1 as usize / 45).clamp(2, 12))
        .x_label_formatter(&|x| tick_label(*x, spans.0))
        .y_label_formatter(&|y| tick_label(*y, spans.1))
        .draw()
}

fn draw_contour(
    slice: &Slice,
    circles: &[([f64; 2], f64)],
    title: &str,
    bar_label: &str,
    unit: &str,
    size: (u32, u32),
    out: &Path,
) -> Result<PixelRange, PlotError> {
    let fail = draw_err(out);
    let (lo, hi) = value_range(slice.values.iter().copied()).ok_or_else(|| {
        PlotError::Input(format!(
            "the slice holds no finite value ({})",
            out.display()
        ))
    })?;
    let body = titled_canvas(out, size, title)?;
    let (bw, bh) = body.dim_in_pixel();
    // Plot area with the physical aspect ratio; the block [labels, plot, colour bar,
    // bar labels] is centred in the image.
    let (left_labels, bottom_labels, pad) = (80u32, 55u32, 12u32);
    let fixed = left_labels + pad + BAR_BLOCK;
    let avail_w = bw.saturating_sub(fixed + 2 * pad).max(20) as f64;
    let avail_h = bh.saturating_sub(bottom_labels + 2 * pad).max(20) as f64;
    let (lu, lv) = (
        slice.upper[0] - slice.lower[0],
        slice.upper[1] - slice.lower[1],
    );
    let scale = (avail_w / lu).min(avail_h / lv);
    let (pw, ph) = ((lu * scale) as u32, (lv * scale) as u32);
    let offset = bw.saturating_sub(fixed + pw) / 2;
    let extra_h = (avail_h as u32).saturating_sub(ph);
    let (top, bottom) = (pad + extra_h / 2, pad + extra_h - extra_h / 2);
    let split = (offset + left_labels + pw + pad).min(bw - 1);
    let (main, bar) = body.split_horizontally(split);
    let mut chart = ChartBuilder::on(&main)
        .margin_top(top)
        .margin_bottom(bottom)
        .margin_left(offset)
        .margin_right(pad)
        .x_label_area_size(bottom_labels)
        .y_label_area_size(left_labels)
        .build_cartesian_2d(
            slice.lower[0]..slice.upper[0],
            slice.lower[1]..slice.upper[1],
        )
        .map_err(&fail)?;
    {
        let plot = chart.plotting_area().strip_coord_spec();
        let (w, h) = plot.dim_in_pixel();
        for py in 0..h {
            let v = slice.upper[1] - (py as f64 + 0.5) / h as f64 * lv;
            for px in 0..w {
                let u = slice.lower[0] + (px as f64 + 0.5) / w as f64 * lu;
                let s = (slice.sample(u, v) - lo) / (hi - lo);
                plot.draw_pixel((px as i32, py as i32), &colour_map(s))
                    .map_err(&fail)?;
            }
        }
    }
    let (du, dv) = (AXES[slice.axes[0]], AXES[slice.axes[1]]);
    let descs = [format!("{du} ({unit})"), format!("{dv} ({unit})")];
    draw_map_axes(&mut chart, &descs, (pw, ph), (lu, lv)).map_err(&fail)?;
    chart
        .draw_series(circles.iter().map(|&(c, r)| {
            let pts: Vec<(f64, f64)> = (0..=72)
                .map(|k| {
                    let phi = k as f64 / 72.0 * std::f64::consts::TAU;
                    (c[0] + r * phi.cos(), c[1] + r * phi.sin())
                })
                .collect();
            PathElement::new(pts, WHITE.stroke_width(2))
        }))
        .map_err(&fail)?;
    let range = chart.plotting_area().get_pixel_range();

    draw_colour_bar(&bar, top, ph, (lo, hi), bar_label, out)?;
    body.present().map_err(&fail)?;
    Ok((range.0, range.1, (lo, hi)))
}

/// A colour bar block: the gap to the plot area, the bar, then its ticks and label.
const BAR_GAP: u32 = 24;
const BAR_W: u32 = 36;
const BAR_BLOCK: u32 = BAR_GAP + BAR_W + 95;

/// A vertical bar of [`colour_map`] from `lo` (bottom) to `hi` (top) with its ticks and
/// `label`, at the left of `area`: `top` pixels below its top and `height` pixels tall
/// (those of the plot area beside it).
fn draw_colour_bar(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    top: u32,
    height: u32,
    (lo, hi): (f64, f64),
    label: &str,
    out: &Path,
) -> Result<(), PlotError> {
    let fail = draw_err(out);
    let (w, h) = area.dim_in_pixel();
    let mut bar_chart = ChartBuilder::on(area)
        .margin_top(top)
        .margin_bottom(h.saturating_sub(top + height))
        .margin_left(BAR_GAP)
        .margin_right(w.saturating_sub(BAR_BLOCK))
        .set_label_area_size(LabelAreaPosition::Right, BAR_BLOCK - BAR_GAP - BAR_W)
        .build_cartesian_2d(0.0..1.0, lo..hi)
        .map_err(&fail)?;
    {
        let plot = bar_chart.plotting_area().strip_coord_spec();
        let (w, h) = plot.dim_in_pixel();
        for py in 0..h {
            let c = colour_map(1.0 - (py as f64 + 0.5) / h as f64);
            for px in 0..w {
                plot.draw_pixel((px as i32, py as i32), &c).map_err(&fail)?;
            }
        }
    }
    bar_chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_desc(label)
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 16))
        .y_labels((height as usize / 45).clamp(2, 10))
        .y_label_formatter(&|v| tick_label(*v, hi - lo))
        .draw()
        .map_err(&fail)?;
    Ok(())
}

// ---------------------------------------------------------------------------------------
// Time series

const MAX_DEFAULT_IDS: usize = 12;

fn series(a: &SeriesArgs) -> Result<PathBuf, PlotError> {
    if matches!(a.quantity, Quantity::SettlingVelocity | Quantity::Clusters) {
        return cloud_series(a);
    }
    if a.quantity == Quantity::AxisAngle {
        return axis_angle_series(a);
    }
    if !a.with.is_empty() {
        return input(
            "--with: other runs are drawn only for --quantity settling-velocity or clusters",
        );
    }
    let run = ParticleRun::open(&a.run_dir)?;
    let ids = if a.ids.is_empty() {
        let last = run.read(*run.frames.last().expect("frames are not empty"))?;
        if last.id.is_empty() {
            return input(format!(
                "RUN_DIR {}: particles.h5 holds no particles",
                a.run_dir.display()
            ));
        }
        if last.id.len() > MAX_DEFAULT_IDS {
            eprintln!(
                "note: {} particles; plotting ids {} to {} (choose with --ids)",
                last.id.len(),
                last.id[0],
                last.id[MAX_DEFAULT_IDS - 1]
            );
        }
        last.id.iter().copied().take(MAX_DEFAULT_IDS).collect()
    } else {
        a.ids.clone()
    };
    let histories = run.series(&ids)?;
    let component = a.component.unwrap_or(match a.quantity {
        Quantity::Position => Component::Z,
        _ => Component::Magnitude,
    });
    let pick = |v: &[f64; 3]| match component {
        Component::X => v[0],
        Component::Y => v[1],
        Component::Z => v[2],
        Component::Magnitude => (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt(),
    };
    let lines: Vec<(String, Vec<(f64, f64)>)> = histories
        .iter()
        .map(|s| {
            let values = match a.quantity {
                Quantity::Position => &s.position,
                _ => &s.velocity,
            };
            (
                format!("id {}", s.id),
                s.time
                    .iter()
                    .zip(values)
                    .map(|(&t, v)| (t, pick(v)))
                    .collect(),
            )
        })
        .collect();
    let (qname, sym) = match a.quantity {
        Quantity::Position => ("position", "x"),
        _ => ("velocity", "u"),
    };
    let cname = match component {
        Component::X => "x",
        Component::Y => "y",
        Component::Z => "z",
        Component::Magnitude => "magnitude",
    };
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| a.run_dir.join(format!("{qname}_{cname}.png")));
    register_font()?;
    let unit = &a.length_unit;
    let y_desc = match (a.quantity, component) {
        (Quantity::Position, Component::Magnitude) => format!("|x| ({unit})"),
        (Quantity::Position, _) => format!("{cname} ({unit})"),
        (_, Component::Magnitude) => format!("|u| ({unit}/s)"),
        (_, _) => format!("{sym}_{cname} ({unit}/s)"),
    };
    let id_list: Vec<String> = ids.iter().map(u32::to_string).collect();
    let symbol = y_desc.split(" (").next().unwrap_or_default();
    let title = format!(
        "particle {qname} {symbol} against time (id {})",
        if id_list.len() > 6 {
            format!("{} ... {}", id_list[0], id_list[id_list.len() - 1])
        } else {
            id_list.join(", ")
        }
    );
    write_series_csv(a.csv.as_deref(), &lines)?;
    let text = LineChart {
        title: &title,
        x_desc: "t (s)",
        y_desc: &y_desc,
    };
    draw_lines(&lines, &text, a.size, &out)?;
    Ok(out)
}

/// The cloud state (`src/cloud.rs`) at every frame of `particles.h5` of a run, in the
/// fluid box of its `fluid.xdmf`.
pub fn cloud_history(dir: &Path) -> Result<Vec<CloudState>, PlotError> {
    let run = ParticleRun::open(dir)?;
    if !dir.join("fluid.xdmf").is_file() {
        return input(format!(
            "RUN_DIR {}: no fluid.xdmf (the cloud quantities need the fluid box for the floor)",
            dir.display()
        ));
    }
    let grid = FluidRun::open(dir)?.grid;
    let lower = grid.lower;
    let upper = [0, 1, 2].map(|d| grid.upper(d));
    run.frames
        .iter()
        .map(|&info| {
            let f = run.read(info)?;
            Ok(CloudState::of(
                info.time,
                &f.position,
                &f.radius,
                &f.velocity,
                (lower, upper),
            ))
        })
        .collect()
}

/// `series` of a cloud quantity: one line per run (`RUN_DIR`, then `--with`), labelled
/// with the run directory's name and its landing time.
fn cloud_series(a: &SeriesArgs) -> Result<PathBuf, PlotError> {
    if a.component.is_some() || !a.ids.is_empty() {
        return input(
            "--component and --ids are for --quantity velocity or position: the cloud quantities take every particle",
        );
    }
    let (qname, y_desc) = match a.quantity {
        Quantity::Clusters => ("clusters", "clusters".to_string()),
        _ => (
            "settling_velocity",
            format!("mean velocity along gravity ({}/s)", a.length_unit),
        ),
    };
    let mut lines = Vec::new();
    for dir in std::iter::once(&a.run_dir).chain(&a.with) {
        let history = cloud_history(dir)?;
        let samples = history.iter().map(|s| s.sample(a.down));
        let landing = crate::cloud::landing_time(samples.clone());
        let name = dir.file_name().map_or_else(
            || dir.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        let landed = match landing {
            Some(t) => format!("lands at {} s", fmt_g(t)),
            None => "not landed".to_string(),
        };
        println!("{}: {landed}", dir.display());
        let points = match a.quantity {
            Quantity::Clusters => history
                .iter()
                .map(|s| (s.time, s.clusters as f64))
                .collect(),
            _ => samples.map(|s| (s.time, s.settling_velocity)).collect(),
        };
        lines.push((format!("{name} ({landed})"), points));
    }
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| a.run_dir.join(format!("{qname}.png")));
    register_font()?;
    let title = match a.quantity {
        Quantity::Clusters => "number of clusters of spheres (gap < r/10) against time",
        _ => "mean settling velocity of the spheres against time",
    };
    write_series_csv(a.csv.as_deref(), &lines)?;
    let text = LineChart {
        title,
        x_desc: "t (s)",
        y_desc: &y_desc,
    };
    draw_lines(&lines, &text, a.size, &out)?;
    Ok(out)
}

/// Angle (degrees) of the long axis `a` to the plane perpendicular to the unit vector
/// `down`: `asin(|a . down| / |a|)`.
pub fn axis_angle(axis: [f64; 3], down: [f64; 3]) -> f64 {
    let along: f64 = (0..3).map(|d| axis[d] * down[d]).sum();
    let length = (0..3).map(|d| axis[d] * axis[d]).sum::<f64>().sqrt();
    (along.abs() / length).min(1.0).asin().to_degrees()
}

/// `series` of `--quantity axis-angle`: for every clump body of the run (the `clump` and
/// `axis` fields of `particles.h5`: the body of each member row and the body's long
/// principal axis), the angle of its long axis to the plane perpendicular to `--down`
/// against time ([`axis_angle`]), one line per body (at most 12).
fn axis_angle_series(a: &SeriesArgs) -> Result<PathBuf, PlotError> {
    if a.component.is_some() || !a.ids.is_empty() || !a.with.is_empty() {
        return input("--component, --ids and --with are not for --quantity axis-angle");
    }
    let run = ParticleRun::open(&a.run_dir)?;
    let path = a.run_dir.join("particles.h5");
    let mut lines: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    for &info in &run.frames {
        let bad = |e: hdf5::Error| {
            PlotError::Input(format!(
                "{}: frame {}: {e} (--quantity axis-angle needs a run with clumps)",
                path.display(),
                info.group()
            ))
        };
        let group = run.file.group(&info.group()).map_err(bad)?;
        let body: Vec<u32> = group
            .dataset("clump")
            .and_then(|d| d.read_raw())
            .map_err(bad)?;
        let axis: Vec<f64> = group
            .dataset("axis")
            .and_then(|d| d.read_raw())
            .map_err(bad)?;
        if axis.len() != 3 * body.len() {
            return input(format!(
                "{}: frame {}: {} axis values for {} rows",
                path.display(),
                info.group(),
                axis.len(),
                body.len()
            ));
        }
        let mut seen = Vec::new();
        for (row, &b) in body.iter().enumerate() {
            if b == u32::MAX || seen.contains(&b) || seen.len() == MAX_DEFAULT_IDS {
                continue;
            }
            seen.push(b);
            let v = [axis[3 * row], axis[3 * row + 1], axis[3 * row + 2]];
            let name = format!("body {b}");
            let angle = (info.time, axis_angle(v, a.down));
            match lines.iter_mut().find(|l| l.0 == name) {
                Some(line) => line.1.push(angle),
                None => lines.push((name, vec![angle])),
            }
        }
    }
    if lines.is_empty() {
        return input(format!(
            "RUN_DIR {}: particles.h5 holds no clump",
            a.run_dir.display()
        ));
    }
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| a.run_dir.join("axis_angle.png"));
    register_font()?;
    write_series_csv(a.csv.as_deref(), &lines)?;
    let text = LineChart {
        title: "angle of the long axis to the horizontal against time",
        x_desc: "t (s)",
        y_desc: "angle (degrees)",
    };
    draw_lines(&lines, &text, a.size, &out)?;
    Ok(out)
}

/// The lines of a series plot as CSV, `line,time,value`, if a file is asked for.
pub(crate) fn write_series_csv(
    path: Option<&Path>,
    lines: &[(String, Vec<(f64, f64)>)],
) -> Result<(), PlotError> {
    let Some(path) = path else {
        return Ok(());
    };
    let mut text = String::from("line,time,value\n");
    for (name, points) in lines {
        for (t, v) in points {
            text.push_str(&format!("\"{name}\",{t:e},{v:e}\n"));
        }
    }
    std::fs::write(path, text)
        .map_err(|e| PlotError::Failed(format!("--csv {}: cannot write: {e}", path.display())))
}

/// The texts of a line chart.
pub(crate) struct LineChart<'a> {
    pub title: &'a str,
    pub x_desc: &'a str,
    pub y_desc: &'a str,
}

/// Named lines of `(x, y)` points on one pair of axes, with a legend.
pub(crate) fn draw_lines(
    lines: &[(String, Vec<(f64, f64)>)],
    chart_text: &LineChart,
    size: (u32, u32),
    out: &Path,
) -> Result<(), PlotError> {
    let LineChart {
        title,
        x_desc,
        y_desc,
    } = *chart_text;
    let fail = draw_err(out);
    let (t0, t1) = value_range(lines.iter().flat_map(|l| l.1.iter().map(|p| p.0)))
        .ok_or_else(|| PlotError::Input("no frames to plot".into()))?;
    let (y0, y1) = value_range(lines.iter().flat_map(|l| l.1.iter().map(|p| p.1)))
        .ok_or_else(|| PlotError::Input("no finite values to plot".into()))?;
    let pad = 0.05 * (y1 - y0);
    let (y0, y1) = (y0 - pad, y1 + pad);
    let root: DrawingArea<BitMapBackend, Shift> = BitMapBackend::new(out, size).into_drawing_area();
    root.fill(&WHITE).map_err(&fail)?;
    let title_px = (size.1 as f64 * 0.035).clamp(14.0, 22.0);
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", title_px))
        .margin(15)
        .x_label_area_size(55)
        .y_label_area_size(90)
        .build_cartesian_2d(t0..t1, y0..y1)
        .map_err(&fail)?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 16))
        .bold_line_style(RGBColor(210, 210, 210))
        .light_line_style(RGBColor(240, 240, 240))
        .x_label_formatter(&|x| tick_label(*x, t1 - t0))
        .y_label_formatter(&|y| tick_label(*y, y1 - y0))
        .draw()
        .map_err(&fail)?;
    for (k, (id, points)) in lines.iter().enumerate() {
        let colour = LINE_COLOURS[k % LINE_COLOURS.len()];
        chart
            .draw_series(LineSeries::new(
                points.iter().copied(),
                colour.stroke_width(2),
            ))
            .map_err(&fail)?
            .label(id.clone())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], colour.stroke_width(2)));
        if points.len() <= 60 {
            chart
                .draw_series(points.iter().map(|&p| Circle::new(p, 3, colour.filled())))
                .map_err(&fail)?;
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(&fail)?;
    root.present().map_err(&fail)?;
    Ok(())
}

// ---------------------------------------------------------------------------------------
// Particle side views

/// A sphere as drawn: centre and radius in the plane of the figure, fill colour.
struct Disc {
    centre: [f64; 2],
    radius: f64,
    colour: RGBColor,
}

/// One panel: its caption and its discs, farthest first.
struct Panel {
    caption: String,
    discs: Vec<Disc>,
}

/// The background of the plot area and the outline of the spheres.
const VIEW_BACKGROUND: RGBColor = RGBColor(240, 244, 250);
const SPHERE_OUTLINE: RGBColor = RGBColor(30, 30, 30);

/// The frames of `--frames`, `--times`, `--time` or `--step` (default: the last).
fn particle_frames(
    a: &ParticlesArgs,
    frames: &[FrameInfo],
    file: &Path,
) -> Result<Vec<FrameInfo>, PlotError> {
    if let Some(k) = a.frames {
        let n = frames.len();
        if k == 0 || k > n {
            return input(format!(
                "--frames {k}: expected 1 to {n} (the frames of {})",
                file.display()
            ));
        }
        if k == 1 {
            return Ok(vec![frames[n - 1]]);
        }
        // Frame indices i (n - 1) / (k - 1), rounded: first to last, distinct.
        return Ok((0..k)
            .map(|i| frames[(2 * i * (n - 1) + k - 1) / (2 * (k - 1))])
            .collect());
    }
    if !a.times.is_empty() {
        return a
            .times
            .iter()
            .map(|&t| frame_in_run(frames, t, "--times", file))
            .collect();
    }
    match a.time {
        Some(t) => frame_in_run(frames, t, "--time", file).map(|f| vec![f]),
        None => pick_frame(frames, None, a.step, file).map(|f| vec![f]),
    }
}

fn particles(a: &ParticlesArgs) -> Result<PathBuf, PlotError> {
    let run = ParticleRun::open(&a.run_dir)?;
    let file = run.dir.join("particles.h5");
    let chosen = particle_frames(a, &run.frames, &file)?;
    let axis = match a.view {
        View::X => 0,
        View::Y => 1,
        View::Z => 2,
    };
    if let Some(w) = a.slice {
        if !(w.is_finite() && w > 0.0 && a.slice_at.is_finite()) {
            return input(format!(
                "--slice {w} --slice-at {}: expected a finite thickness > 0 and a finite centre",
                a.slice_at
            ));
        }
    }
    let mut frames = chosen
        .iter()
        .map(|&f| run.read(f))
        .collect::<Result<Vec<_>, _>>()?;
    if let Some(w) = a.slice {
        for f in &mut frames {
            f.retain(|p| (p[axis] - a.slice_at).abs() <= 0.5 * w);
        }
    }
    if frames.iter().all(|f| f.id.is_empty()) {
        return input(format!(
            "RUN_DIR {}: particles.h5 holds no particles in the chosen frames{}",
            a.run_dir.display(),
            if a.slice.is_some() { " and slice" } else { "" }
        ));
    }
    let axes = plane_axes(axis);
    // The figure's box: the fluid domain, or the spheres' extent over the chosen frames.
    let (lower, upper) = if a.run_dir.join("fluid.h5").is_file() {
        let grid = FluidRun::open(&a.run_dir)?.grid;
        (axes.map(|d| grid.lower[d]), axes.map(|d| grid.upper(d)))
    } else {
        let extent = |d: usize| {
            let spheres = || {
                frames.iter().flat_map(|f| {
                    f.position
                        .iter()
                        .zip(&f.radius)
                        .map(move |(p, r)| (p[d], *r))
                })
            };
            (
                spheres().map(|(x, r)| x - r).fold(f64::INFINITY, f64::min),
                spheres()
                    .map(|(x, r)| x + r)
                    .fold(f64::NEG_INFINITY, f64::max),
            )
        };
        let (e0, e1) = (extent(axes[0]), extent(axes[1]));
        ([e0.0, e1.0], [e0.1, e1.1])
    };
    if !(0..2).all(|k| lower[k].is_finite() && upper[k] > lower[k]) {
        return input(format!(
            "{}: the spheres span no area seen along {} ({} from {} to {}, {} from {} to {})",
            file.display(),
            AXES[axis],
            AXES[axes[0]],
            lower[0],
            upper[0],
            AXES[axes[1]],
            lower[1],
            upper[1]
        ));
    }
    let value = |f: &ParticleFrame, i: usize| match a.color {
        SphereColour::Speed => {
            let v = f.velocity[i];
            (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
        }
        SphereColour::Z => f.position[i][2],
        SphereColour::Id => f64::from(f.id[i]),
    };
    let unit = &a.length_unit;
    let bar = match a.color {
        SphereColour::Id => None,
        colour => {
            let all = frames
                .iter()
                .flat_map(|f| (0..f.id.len()).map(move |i| (f, i)));
            let range = value_range(all.map(|(f, i)| value(f, i))).ok_or_else(|| {
                PlotError::Input(format!("{}: no finite values to colour by", file.display()))
            })?;
            let label = match colour {
                SphereColour::Z => format!("z ({unit})"),
                _ => format!("|v| ({unit}/s)"),
            };
            Some((label, range))
        }
    };
    // Depth toward the viewer (at -y for a y view, +x and +z otherwise): farthest first.
    let toward = if axis == 1 { -1.0 } else { 1.0 };
    let panels: Vec<Panel> = frames
        .iter()
        .map(|f| {
            let mut order: Vec<usize> = (0..f.id.len()).collect();
            order.sort_by(|&i, &j| {
                (toward * f.position[i][axis]).total_cmp(&(toward * f.position[j][axis]))
            });
            let discs = order
                .into_iter()
                .map(|i| Disc {
                    centre: axes.map(|d| f.position[i][d]),
                    radius: f.radius[i],
                    colour: match &bar {
                        Some((_, (lo, hi))) => colour_map((value(f, i) - lo) / (hi - lo)),
                        None => LINE_COLOURS[f.id[i] as usize % LINE_COLOURS.len()],
                    },
                })
                .collect();
            Panel {
                caption: format!("t = {} s (step {})", fmt_g(f.info.time), f.info.step),
                discs,
            }
        })
        .collect();
    let series = a.frames.is_some() || !a.times.is_empty();
    let view = AXES[axis];
    let out = a.out.clone().unwrap_or_else(|| {
        a.run_dir.join(if series {
            format!("particles_{view}_series.png")
        } else {
            format!("particles_{view}_{:08}.png", chosen[0].step)
        })
    });
    let size = a.size.unwrap_or(if series {
        ((260 * panels.len() as u32 + 250).clamp(900, 10_000), 700)
    } else {
        (900, 700)
    });
    register_font()?;
    let what = match a.color {
        SphereColour::Speed => "speed |v|",
        SphereColour::Id => "id",
        SphereColour::Z => "height z",
    };
    let which = match a.slice {
        Some(w) => format!(
            "spheres with {view} in {} +- {} {unit}",
            fmt_g(a.slice_at),
            fmt_g(0.5 * w)
        ),
        None => "spheres".to_string(),
    };
    let title = format!(
        "{which} seen along {view} ({} to the right, {} up), coloured by {what}",
        AXES[axes[0]], AXES[axes[1]]
    );
    let view_box = ViewBox {
        lower,
        upper,
        labels: axes.map(|d| format!("{} ({unit})", AXES[d])),
    };
    let bar_ref = bar.as_ref().map(|(l, r)| (l.as_str(), *r));
    let areas = draw_particles(&panels, &view_box, &title, bar_ref, size, &out)?;
    for ((x, y), f) in areas.iter().zip(&frames) {
        println!(
            "plot area: x {}..{}, y {}..{} px; t = {} s (step {}), {} spheres",
            x.start,
            x.end,
            y.start,
            y.end,
            fmt_g(f.info.time),
            f.info.step,
            f.id.len()
        );
    }
    match &bar {
        Some((label, (lo, hi))) => println!("{label} from {} to {}", fmt_g(*lo), fmt_g(*hi)),
        None => println!("colour by id: {} colours, repeating", LINE_COLOURS.len()),
    }
    Ok(out)
}

/// The box of a side view in the figure's (horizontal, vertical) axes, and their labels.
struct ViewBox {
    lower: [f64; 2],
    upper: [f64; 2],
    labels: [String; 2],
}

/// Pixel ranges (horizontal, vertical) of a plot area in the image.
type AreaRange = (std::ops::Range<i32>, std::ops::Range<i32>);

/// Draw the panels side by side, all with the box `view_box` at one scale, equal in both
/// directions, and one colour bar if `bar` is given. Returns the pixel ranges of the
/// panels' plot areas.
fn draw_particles(
    panels: &[Panel],
    view_box: &ViewBox,
    title: &str,
    bar: Option<(&str, (f64, f64))>,
    size: (u32, u32),
    out: &Path,
) -> Result<Vec<AreaRange>, PlotError> {
    let ViewBox {
        lower,
        upper,
        labels,
    } = view_box;
    let fail = draw_err(out);
    let body = titled_canvas(out, size, title)?;
    let (bw, bh) = body.dim_in_pixel();
    // Per panel [labels, plot area, pad] under a caption; the colour bar after the last;
    // the whole block centred. One scale (pixels per length unit) for both directions.
    let k = panels.len() as u32;
    let (left_labels, bottom_labels, pad, caption) = (80u32, 55u32, 12u32, 30u32);
    let bar_block = if bar.is_some() { BAR_BLOCK } else { 0 };
    let avail_w = (bw.saturating_sub(k * (left_labels + pad) + bar_block + 2 * pad) / k).max(10);
    let avail_h = bh.saturating_sub(caption + bottom_labels + 2 * pad).max(10);
    let (lu, lv) = (upper[0] - lower[0], upper[1] - lower[1]);
    let scale = (avail_w as f64 / lu).min(avail_h as f64 / lv);
    let (pw, ph) = (
        ((lu * scale).round() as u32).max(1),
        ((lv * scale).round() as u32).max(1),
    );
    let panel_w = left_labels + pw + pad;
    let block_w = k * panel_w + bar_block;
    let offset = bw.saturating_sub(block_w) / 2;
    let top = pad + caption + avail_h.saturating_sub(ph) / 2;
    let block = body.margin(0, 0, offset, bw.saturating_sub(offset + block_w));
    let (row, bar_area) = block.split_horizontally(k * panel_w);
    let mut ranges = Vec::new();
    for (panel, area) in panels.iter().zip(row.split_evenly((1, k as usize))) {
        let mut chart = ChartBuilder::on(&area)
            .margin_top(top)
            .margin_bottom(bh.saturating_sub(top + ph + bottom_labels))
            .margin_right(pad)
            .x_label_area_size(bottom_labels)
            .y_label_area_size(left_labels)
            .build_cartesian_2d(lower[0]..upper[0], lower[1]..upper[1])
            .map_err(&fail)?;
        {
            let plot = chart.plotting_area().strip_coord_spec();
            plot.fill(&VIEW_BACKGROUND).map_err(&fail)?;
            let (w, h) = plot.dim_in_pixel();
            let (sx, sy) = (w as f64 / lu, h as f64 / lv);
            for disc in &panel.discs {
                let cx = (disc.centre[0] - lower[0]) * sx;
                let cy = (upper[1] - disc.centre[1]) * sy;
                // At least a pixel across; a 1-pixel outline from 2.5 pixels of radius.
                let r = (disc.radius * sx).max(0.8);
                let rim = if r >= 2.5 { r - 1.0 } else { r };
                let x0 = (cx - r).floor().max(0.0);
                let x1 = (cx + r).ceil().min(w as f64 - 1.0);
                let y0 = (cy - r).floor().max(0.0);
                let y1 = (cy + r).ceil().min(h as f64 - 1.0);
                if x0 > x1 || y0 > y1 {
                    continue;
                }
                for py in y0 as i32..=y1 as i32 {
                    for px in x0 as i32..=x1 as i32 {
                        let d = (px as f64 + 0.5 - cx).hypot(py as f64 + 0.5 - cy);
                        if d <= r {
                            let c = if d > rim {
                                &SPHERE_OUTLINE
                            } else {
                                &disc.colour
                            };
                            plot.draw_pixel((px, py), c).map_err(&fail)?;
                        }
                    }
                }
            }
        }
        draw_map_axes(&mut chart, labels, (pw, ph), (lu, lv)).map_err(&fail)?;
        let style = TextStyle::from(("sans-serif", 16).into_font())
            .pos(Pos::new(HPos::Center, VPos::Bottom));
        area.draw_text(
            &panel.caption,
            &style,
            ((left_labels + pw / 2) as i32, top as i32 - 8),
        )
        .map_err(&fail)?;
        ranges.push(chart.plotting_area().get_pixel_range());
    }
    if let Some((label, range)) = bar {
        draw_colour_bar(&bar_area, top, ph, range, label, out)?;
    }
    body.present().map_err(&fail)?;
    Ok(ranges)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn planes_parse() {
        assert_eq!(parse_plane("z=1.0").unwrap().axis, 2);
        assert_eq!(parse_plane("y = 0.25").unwrap().value, 0.25);
        assert!(parse_plane("w=1").is_err());
        assert!(parse_plane("x=abc").is_err());
        assert!(parse_plane("x").is_err());
    }

    #[test]
    fn grid_from_xdmf_and_layers() {
        let x = "<Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"17 5 5\"/>\n\
                 <Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n\
                 <DataItem Dimensions=\"3\" Format=\"XML\">0e0 0e0 0e0</DataItem>\n\
                 <DataItem Dimensions=\"3\" Format=\"XML\">1.25e-1 1.25e-1 1.25e-1</DataItem>";
        let g = FluidGrid::from_xdmf(x).unwrap();
        assert_eq!(g.n, [4, 4, 16]);
        assert_eq!(g.upper(2), 2.0);
        assert_eq!(g.layer(2, 2.0), Some(15));
        assert_eq!(g.layer(2, 0.0), Some(0));
        assert_eq!(g.layer(1, 0.2), Some(1));
        assert_eq!(g.layer(2, 2.1), None);
    }

    #[test]
    fn colour_map_ends_and_slice_sampling() {
        assert_eq!(colour_map(0.0), RGBColor(0x44, 0x01, 0x54));
        assert_eq!(colour_map(1.0), RGBColor(0xfd, 0xe7, 0x25));
        let g = FluidGrid {
            n: [2, 1, 2],
            lower: [0.0; 3],
            h: [1.0; 3],
        };
        // A y-plane: horizontal x, vertical z; value = z index.
        let s = Slice::cut(&g, 1, 0, |c| (c / 2) as f64);
        assert_eq!(s.axes, [0, 2]);
        assert_eq!(s.sample(0.5, 0.5), 0.0);
        assert_eq!(s.sample(0.5, 1.5), 1.0);
        assert_eq!(s.sample(1.0, 1.0), 0.5);
        assert_eq!(s.sample(0.0, 2.0), 1.0);
    }
}
