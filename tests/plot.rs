//! `grainflow plot` (src/plot.rs): contour slices of a small flow run, time series and side
//! views of small particle runs are written as PNGs of the asked size whose pixels show
//! the data (the lid of the cavity is bright, its bottom dark; one line colour per
//! particle; spheres at their projected places, nearer over farther, at equal scale in
//! both directions), the reader returns the particle histories, and bad input exits 2
//! naming the argument.
mod common;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use common::*;

/// Runs shared by all tests: the seed's lid-driven box at level 1 (4 x 4 x 16 cells,
/// 3 fluid steps), two free-falling spheres (11 frames), four spheres drifting without
/// gravity (6 frames), and those four spheres with the cavity's fluid files (its box).
struct Runs {
    fluid: PathBuf,
    particles: PathBuf,
    four: PathBuf,
    four_in_box: PathBuf,
}

/// A scene of glass spheres, each `(radius, position, velocity)`, with DEM steps of 1e-5 s
/// to `end_time`, gravity `g` along z and a frame every `output_interval`.
fn glass_spheres(
    end_time: f64,
    g: f64,
    output_interval: f64,
    spheres: &[(f64, [f64; 3], [f64; 3])],
) -> String {
    let mut text = format!(
        "[simulation]\ndt = 1.0e-5\nend_time = {}\ngravity = [0.0, 0.0, {}]\noutput_interval = {}\n\n",
        toml_f(end_time),
        toml_f(g),
        toml_f(output_interval)
    );
    text += &material_toml("glass", 2500.0, 1.0e7, 0.3, "restitution = 0.5");
    for &(radius, position, velocity) in spheres {
        text += &sphere_toml("glass", radius, position, velocity, [0.0; 3], false);
    }
    text
}

/// `grainflow run SCENE --out OUT` and `extra`, which must succeed (`what` names it).
fn run_ok(what: &str, scene: &Path, out: &Path, extra: &[&str]) {
    let mut args = vec!["run", s(scene), "--out", s(out)];
    args.extend_from_slice(extra);
    let (code, stdout, stderr) = run_cli(&args);
    assert_eq!(code, 0, "{what}\nstdout:\n{stdout}\nstderr:\n{stderr}");
}

fn runs() -> &'static Runs {
    static RUNS: OnceLock<Runs> = OnceLock::new();
    RUNS.get_or_init(|| {
        let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("plot-tests");
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(&root).expect("test directory");
        let fluid = root.join("cavity");
        let cavity = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/cavity-lid-box.toml");
        run_ok(
            "cavity run",
            &cavity,
            &fluid,
            &["--steps", "3", "--set", "fluid.level=1"],
        );
        // Two free-falling spheres, the second starting upwards at 1 m/s.
        let two_spheres = glass_spheres(
            0.1,
            -9.81,
            0.01,
            &[
                (0.001, [0.0, 0.0, 0.0], [0.0; 3]),
                (0.001, [0.01, 0.0, 0.0], [0.0, 0.0, 1.0]),
            ],
        );
        let particles = root.join("two-spheres");
        let scene = write_scene(&root, "two-spheres.toml", &two_spheres);
        run_ok("particle run", &scene, &particles, &[]);
        // Four spheres inside the cavity's box 0.5 x 0.5 x 2, no gravity, no contacts; at
        // step 0 the speeds are 0, 1, 0.5 and 0. Seen along y, sphere 2 (y = 0.1, near)
        // covers part of sphere 3 (y = 0.4, far).
        let four_spheres = glass_spheres(
            1.0e-3,
            0.0,
            2.0e-4,
            &[
                (0.05, [0.1, 0.25, 0.1], [0.0; 3]),
                (0.05, [0.4, 0.25, 0.1], [0.0, 0.0, 1.0]),
                (0.08, [0.3, 0.1, 1.5], [0.5, 0.0, 0.0]),
                (0.12, [0.25, 0.4, 1.5], [0.0; 3]),
            ],
        );
        let four = root.join("four-spheres");
        let scene = write_scene(&root, "four-spheres.toml", &four_spheres);
        run_ok("four spheres", &scene, &four, &[]);
        let four_in_box = root.join("four-in-box");
        std::fs::create_dir_all(&four_in_box).expect("test directory");
        for (dir, name) in [
            (&four, "particles.h5"),
            (&fluid, "fluid.h5"),
            (&fluid, "fluid.xdmf"),
        ] {
            std::fs::copy(dir.join(name), four_in_box.join(name)).expect("copy run file");
        }
        Runs {
            fluid,
            particles,
            four,
            four_in_box,
        }
    })
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

