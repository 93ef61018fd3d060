//! Excavation profiles of a particle bed (`grainflow plot profile`) and the extracted
//! mass of a run (`grainflow plot extraction`): the suction case's figures
//! (`cases/suction.toml`, docs/suction.md).
//!
//! The bed surface height at distance r from a vertical axis is the equivalent height
//! of the packed bed in the annulus [r, r + dr): the particles are counted in layers of
//! height dz by 32 points of each sphere, each layer's solid fraction phi (sphere
//! volumes over the annulus volume) is divided by the packed fraction phi_ref, and the
//! ratios are summed times dz from the floor up to the first two layers in a row below
//! phi_ref / 4 (the top of the bed: a grain carried up the pipe, above that gap, is not
//! bed; one sparse layer alone is the sampling noise of a small annulus). phi_ref is
//! the solid fraction of the first frame's bed in the profiled cylinder between dz and
//! half its highest centre, away from the floor and the surface.
//!
//! The crater is measured against the first frame's profile, not against a flat far
//! field (a poured bed is not flat: it heaps where it was poured and sags at the walls).
//! The excavation at r is the drop d(r) = h_0(r) - h(r); the crater's depth is the
//! largest drop, its radius the smallest r beyond the deepest annulus at which the drop
//! is back below a tenth of the depth (interpolated linearly), and its volume the bulk
//! (packed) volume sum of d(r) A(r) over the annuli inside that radius. The volume is
//! checked against the particles: the solid volume that left the profiled cylinder over
//! phi_ref is the bulk volume it should be.
use std::path::{Path, PathBuf};

use clap::Args;

use crate::plot::{
    draw_lines, frame_in_run, input, register_font, write_series_csv, LineChart, ParticleFrame,
    ParticleRun, PlotError,
};

#[derive(Args, Debug)]
pub struct ProfileArgs {
    /// Output directory of a run (holds particles.h5).
    pub run_dir: PathBuf,
    /// The vertical axis of the profile, its x,y (e.g. the suction pipe's, 10,10).
    #[arg(long, value_parser = parse_xy)]
    pub axis: [f64; 2],
    /// Times of the profiles, s (the nearest frames), e.g. 0,0.25,0.5,1.
    #[arg(long, value_delimiter = ',', required = true)]
    pub times: Vec<f64>,
    /// Width of the annuli.
    #[arg(long, default_value_t = 0.5)]
    pub dr: f64,
    /// Height of the layers (about a mean grain diameter).
    #[arg(long, default_value_t = 1.0)]
    pub dz: f64,
    /// Outer radius of the profiled cylinder (inside the tank).
    #[arg(long)]
    pub r_max: f64,
    /// Also write the profiles to this CSV file (`line,time,value` = time, r, height).
    #[arg(long)]
    pub csv: Option<PathBuf>,
    /// Output PNG (default `RUN_DIR/profile.png`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Image size in pixels, WIDTHxHEIGHT.
    #[arg(long, default_value = "900x600", value_parser = crate::plot::parse_size)]
    pub size: (u32, u32),
    /// Length unit of the scene, for the axis labels.
    #[arg(long, default_value = "m")]
    pub length_unit: String,
}

#[derive(Args, Debug)]
pub struct ExtractionArgs {
    /// Output directory of a run (holds sinks.csv).
    pub run_dir: PathBuf,
    /// Further run directories drawn on the same axes (e.g. the other friction cases).
    #[arg(long = "with", value_name = "RUN_DIR")]
    pub with: Vec<PathBuf>,
    /// Also write the plotted values to this CSV file (`line,time,value`).
    #[arg(long)]
    pub csv: Option<PathBuf>,
    /// Output PNG (default `RUN_DIR/extraction.png`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Image size in pixels, WIDTHxHEIGHT.
    #[arg(long, default_value = "900x600", value_parser = crate::plot::parse_size)]
    pub size: (u32, u32),
    /// Mass unit of the scene, for the axis label.
    #[arg(long, default_value = "kg")]
    pub mass_unit: String,
}

fn parse_xy(s: &str) -> Result<[f64; 2], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|c| c.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("expected X,Y, e.g. 10,10: {e}"))?;
    match v[..] {
        [x, y] if x.is_finite() && y.is_finite() => Ok([x, y]),
        _ => Err(format!("expected two finite numbers X,Y, got `{s}`")),
    }
}

/// The points of the unit ball that split a sphere's volume over the bins, equal
/// weights: the 32 points of the lattice {-3/4, -1/4, 1/4, 3/4}^3 inside the ball, the
/// midpoint rule on the cells of side 1/2 whose centres are inside (32 cells of volume
/// 4.0 against the ball's 4.19; the weights are a sphere's volume / 32, so the total is
/// exact).
fn ball_points() -> Vec<[f64; 3]> {
    const C: [f64; 4] = [-0.75, -0.25, 0.25, 0.75];
    let mut points = Vec::with_capacity(32);
    for x in C {
        for y in C {
            for z in C {
                if x * x + y * y + z * z < 1.0 {
                    points.push([x, y, z]);
                }
            }
        }
    }
    points
}

