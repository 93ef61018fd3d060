//! `grainflow plot` (src/plot.rs): contour slices of a small flow run and time series of a
//! small particle run are written as PNGs of the asked size whose pixels show the data
//! (the lid of the cavity is bright, its bottom dark; one line colour per particle), the
//! reader returns the particle histories, and bad input exits 2 naming the argument.
mod common;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use common::*;

/// Two runs shared by all tests: the seed's lid-driven box at level 1 (4 x 4 x 16 cells,
/// 3 fluid steps) and two free-falling spheres (11 frames).
struct Runs {
    fluid: PathBuf,
    particles: PathBuf,
}

const TWO_SPHERES: &str = r#"
[simulation]
dt = 1.0e-5
end_time = 0.1
gravity = [0.0, 0.0, -9.81]
output_interval = 0.01

[[materials]]
name = "glass"
density = 2500.0
youngs_modulus = 1.0e7
poisson_ratio = 0.3
restitution = 0.5

[[spheres]]
material = "glass"
radius = 0.001
position = [0.0, 0.0, 0.0]

[[spheres]]
material = "glass"
radius = 0.001
position = [0.01, 0.0, 0.0]
velocity = [0.0, 0.0, 1.0]
"#;

fn runs() -> &'static Runs {
    static RUNS: OnceLock<Runs> = OnceLock::new();
    RUNS.get_or_init(|| {
        let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("plot-tests");
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(&root).expect("test directory");
        let fluid = root.join("cavity");
        let cavity = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/cavity-lid-box.toml");
        let (code, stdout, stderr) = run_cli(&[
            "run",
            cavity.to_str().unwrap(),
            "--out",
            fluid.to_str().unwrap(),
            "--steps",
            "3",
            "--set",
            "fluid.level=1",
        ]);
        assert_eq!(code, 0, "cavity run\nstdout:\n{stdout}\nstderr:\n{stderr}");
        let scene = write_scene(&root, "two-spheres.toml", TWO_SPHERES);
        let particles = root.join("two-spheres");
        let (code, stdout, stderr) = run_cli(&[
            "run",
            scene.to_str().unwrap(),
            "--out",
            particles.to_str().unwrap(),
        ]);
        assert_eq!(
            code, 0,
            "particle run\nstdout:\n{stdout}\nstderr:\n{stderr}"
        );
        Runs { fluid, particles }
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

/// "plot area: x A..B, y C..D px; ..." printed by `plot contour`.
fn plot_area(stdout: &str) -> (u32, u32, u32, u32) {
    let line = stdout
        .lines()
        .find(|l| l.starts_with("plot area:"))
        .unwrap_or_else(|| panic!("no plot area line in\n{stdout}"));
    let nums: Vec<u32> = line
        .split(|c: char| !c.is_ascii_digit())
        .filter(|w| !w.is_empty())
        .take(4)
        .map(|w| w.parse().unwrap())
        .collect();
    (nums[0], nums[1], nums[2], nums[3])
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