fn decode(path: &Path) -> image::RgbImage {
    image::open(path)
        .unwrap_or_else(|e| panic!("{} is not a PNG: {e}", path.display()))
        .to_rgb8()
}

/// "plot area: x A..B, y C..D px; ..." printed by `plot contour` (the first line).
fn plot_area(stdout: &str) -> (u32, u32, u32, u32) {
    *plot_areas(stdout)
        .first()
        .unwrap_or_else(|| panic!("no plot area line in\n{stdout}"))
}

/// Every "plot area: x A..B, y C..D px; ..." line (one per panel of `plot particles`).
fn plot_areas(stdout: &str) -> Vec<(u32, u32, u32, u32)> {
    stdout
        .lines()
        .filter(|l| l.starts_with("plot area:"))
        .map(|line| {
            let nums: Vec<u32> = line
                .split(|c: char| !c.is_ascii_digit())
                .filter(|w| !w.is_empty())
                .take(4)
                .map(|w| w.parse().unwrap())
                .collect();
            (nums[0], nums[1], nums[2], nums[3])
        })
        .collect()
}

fn distance(a: image::Rgb<u8>, b: image::Rgb<u8>) -> f64 {
    (0..3)
        .map(|k| (a[k] as f64 - b[k] as f64).powi(2))
        .sum::<f64>()
        .sqrt()
}

#[test]
fn velocity_contour_is_bright_at_the_lid_and_dark_at_the_bottom() {
    let r = runs();
    let out = r.fluid.join("lid.png");
    let (code, stdout, stderr) = run_cli(&[
        "plot",
        "contour",
        s(&r.fluid),
        "--field",
        "velocity",
        "--plane",
        "y=0.2",
        "--size",
        "640x800",
        "--out",
        s(&out),
    ]);
    assert_eq!(code, 0, "stdout:\n{stdout}\nstderr:\n{stderr}");
    let img = decode(&out);
    assert_eq!(img.dimensions(), (640, 800));
    // The slice is x (horizontal) against z (vertical, lid z = 2 on top). After 3 steps
    // only the top cell layer moves (its centre value is at least 1/6 of the lid speed
    // through the lid face), so the top of the plot is the top of the colour map
    // (viridis yellow) and the bottom its start (dark violet).
    let (x0, x1, y0, y1) = plot_area(&stdout);
    assert!(
        x1 > x0 + 50 && y1 > y0 + 200,
        "plot area {x0}..{x1} x {y0}..{y1}"
    );
    let xm = (x0 + x1) / 2;
    let lid = *img.get_pixel(xm, y0 + 3);
    let bottom = *img.get_pixel(xm, y1 - 3);
    assert!(
        lid[0] > 200 && lid[1] > 200 && lid[2] < 100,
        "near the lid: {lid:?}, expected the bright end of the map"
    );
    assert!(
        bottom[2] > bottom[0] && bottom[1] < 40,
        "near the bottom: {bottom:?}, expected the dark end of the map"
    );
    assert!(
        distance(lid, bottom) > 150.0,
        "lid {lid:?} bottom {bottom:?}"
    );
    // The colour bar (right of the plot area) runs from yellow at the top to violet.
    let bar_x = (x1 + 40..640)
        .find(|&x| {
            distance(
                *img.get_pixel(x, (y0 + y1) / 2),
                image::Rgb([255, 255, 255]),
            ) > 50.0
        })
        .expect("a colour bar right of the plot");
    assert!(distance(*img.get_pixel(bar_x + 5, y0 + 2), lid) < 40.0);
    assert!(distance(*img.get_pixel(bar_x + 5, y1 - 2), bottom) < 40.0);
}