/// The annuli and layers of a profile about the vertical axis through `axis`.
#[derive(Clone, Copy, Debug)]
pub struct ProfileGrid {
    pub axis: [f64; 2],
    pub dr: f64,
    pub dz: f64,
    pub r_max: f64,
}

impl ProfileGrid {
    fn annuli(&self) -> usize {
        (self.r_max / self.dr).floor() as usize
    }

    /// The solid volume per (annulus, layer) of `frame`, layers from z = 0 up to the
    /// highest particle top: each sphere's volume is split over the bins by
    /// [`ball_points`] (a grain on a bin edge counts half on either side, not all on
    /// the side of its centre).
    fn solid(&self, frame: &ParticleFrame) -> Vec<Vec<f64>> {
        let top = frame
            .position
            .iter()
            .zip(&frame.radius)
            .map(|(p, r)| p[2] + r)
            .fold(0.0, f64::max);
        let layers = (top / self.dz).floor() as usize + 1;
        let mut v = vec![vec![0.0; layers]; self.annuli()];
        let points = ball_points();
        for (p, &r) in frame.position.iter().zip(&frame.radius) {
            let share = 4.0 / 3.0 * std::f64::consts::PI * r.powi(3) / points.len() as f64;
            for q in &points {
                let (x, y, z) = (p[0] + r * q[0], p[1] + r * q[1], p[2] + r * q[2]);
                let rho = (x - self.axis[0]).hypot(y - self.axis[1]);
                let (a, l) = ((rho / self.dr).floor(), (z / self.dz).floor());
                if a < self.annuli() as f64 && l >= 0.0 {
                    v[a as usize][l as usize] += share;
                }
            }
        }
        v
    }

    fn annulus_area(&self, a: usize) -> f64 {
        let (r0, r1) = (a as f64 * self.dr, (a + 1) as f64 * self.dr);
        std::f64::consts::PI * (r1 * r1 - r0 * r0)
    }

    /// The packed solid fraction of `frame`'s bed (module docs).
    pub fn reference_fraction(&self, frame: &ParticleFrame) -> f64 {
        let top = frame.position.iter().map(|p| p[2]).fold(0.0, f64::max);
        let solid = self.solid(frame);
        let layers = ((0.5 * top / self.dz).floor() as usize).max(2);
        let (mut vs, mut vt) = (0.0, 0.0);
        for (a, col) in solid.iter().enumerate() {
            for v in col.iter().take(layers).skip(1) {
                vs += v;
                vt += self.annulus_area(a) * self.dz;
            }
        }
        vs / vt
    }

    /// The bed surface height of every annulus, `(mid radius, height)`.
    pub fn profile(&self, frame: &ParticleFrame, phi_ref: f64) -> Vec<(f64, f64)> {
        self.solid(frame)
            .iter()
            .enumerate()
            .map(|(a, col)| {
                let cell = self.annulus_area(a) * self.dz;
                let ratio: Vec<f64> = col.iter().map(|v| v / cell / phi_ref).collect();
                let top = (0..ratio.len())
                    .find(|&l| ratio[l] < 0.25 && ratio.get(l + 1).is_none_or(|&q| q < 0.25))
                    .unwrap_or(ratio.len());
                let h = ratio[..top].iter().sum::<f64>() * self.dz;
                ((a as f64 + 0.5) * self.dr, h)
            })
            .collect()
    }
}

/// The crater of a profile against the first frame's (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crater {
    /// The largest drop of the surface.
    pub depth: f64,
    /// Where the drop is back below a tenth of the depth.
    pub radius: f64,
    /// The bulk volume of the drop inside that radius.
    pub volume: f64,
}

impl ProfileGrid {
    /// The crater of `profile` against the `initial` profile of the same grid.
    pub fn crater(&self, initial: &[(f64, f64)], profile: &[(f64, f64)]) -> Crater {
        let drop: Vec<f64> = initial
            .iter()
            .zip(profile)
            .map(|(a, b)| a.1 - b.1)
            .collect();
        let deepest = (0..drop.len())
            .max_by(|&i, &j| drop[i].total_cmp(&drop[j]))
            .expect("a profile has at least 4 annuli");
        let depth = drop[deepest].max(0.0);
        if depth == 0.0 {
            return Crater {
                depth,
                radius: 0.0,
                volume: 0.0,
            };
        }
        let level = 0.1 * depth;
        let mid = |a: usize| profile[a].0;
        let mut radius = self.r_max;
        let mut inside = drop.len();
        for a in deepest..drop.len() - 1 {
            if drop[a + 1] < level {
                let t = (drop[a] - level) / (drop[a] - drop[a + 1]);
                radius = mid(a) + t.clamp(0.0, 1.0) * (mid(a + 1) - mid(a));
                inside = a + 1;
                break;
            }
        }
        let volume = (0..inside).map(|a| drop[a] * self.annulus_area(a)).sum();
        Crater {
            depth,
            radius,
            volume,
        }
    }