#[test]
fn pressure_contour_default_name_and_size() {
    let r = runs();
    let (code, stdout, stderr) = run_cli(&[
        "plot",
        "contour",
        s(&r.fluid),
        "--field",
        "pressure",
        "--plane",
        "z=1.9",
    ]);
    assert_eq!(code, 0, "stdout:\n{stdout}\nstderr:\n{stderr}");
    // Default: the last frame (step 3), RUN_DIR/<field>_<plane>_<step>.png, 900 x 700.
    let out = r.fluid.join("pressure_z1.9_00000003.png");
    assert!(stdout.contains(s(&out)), "{stdout}");
    assert_eq!(decode(&out).dimensions(), (900, 700));
    // --time picks the nearest frame: t = 1e-5 is nearest the first (step 0).
    let (code, stdout, stderr) = run_cli(&[
        "plot",
        "contour",
        s(&r.fluid),
        "--field",
        "velocity",
        "--plane",
        "x=0.1",
        "--time",
        "1e-5",
    ]);
    assert_eq!(code, 0, "stdout:\n{stdout}\nstderr:\n{stderr}");
    assert!(
        r.fluid.join("velocity_x0.1_00000000.png").is_file(),
        "{stdout}"
    );
}

#[test]
fn series_draws_one_line_per_id() {
    let r = runs();
    let out = r.particles.join("vz.png");
    let (code, stdout, stderr) = run_cli(&[
        "plot",
        "series",
        s(&r.particles),
        "--quantity",
        "velocity",
        "--component",
        "z",
        "--ids",
        "0,1",
        "--size",
        "800x500",
        "--out",
        s(&out),
    ]);
    assert_eq!(code, 0, "stdout:\n{stdout}\nstderr:\n{stderr}");
    let img = decode(&out);
    assert_eq!(img.dimensions(), (800, 500));
    // The first two line colours of src/plot.rs, each on many pixels (line and legend).
    for (id, colour) in [(0, [0u8, 114, 178]), (1, [213, 94, 0])] {
        let n = img.pixels().filter(|p| p.0 == colour).count();
        assert!(n > 200, "id {id}: {n} pixels of its line colour {colour:?}");
    }
    // Only id 1: the colour of a second line is absent.
    let out1 = r.particles.join("z1.png");
    let (code, _, stderr) = run_cli(&[
        "plot",
        "series",
        s(&r.particles),
        "--quantity",
        "position",
        "--ids",
        "1",
        "--out",
        s(&out1),
    ]);
    assert_eq!(code, 0, "{stderr}");
    let img = decode(&out1);
    assert_eq!(img.dimensions(), (900, 600));
    assert_eq!(img.pixels().filter(|p| p.0 == [213, 94, 0]).count(), 0);
    // Default name: RUN_DIR/<quantity>_<component>.png.
    let (code, _, stderr) = run_cli(&["plot", "series", s(&r.particles), "--quantity", "velocity"]);
    assert_eq!(code, 0, "{stderr}");
    assert!(r.particles.join("velocity_magnitude.png").is_file());
}

/// The reader behind `plot series`: free fall, u_z = u_z(0) - g t at every frame.
#[test]
fn reader_returns_particle_histories() {
    let r = runs();
    let run = grainflow::plot::ParticleRun::open(&r.particles).expect("particles.h5");
    assert_eq!(run.frames.len(), 11);
    let series = run.series(&[1, 0]).expect("ids 0 and 1");
    assert_eq!((series[0].id, series[1].id), (1, 0));
    for (s, u0) in [(&series[0], 1.0), (&series[1], 0.0)] {
        assert_eq!(s.time.len(), 11);
        for (t, v) in s.time.iter().zip(&s.velocity) {
            assert!(
                (v[2] - (u0 - 9.81 * t)).abs() < 1e-9,
                "id {}: u_z({t}) = {}",
                s.id,
                v[2]
            );
        }
    }
    assert!(run.series(&[5]).is_err());
    let fluid = grainflow::plot::FluidRun::open(&r.fluid).expect("fluid.h5");
    assert_eq!(fluid.grid.n, [4, 4, 16]);
    assert_eq!(
        fluid.frames.iter().map(|f| f.step).collect::<Vec<_>>(),
        [0, 3]
    );
}

fn contour<'a>(dir: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut v = vec!["plot", "contour", dir];
    v.extend_from_slice(extra);
    v
}

fn assert_bad(args: &[&str], names: &[&str]) {
    let (code, stdout, stderr) = run_cli(args);
    assert_eq!(code, 2, "{args:?}\nstdout:\n{stdout}\nstderr:\n{stderr}");
    for name in names {
        assert!(stderr.contains(name), "{args:?}: `{name}` not in\n{stderr}");
    }
}

#[test]
fn bad_input_exits_2_naming_the_argument() {
    let r = runs();
    let (fluid, particles) = (s(&r.fluid), s(&r.particles));
    let missing_dir = r.fluid.with_file_name("no-such-run");
    let missing = s(&missing_dir);
    let velocity_z1 = ["--field", "velocity", "--plane", "z=1.0"];
    assert_bad(&contour(missing, &velocity_z1), &["RUN_DIR", missing]);
    assert_bad(&contour(particles, &velocity_z1), &["fluid.h5"]);
    assert_bad(
        &contour(fluid, &["--field", "velocity", "--plane", "z=2.5"]),
        &["--plane", "z from 0 to 2"],
    );
    assert_bad(
        &contour(fluid, &["--field", "velocity", "--plane", "w=0.5"]),
        &["--plane"],
    );
    assert_bad(
        &contour(fluid, &["--field", "vorticity", "--plane", "z=1"]),
        &["--field", "vorticity"],
    );
    assert_bad(
        &contour(
            fluid,
            &["--field", "pressure", "--plane", "z=1", "--step", "2"],
        ),
        &["--step", "0, 3"],
    );
    assert_bad(
        &["plot", "series", missing, "--quantity", "velocity"],
        &["RUN_DIR", missing],
    );
    assert_bad(
        &[
            "plot",
            "series",
            particles,
            "--quantity",
            "velocity",
            "--ids",
            "0,7",
        ],
        &["--ids", "7"],
    );
    assert_bad(
        &["plot", "series", particles, "--quantity", "speed"],
        &["--quantity"],
    );
}

#[test]
fn missing_font_exits_2_naming_the_path() {
    let r = runs();
    let font = "/nonexistent/fonts/DejaVuSans.ttf";
    let out = grainflow()
        .args(["plot", "series", s(&r.particles), "--quantity", "velocity"])
        .args(["--out", s(&r.particles.join("nofont.png"))])
        .env("GRAINFLOW_FONT", font)
        .output()
        .expect("run grainflow");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains(font) && stderr.contains("setup.sh"),
        "{stderr}"
    );
    assert!(!r.particles.join("nofont.png").exists());
}

/// The colours of src/plot.rs: viridis at 0, 0.5 and 1, the colours of ids 1 and 2, and
/// the background of a side view.
const VIRIDIS_0: [u8; 3] = [0x44, 0x01, 0x54];
const VIRIDIS_HALF: [u8; 3] = [0x21, 0x91, 0x8c];
const VIRIDIS_1: [u8; 3] = [0xfd, 0xe7, 0x25];
const ID_1: [u8; 3] = [213, 94, 0];
const ID_2: [u8; 3] = [0, 158, 115];
const BACKGROUND: [u8; 3] = [240, 244, 250];

/// Maps the box `lower..upper` (horizontal, vertical) onto a plot area.
struct Frame {
    area: (u32, u32, u32, u32),
    lower: [f64; 2],
    upper: [f64; 2],
}

impl Frame {
    fn pixel(&self, u: f64, v: f64) -> (u32, u32) {
        let (x0, x1, y0, y1) = self.area;
        let fx = (u - self.lower[0]) / (self.upper[0] - self.lower[0]);
        let fy = (self.upper[1] - v) / (self.upper[1] - self.lower[1]);
        (
            (x0 as f64 + fx * (x1 - x0) as f64) as u32,
            (y0 as f64 + fy * (y1 - y0) as f64) as u32,
        )
    }
}