    /// The solid volume of `frame`'s particles inside the profiled cylinder (split
    /// as in the profile).
    pub fn solid_volume(&self, frame: &ParticleFrame) -> f64 {
        self.solid(frame).iter().flatten().sum()
    }
}

pub fn profile_plot(a: &ProfileArgs) -> Result<PathBuf, PlotError> {
    let axis = a.axis;
    for (name, v) in [("--dr", a.dr), ("--dz", a.dz), ("--r-max", a.r_max)] {
        if !(v.is_finite() && v > 0.0) {
            return input(format!("{name}: expected a length > 0, got {v}"));
        }
    }
    if a.r_max < 4.0 * a.dr {
        return input(format!(
            "--r-max {}: expected at least 4 annuli of --dr {}",
            a.r_max, a.dr
        ));
    }
    let grid = ProfileGrid {
        axis,
        dr: a.dr,
        dz: a.dz,
        r_max: a.r_max,
    };
    let run = ParticleRun::open(&a.run_dir)?;
    let file = a.run_dir.join("particles.h5");
    let first = run.read(run.frames[0])?;
    let phi_ref = grid.reference_fraction(&first);
    if phi_ref.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return input(format!(
            "{}: the first frame has no bed inside --r-max {} of --axis",
            file.display(),
            a.r_max
        ));
    }
    let initial = grid.profile(&first, phi_ref);
    let solid0 = grid.solid_volume(&first);
    let unit = &a.length_unit;
    println!("packed solid fraction phi_ref = {phi_ref:.3} (first frame)");
    println!(
        "time (s), crater depth ({unit}), radius ({unit}), volume ({unit}^3), \
         solid volume lost from the cylinder / phi_ref ({unit}^3)"
    );
    let mut lines = Vec::new();
    for &t in &a.times {
        let info = frame_in_run(&run.frames, t, "--times", &file)?;
        let frame = run.read(info)?;
        let profile = grid.profile(&frame, phi_ref);
        let c = grid.crater(&initial, &profile);
        let lost = (solid0 - grid.solid_volume(&frame)) / phi_ref;
        println!(
            "t = {:.3} s: {:.3}, {:.3}, {:.2}, {lost:.2}",
            info.time, c.depth, c.radius, c.volume
        );
        lines.push((format!("t = {:.2} s", info.time), profile));
    }
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| a.run_dir.join("profile.png"));
    register_font()?;
    write_series_csv(a.csv.as_deref(), &lines)?;
    let chart = LineChart {
        title: "excavation profile: bed surface height against distance from the axis",
        x_desc: &format!("distance from the axis ({unit})"),
        y_desc: &format!("bed surface height ({unit})"),
    };
    draw_lines(&lines, &chart, a.size, &out)?;
    Ok(out)
}

/// `(time, removed mass so far)` of every line of a run's `sinks.csv`, all sinks.
pub fn extracted_mass(dir: &Path) -> Result<Vec<(f64, f64)>, PlotError> {
    let path = dir.join("sinks.csv");
    let text = std::fs::read_to_string(&path).map_err(|e| {
        PlotError::Input(format!(
            "RUN_DIR {}: no readable sinks.csv (written by runs with sinks): {e}",
            dir.display()
        ))
    })?;
    let mut points: Vec<(f64, f64)> = vec![(0.0, 0.0)];
    for (k, line) in text.lines().enumerate().skip(1) {
        let cols: Vec<&str> = line.split(',').collect();
        let (Some(t), Some(m)) = (
            cols.first().and_then(|s| s.parse::<f64>().ok()),
            cols.get(4).and_then(|s| s.parse::<f64>().ok()),
        ) else {
            return input(format!(
                "{} line {}: expected `time,sink,name,count,mass,...`",
                path.display(),
                k + 1
            ));
        };
        let total = points.last().map_or(0.0, |p| p.1) + m;
        if points.last().is_some_and(|p| p.0 == t) {
            points.last_mut().expect("a point").1 = total;
        } else {
            points.push((t, total));
        }
    }
    Ok(points)
}

pub fn extraction_plot(a: &ExtractionArgs) -> Result<PathBuf, PlotError> {
    let mut lines = Vec::new();
    for dir in std::iter::once(&a.run_dir).chain(&a.with) {
        let name = dir
            .file_name()
            .map_or_else(|| dir.display().to_string(), |n| n.to_string_lossy().into());
        lines.push((name, extracted_mass(dir)?));
    }
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| a.run_dir.join("extraction.png"));
    register_font()?;
    write_series_csv(a.csv.as_deref(), &lines)?;
    let chart = LineChart {
        title: "extracted mass against time",
        x_desc: "t (s)",
        y_desc: &format!("extracted mass ({})", a.mass_unit),
    };
    draw_lines(&lines, &chart, a.size, &out)?;
    Ok(out)
}