fn assert_colour(img: &image::RgbImage, (x, y): (u32, u32), want: [u8; 3], what: &str) {
    let got = *img.get_pixel(x, y);
    assert!(
        distance(got, image::Rgb(want)) < 3.0,
        "{what} at pixel ({x}, {y}): {got:?}, expected {want:?}"
    );
}

fn particles_plot<'a>(dir: &'a str, extra: &[&'a str]) -> (String, String) {
    let mut args = vec!["plot", "particles", dir];
    args.extend_from_slice(extra);
    let (code, stdout, stderr) = run_cli(&args);
    assert_eq!(code, 0, "{args:?}\nstdout:\n{stdout}\nstderr:\n{stderr}");
    (stdout, stderr)
}

#[test]
fn particles_side_view_draws_spheres_in_place_and_depth_order() {
    let r = runs();
    let out = r.four.join("side.png");
    let (stdout, _) = particles_plot(
        s(&r.four),
        &["--step", "0", "--size", "700x900", "--out", s(&out)],
    );
    let img = decode(&out);
    assert_eq!(img.dimensions(), (700, 900));
    // Without fluid files the box is the spheres' extent: x 0.05..0.45, z 0.05..1.62;
    // one length unit has the same number of pixels in both directions.
    let area = plot_area(&stdout);
    let (x0, x1, y0, y1) = area;
    let (w, h) = ((x1 - x0) as f64, (y1 - y0) as f64);
    assert!(w > 100.0, "plot area {area:?}");
    let expected_h = w * (1.62 - 0.05) / (0.45 - 0.05);
    assert!(
        (h - expected_h).abs() <= 2.0,
        "plot area {area:?}: height {h}, expected {expected_h}"
    );
    assert!(stdout.contains("|v| (m/s) from 0 to 1"), "{stdout}");
    let view = Frame {
        area,
        lower: [0.05, 0.05],
        upper: [0.45, 1.62],
    };
    assert_colour(&img, view.pixel(0.1, 0.1), VIRIDIS_0, "sphere 0 (at rest)");
    assert_colour(&img, view.pixel(0.4, 0.1), VIRIDIS_1, "sphere 1 (|v| = 1)");
    // Sphere 2 (near, |v| = 0.5) over sphere 3 (far, at rest) where they overlap; sphere
    // 3 beside it; nothing between the spheres.
    assert_colour(&img, view.pixel(0.3, 1.5), VIRIDIS_HALF, "near sphere 2");
    assert_colour(
        &img,
        view.pixel(0.16, 1.5),
        VIRIDIS_0,
        "far sphere 3 beside 2",
    );
    assert_colour(
        &img,
        view.pixel(0.25, 0.8),
        BACKGROUND,
        "between the spheres",
    );
    // Seen along x (from +x) the spheres are at (y, z); coloured by id. Spheres 0 and 1
    // have the same (y, z): sphere 1 (x = 0.4) is the nearer and covers sphere 0.
    let out_x = r.four.join("side-x.png");
    let (stdout, _) = particles_plot(
        s(&r.four),
        &[
            "--step",
            "0",
            "--view",
            "x",
            "--color",
            "id",
            "--out",
            s(&out_x),
        ],
    );
    let img = decode(&out_x);
    // y 0.02..0.52 (sphere 2 reaches 0.1 - 0.08, sphere 3 0.4 + 0.12), z 0.05..1.62.
    let view = Frame {
        area: plot_area(&stdout),
        lower: [0.02, 0.05],
        upper: [0.52, 1.62],
    };
    assert_colour(&img, view.pixel(0.25, 0.1), ID_1, "sphere 1 over sphere 0");
    assert_colour(&img, view.pixel(0.1, 1.5), ID_2, "sphere 2 coloured by id");
    assert_colour(&img, view.pixel(0.1, 0.8), BACKGROUND, "beside the spheres");
}

#[test]
fn particles_axes_span_the_fluid_box_at_equal_scale() {
    let r = runs();
    let (stdout, _) = particles_plot(s(&r.four_in_box), &["--time", "0", "--color", "z"]);
    // The default name and size; the box of fluid.xdmf, 0.5 x 2 (x, z).
    let out = r.four_in_box.join("particles_y_00000000.png");
    assert!(stdout.contains(s(&out)), "{stdout}");
    assert!(stdout.contains("z (m) from 0.1 to 1.5"), "{stdout}");
    let img = decode(&out);
    assert_eq!(img.dimensions(), (900, 700));
    let area = plot_area(&stdout);
    let (x0, x1, y0, y1) = area;
    let (w, h) = ((x1 - x0) as f64, (y1 - y0) as f64);
    assert!(
        h > 300.0 && (h - 4.0 * w).abs() <= 2.0,
        "plot area {area:?}"
    );
    let view = Frame {
        area,
        lower: [0.0, 0.0],
        upper: [0.5, 2.0],
    };
    // Colour by height: the spheres at z = 0.1 are the low end, those at 1.5 the top.
    assert_colour(&img, view.pixel(0.1, 0.1), VIRIDIS_0, "sphere 0 at z = 0.1");
    assert_colour(&img, view.pixel(0.3, 1.5), VIRIDIS_1, "sphere 2 at z = 1.5");
    assert_colour(&img, view.pixel(0.25, 1.9), BACKGROUND, "top of the box");
}

/// `--slice`: only the spheres centred in the slab are drawn, the box stays the fluid's.
#[test]
fn particles_slice_keeps_the_spheres_in_the_slab() {
    let r = runs();
    let out = r.four_in_box.join("slice.png");
    // Seen along y: the slab y in 0.4 +- 0.05 holds sphere 3 alone (y = 0.4); spheres 0
    // and 1 (y = 0.25) and sphere 2 (y = 0.1, in front of 3) are left out.
    let (stdout, _) = particles_plot(
        s(&r.four_in_box),
        &[
            "--time",
            "0",
            "--slice",
            "0.1",
            "--slice-at",
            "0.4",
            "--out",
            s(&out),
        ],
    );
    assert!(stdout.contains("(step 0), 1 spheres"), "{stdout}");
    let img = decode(&out);
    let view = Frame {
        area: plot_area(&stdout),
        lower: [0.0, 0.0],
        upper: [0.5, 2.0],
    };
    // Sphere 3 at rest alone: the colour scale is centred on its speed.
    assert_colour(
        &img,
        view.pixel(0.3, 1.5),
        VIRIDIS_HALF,
        "sphere 3, no longer behind 2",
    );
    assert_colour(&img, view.pixel(0.1, 0.1), BACKGROUND, "sphere 0 left out");
    assert_colour(&img, view.pixel(0.4, 0.1), BACKGROUND, "sphere 1 left out");
    // A slab holding no sphere, and a thickness that is not one, are bad input.
    let (four, out) = (s(&r.four_in_box), s(&out));
    let base = ["plot", "particles", four, "--time", "0", "--out", out];
    let with = |extra: &[&'static str]| [&base[..], extra].concat();
    assert_bad(
        &with(&["--slice", "0.01", "--slice-at", "0.33"]),
        &["slice"],
    );
    assert_bad(&with(&["--slice", "0"]), &["--slice 0", "thickness"]);
    assert_bad(&with(&["--slice", "-1"]), &["--slice", "thickness"]);
}

#[test]
fn particles_series_has_one_panel_per_frame() {
    let r = runs();
    let (stdout, _) = particles_plot(s(&r.four), &["--frames", "3"]);
    let out = r.four.join("particles_y_series.png");
    assert!(stdout.contains(s(&out)), "{stdout}");
    let areas = plot_areas(&stdout);
    assert_eq!(areas.len(), 3, "{stdout}");
    // First, middle and last of the 6 frames (steps 0, 20, ..., 100).
    for step in ["(step 0)", "(step 60)", "(step 100)"] {
        assert!(stdout.contains(step), "{step} not in\n{stdout}");
    }
    let img = decode(&out);
    let (w, h) = img.dimensions();
    assert!(w > 900 && h == 700, "{w}x{h}");
    for pair in areas.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        assert!(b.0 > a.1, "panels overlap: {a:?} {b:?}");
        assert_eq!((a.1 - a.0, a.2, a.3), (b.1 - b.0, b.2, b.3), "panel sizes");
    }
    // Sphere 1 moves up at 1 m/s (0.001 in the run): its start is inside it in every
    // panel; one shared colour scale from 0 to 1.
    assert!(stdout.contains("|v| (m/s) from 0 to 1"), "{stdout}");
    let (lower, upper) = ([0.05, 0.05], [0.45, 1.621]);
    for area in &areas {
        let view = Frame {
            area: *area,
            lower,
            upper,
        };
        assert_colour(&img, view.pixel(0.4, 0.1), VIRIDIS_1, "sphere 1");
        assert_colour(
            &img,
            view.pixel(0.25, 0.8),
            BACKGROUND,
            "between the spheres",
        );
    }
    // --times: one panel per time.
    let (stdout, _) = particles_plot(
        s(&r.four),
        &["--times", "0,0.0005", "--out", s(&r.four.join("two.png"))],
    );
    assert_eq!(plot_areas(&stdout).len(), 2, "{stdout}");
}

#[test]
fn particles_bad_input_exits_2_naming_the_argument() {
    let r = runs();
    let four = s(&r.four);
    let missing_dir = r.four.with_file_name("no-such-run");
    let missing = s(&missing_dir);
    let empty_dir = r.four.with_file_name("empty-run");
    std::fs::create_dir_all(&empty_dir).expect("test directory");
    let p = |extra: &[&'static str]| -> Vec<String> {
        ["plot", "particles", four]
            .iter()
            .chain(extra)
            .map(|a| a.to_string())
            .collect()
    };
    let bad = |args: Vec<String>, names: &[&str]| {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        assert_bad(&args, names);
    };
    assert_bad(&["plot", "particles", missing], &["RUN_DIR", missing]);
    assert_bad(
        &["plot", "particles", s(&empty_dir)],
        &["RUN_DIR", "particles.h5"],
    );
    bad(p(&["--view", "w"]), &["--view", "w"]);
    bad(p(&["--color", "temperature"]), &["--color", "temperature"]);
    bad(p(&["--time", "5"]), &["--time", "outside the run"]);
    bad(p(&["--time", "-1"]), &["--time", "outside the run"]);
    bad(p(&["--times", "0,7"]), &["--times 7", "outside the run"]);
    bad(p(&["--frames", "0"]), &["--frames 0"]);
    bad(p(&["--frames", "7"]), &["--frames 7", "1 to 6"]);
    bad(p(&["--step", "3"]), &["--step", "0, 20, 40"]);
    bad(p(&["--step", "0", "--time", "0"]), &["--step", "--time"]);
    bad(p(&["--size", "50x50"]), &["--size"]);
}

/// The cloud quantities of `plot series` on the four spheres in the cavity's box: no
/// contacts (4 clusters in every frame), settling velocity along -z the mean of -v_z,
/// -1/4 (sphere 1 rises at 1), along x the mean of v_x, 1/8; one line per run with
/// `--with`, each labelled "not landed" (no gravity, nothing on the floor).
#[test]
fn cloud_series_counts_clusters_and_averages_the_velocity_along_gravity() {
    let r = runs();
    let csv = r.four_in_box.join("clusters.csv");
    let (code, stdout, stderr) = run_cli(&[
        "plot",
        "series",
        s(&r.four_in_box),
        "--quantity",
        "clusters",
        "--with",
        s(&r.four_in_box),
        "--csv",
        s(&csv),
    ]);
    assert_eq!(code, 0, "{stderr}");
    assert_eq!(stdout.matches("not landed").count(), 2, "{stdout}");
    let text = std::fs::read_to_string(&csv).expect("csv");
    let rows: Vec<&str> = text.lines().skip(1).collect();
    assert_eq!(rows.len(), 2 * 6, "{text}");
    assert!(rows.iter().all(|l| l.ends_with(",4e0")), "{text}");
    for (down, expected) in [("-z", -0.25), ("x", 0.125)] {
        let csv = r.four_in_box.join("settling.csv");
        let (code, _, stderr) = run_cli(&[
            "plot",
            "series",
            s(&r.four_in_box),
            "--quantity",
            "settling-velocity",
            &format!("--down={down}"),
            "--csv",
            s(&csv),
        ]);
        assert_eq!(code, 0, "{stderr}");
        let text = std::fs::read_to_string(&csv).expect("csv");
        let first: f64 = text
            .lines()
            .nth(1)
            .and_then(|l| l.rsplit(',').next())
            .unwrap()
            .parse()
            .unwrap();
        assert!((first - expected).abs() < 1e-12, "{down}: {text}");
    }
}

/// Bad input to the cloud quantities exits 2 naming the argument or the missing file.
#[test]
fn cloud_series_rejects_what_it_cannot_use() {
    let r = runs();
    for (args, needle) in [
        (vec!["--quantity", "clusters", "--ids", "0"], "--ids"),
        (
            vec!["--quantity", "velocity", "--with", s(&r.four_in_box)],
            "--with",
        ),
        (
            vec!["--quantity", "clusters", "--down", "w"],
            "expected -x, x",
        ),
    ] {
        let mut all = vec!["plot", "series", s(&r.four_in_box)];
        all.extend(args);
        let (code, _, stderr) = run_cli(&all);
        assert_eq!(code, 2, "{all:?}: {stderr}");
        assert!(stderr.contains(needle), "{all:?}: {stderr}");
    }
    // a run without a fluid box has no floor
    let (code, _, stderr) = run_cli(&["plot", "series", s(&r.four), "--quantity", "clusters"]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("fluid.xdmf"), "{stderr}");
}

/// `plot series --quantity axis-angle`: a two-sphere clump spinning freely about the y
/// axis (no gravity, no walls) at w = 10 rad/s from horizontal (body x axis along world
/// x): its long axis turns in the x-z plane, at `w t` (in degrees) to the horizontal of
/// `--down=-z` until t = pi / (2 w) = 0.157 s. Torque-free rotation about a principal
/// axis is steady; the orientation's Runge-Kutta turn is exact to 1e-6 degrees here (bar
/// 1e-3 degrees over the 11 frames to t = 0.1 s, 57.3 degrees); a run without clumps
/// exits 2.
#[test]
fn axis_angle_series_follows_a_spinning_clump() {
    let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("plot-axis-angle");
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).expect("test directory");
    let mut text = String::from(
        "[simulation]\ndt = 1.0e-5\nend_time = 0.1\ngravity = [0.0, 0.0, 0.0]\noutput_interval = 0.01\n\n",
    );
    text += &material_toml("glass", 2500.0, 1.0e7, 0.3, "restitution = 0.5");
    text += "\n[[clump_types]]\nname = \"pair\"\nmaterial = \"glass\"\n\
             spheres = [{ offset = [-0.0008, 0.0, 0.0], radius = 0.001 }, \
             { offset = [0.0008, 0.0, 0.0], radius = 0.001 }]\n\n\
             [[clumps]]\ntype = \"pair\"\nposition = [0.0, 0.0, 0.0]\n\
             angular_velocity = [0.0, 10.0, 0.0]\n";
    let scene = write_scene(&root, "spinning-pair.toml", &text);
    let run = root.join("spinning-pair");
    run_ok("spinning clump", &scene, &run, &[]);
    let csv = root.join("angle.csv");
    let (code, stdout, stderr) = run_cli(&[
        "plot",
        "series",
        s(&run),
        "--quantity",
        "axis-angle",
        "--down=-z",
        "--csv",
        s(&csv),
    ]);
    assert_eq!(code, 0, "stdout:\n{stdout}\nstderr:\n{stderr}");
    assert!(run.join("axis_angle.png").is_file());
    let values: Vec<(f64, f64)> = std::fs::read_to_string(&csv)
        .expect("csv")
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            assert_eq!(f[0], "\"body 0\"", "{l}");
            (f[1].parse().expect("time"), f[2].parse().expect("angle"))
        })
        .collect();
    assert_eq!(values.len(), 11, "{values:?}");
    for (t, angle) in values {
        let expected = (10.0 * t).to_degrees();
        assert!(
            (angle - expected).abs() < 1e-3,
            "t = {t}: {angle} degrees, expected {expected}"
        );
    }
    assert_bad(
        &[
            "plot",
            "series",
            s(&runs().particles),
            "--quantity",
            "axis-angle",
        ],
        &["axis-angle"],
    );
}
