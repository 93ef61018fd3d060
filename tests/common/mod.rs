//! Helpers shared by the integration tests: scenes from TOML text, particle state by
//! stable id, the Hertz formulas of `shared/reference/contact-benchmarks.md` (Hertz 1896;
//! Johnson, Contact Mechanics, 1985), an independent RK4 integration of the normal
//! contact equation, and running the `grainflow` binary.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use grainflow::run::Simulation;
use grainflow_components::{Particles, RunHealth};

/// Build a simulation from scene text; `name` stands for the file name in errors.
pub fn simulation(text: &str, name: &str) -> Simulation {
    let path = Path::new(name);
    let scene = grainflow::scene::parse(text, path, &[])
        .unwrap_or_else(|e| panic!("test scene {name} does not parse: {e}"));
    Simulation::new(scene, path, None)
        .unwrap_or_else(|e| panic!("test scene {name} does not build: {e}"))
}

/// The row of the particle with stable id `id` (rows are re-sorted at list rebuilds).
pub fn row(sim: &Simulation, id: u32) -> usize {
    sim.world
        .resource::<Particles>()
        .id
        .iter()
        .position(|&k| k == id)
        .unwrap_or_else(|| panic!("no particle with id {id}"))
}

pub fn position(sim: &Simulation, id: u32) -> [f64; 3] {
    let i = row(sim, id);
    let p = sim.world.resource::<Particles>();
    [p.position[0][i], p.position[1][i], p.position[2][i]]
}

pub fn velocity(sim: &Simulation, id: u32) -> [f64; 3] {
    let i = row(sim, id);
    let p = sim.world.resource::<Particles>();
    [p.velocity[0][i], p.velocity[1][i], p.velocity[2][i]]
}

/// Translational kinetic energy of all particles, computed here from the state.
pub fn kinetic_energy(sim: &Simulation) -> f64 {
    let p = sim.world.resource::<Particles>();
    (0..p.len())
        .map(|i| {
            let v2: f64 = (0..3).map(|d| p.velocity[d][i].powi(2)).sum();
            0.5 * p.mass(i) * v2
        })
        .sum()
}

pub fn health(sim: &Simulation) -> &RunHealth {
    sim.world.resource::<RunHealth>()
}

pub fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// |a - b| / |b|.
pub fn rel(a: f64, b: f64) -> f64 {
    ((a - b) / b).abs()
}

pub fn sphere_mass(density: f64, radius: f64) -> f64 {
    density * 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3)
}

/// 1/E* = (1-nu1^2)/E1 + (1-nu2^2)/E2.
pub fn e_star(e1: f64, nu1: f64, e2: f64, nu2: f64) -> f64 {
    1.0 / ((1.0 - nu1 * nu1) / e1 + (1.0 - nu2 * nu2) / e2)
}

/// Effective quantities of one Hertz contact (reference file, "Hertz impact formulas").
#[derive(Debug, Clone, Copy)]
pub struct Hertz {
    pub e_star: f64,
    pub r_star: f64,
    pub m_star: f64,
}

impl Hertz {
    /// Two identical spheres of one material.
    pub fn pair(e: f64, nu: f64, density: f64, radius: f64) -> Self {
        Self {
            e_star: e_star(e, nu, e, nu),
            r_star: 0.5 * radius,
            m_star: 0.5 * sphere_mass(density, radius),
        }
    }
    /// A sphere against a rigid wall: R* = R, m* = m, the wall term of E* vanishes.
    pub fn rigid_wall(e: f64, nu: f64, density: f64, radius: f64) -> Self {
        Self {
            e_star: e / (1.0 - nu * nu),
            r_star: radius,
            m_star: sphere_mass(density, radius),
        }
    }
    /// c_n = (4/3) E* sqrt(R*), F = c_n delta^(3/2) (seed slide "Models for DEM").
    pub fn c_n(&self) -> f64 {
        4.0 / 3.0 * self.e_star * self.r_star.sqrt()
    }
    /// t_c = 2.868 (m*^2 / (R* E*^2 v))^(1/5), v the approach speed.
    pub fn contact_time(&self, v: f64) -> f64 {
        2.868 * (self.m_star.powi(2) / (self.r_star * self.e_star.powi(2) * v)).powf(0.2)
    }
    /// delta_max = (15 m* v^2 / (16 E* sqrt(R*)))^(2/5).
    pub fn max_overlap(&self, v: f64) -> f64 {
        (15.0 * self.m_star * v * v / (16.0 * self.e_star * self.r_star.sqrt())).powf(0.4)
    }
    pub fn max_force(&self, v: f64) -> f64 {
        self.c_n() * self.max_overlap(v).powf(1.5)
    }
}

/// Rayleigh time step dt_R = pi R sqrt(rho/G) / (0.1631 nu + 0.8766), G = E/(2(1+nu))
/// (reference file; Li, Xu & Thornton 2005).
pub fn rayleigh_time_step(radius: f64, e: f64, nu: f64, density: f64) -> f64 {
    let g = e / (2.0 * (1.0 + nu));
    std::f64::consts::PI * radius * (density / g).sqrt() / (0.1631 * nu + 0.8766)
}

/// Normal damping of the one-dimensional contact equation.
#[derive(Debug, Clone, Copy)]
pub enum Damping {
    /// F_d = d_n delta_dot (seed slide "Models for DEM").
    Constant(f64),
    /// F_d = 2 sqrt(5/6) |beta| sqrt(S_n m*) delta_dot, S_n = 2 E* sqrt(R* delta),
    /// beta = ln e / sqrt(ln^2 e + pi^2) (reference file, "Damping against restitution").
    Restitution(f64),
}

/// m* delta'' = -c_n delta^(3/2) - F_d(delta, delta') from delta = 0, delta' = v, integrated
/// with classical RK4 at step `h` until delta returns to 0 (end point by linear
/// interpolation). Returns (restitution coefficient, contact duration). The force is not
/// clipped at zero. Independent of grainflow's code: the reference for its contact models.
pub fn rk4_normal_impact(h: &Hertz, damping: Damping, v: f64, steps_per_tc: f64) -> (f64, f64) {
    let c_n = h.c_n();
    let m = h.m_star;
    let damping_force = |x: f64, xd: f64| -> f64 {
        match damping {
            Damping::Constant(d) => d * xd,
            Damping::Restitution(e) => {
                let l = e.ln();
                let beta = l / (l * l + std::f64::consts::PI.powi(2)).sqrt();
                let s_n = 2.0 * h.e_star * (h.r_star * x).sqrt();
                -2.0 * (5.0f64 / 6.0).sqrt() * beta * (s_n * m).sqrt() * xd
            }
        }
    };
    let acc = |x: f64, xd: f64| -> f64 {
        let x = x.max(0.0);
        -(c_n * x.powf(1.5) + damping_force(x, xd)) / m
    };
    let dt = h.contact_time(v) / steps_per_tc;
    let (mut x, mut xd, mut t) = (0.0f64, v, 0.0f64);
    loop {
        let (k1x, k1v) = (xd, acc(x, xd));
        let (k2x, k2v) = (
            xd + 0.5 * dt * k1v,
            acc(x + 0.5 * dt * k1x, xd + 0.5 * dt * k1v),
        );
        let (k3x, k3v) = (
            xd + 0.5 * dt * k2v,
            acc(x + 0.5 * dt * k2x, xd + 0.5 * dt * k2v),
        );
        let (k4x, k4v) = (xd + dt * k3v, acc(x + dt * k3x, xd + dt * k3v));
        let xn = x + dt / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
        let xdn = xd + dt / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
        if xn <= 0.0 && t > 0.0 {
            let s = x / (x - xn);
            return (-(xd + s * (xdn - xd)) / v, t + s * dt);
        }
        x = xn;
        xd = xdn;
        t += dt;
        assert!(t < 100.0 * h.contact_time(v), "RK4 contact never ended");
    }
}

/// The `grainflow` binary built for these tests.
pub fn grainflow() -> Command {
    Command::new(env!("CARGO_BIN_EXE_grainflow"))
}

/// Run the binary with `args`; returns (exit code, stdout, stderr).
pub fn run_cli(args: &[&str]) -> (i32, String, String) {
    let out: Output = grainflow()
        .args(args)
        .env("RUST_LOG", "warn")
        .output()
        .expect("cannot start the grainflow binary");
    (
        out.status.code().expect("grainflow was killed by a signal"),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Write `text` to `dir/name` and return the path.
pub fn write_scene(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).expect("write the test scene");
    path
}

/// A small deterministic generator (xorshift64*) for random test sets.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_f64(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let r = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D);
        (r >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next_f64()
    }
}

/// A head-on impact: two identical spheres at +-`speed` along x, or one sphere falling
/// along -z at `speed` onto a rigid plane z = 0. No gravity. `damping` is the material's
/// damping line(s), e.g. `restitution = 0.5` or `normal_damping = 0.0`; the rigid wall
/// material gets the same line so that the pair uses the same law.
#[derive(Debug, Clone)]
pub struct ImpactScene {
    pub youngs_modulus: f64,
    pub poisson_ratio: f64,
    pub density: f64,
    pub radius: f64,
    pub speed: f64,
    pub wall: bool,
    pub damping: String,
}

impl ImpactScene {
    pub fn hertz(&self) -> Hertz {
        let (e, nu, rho, r) = (
            self.youngs_modulus,
            self.poisson_ratio,
            self.density,
            self.radius,
        );
        if self.wall {
            Hertz::rigid_wall(e, nu, rho, r)
        } else {
            Hertz::pair(e, nu, rho, r)
        }
    }

    /// Approach speed: relative speed of the two spheres, or the sphere's speed.
    pub fn approach_speed(&self) -> f64 {
        if self.wall {
            self.speed
        } else {
            2.0 * self.speed
        }
    }

    /// Scene text; the surfaces start `gap` apart.
    pub fn toml(&self, integrator: &str, dt: f64, gap: f64) -> String {
        let (r, v) = (self.radius, self.speed);
        let common = format!(
            "[simulation]\ndt = {dt:e}\nend_time = 1.0\nintegrator = \"{integrator}\"\n\
             gravity = [0.0, 0.0, 0.0]\n\n\
             [[materials]]\nname = \"m\"\ndensity = {:e}\nyoungs_modulus = {:e}\n\
             poisson_ratio = {}\n{}\n",
            self.density, self.youngs_modulus, self.poisson_ratio, self.damping
        );
        if self.wall {
            // Rigid plane: E = 1e25 Pa makes the wall's (1-nu^2)/E 1e-14 of the sphere's.
            format!(
                "{common}\n[[materials]]\nname = \"rigid\"\ndensity = 1.0\n\
                 youngs_modulus = 1e25\n{}\n\n\
                 [[walls]]\ntype = \"plane\"\nmaterial = \"rigid\"\n\
                 point = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\n\n\
                 [[spheres]]\nmaterial = \"m\"\nradius = {r:e}\n\
                 position = [0.0, 0.0, {:e}]\nvelocity = [0.0, 0.0, {:e}]\n",
                self.damping,
                r + gap,
                -v
            )
        } else {
            format!(
                "{common}\n[[spheres]]\nmaterial = \"m\"\nradius = {r:e}\n\
                 position = [{:e}, 0.0, 0.0]\nvelocity = [{v:e}, 0.0, 0.0]\n\n\
                 [[spheres]]\nmaterial = \"m\"\nradius = {r:e}\n\
                 position = [{:e}, 0.0, 0.0]\nvelocity = [{:e}, 0.0, 0.0]\n",
                -(r + 0.5 * gap),
                r + 0.5 * gap,
                -v
            )
        }
    }

    /// Gap between the surfaces.
    pub fn gap(&self, sim: &Simulation) -> f64 {
        if self.wall {
            position(sim, 0)[2] - self.radius
        } else {
            distance(position(sim, 0), position(sim, 1)) - 2.0 * self.radius
        }
    }

    /// Normal approach velocity (positive while closing).
    pub fn approach_velocity(&self, sim: &Simulation) -> f64 {
        if self.wall {
            -velocity(sim, 0)[2]
        } else {
            velocity(sim, 0)[0] - velocity(sim, 1)[0]
        }
    }
}

/// What `step_through_contact` saw.
#[derive(Debug, Clone, Copy)]
pub struct Impact {
    /// Times at which the gap crossed zero, linearly interpolated between steps, s.
    pub start: f64,
    pub end: f64,
    /// Largest overlap (-gap) at the end of a step, m.
    pub max_overlap: f64,
    /// Largest `RunHealth::max_overlap_ratio` (overlap / smaller radius) of any step.
    pub max_overlap_ratio: f64,
}

impl Impact {
    pub fn duration(&self) -> f64 {
        self.end - self.start
    }
}

/// Step until the gap has closed, reopened, and 200 more steps have passed: Gear carries
/// the contact's jerk and snap a few steps beyond the separation, so velocities are read
/// once those have decayed. Panics after `max_steps` or on a failed run.
pub fn step_through_contact(
    sim: &mut Simulation,
    gap: impl Fn(&Simulation) -> f64,
    max_steps: u64,
) -> Impact {
    let dt = sim.world.resource::<grainflow_components::SimClock>().dt;
    let (mut start, mut end) = (None, None);
    let (mut max_overlap, mut max_ratio) = (0.0f64, 0.0f64);
    let mut previous = gap(sim);
    let mut after = 0;
    for k in 1..=max_steps {
        sim.step();
        if let Some(f) = sim.failure() {
            panic!("run failed: {f}");
        }
        let g = gap(sim);
        max_overlap = max_overlap.max(-g);
        max_ratio = max_ratio.max(health(sim).max_overlap_ratio);
        let t_cross = (k - 1) as f64 * dt + dt * previous / (previous - g);
        if start.is_none() && previous > 0.0 && g <= 0.0 {
            start = Some(t_cross);
        } else if start.is_some() && end.is_none() && previous <= 0.0 && g > 0.0 {
            end = Some(t_cross);
        }
        previous = g;
        if let (Some(start), Some(end)) = (start, end) {
            after += 1;
            if after == 200 {
                return Impact {
                    start,
                    end,
                    max_overlap,
                    max_overlap_ratio: max_ratio,
                };
            }
        }
    }
    panic!(
        "no complete contact within {max_steps} steps (start {start:?}, end {end:?}, gap {previous:e})"
    );
}

/// The glass pair of Chung & Ooi (2011, Granular Matter 13:643-656) test 1: R = 0.010 m,
/// head-on at +-10 m/s, E = 48 GPa, nu = 0.20, rho = 2800 kg/m^3; `damping` is the
/// material's damping line.
pub fn glass_pair(damping: String) -> ImpactScene {
    ImpactScene {
        youngs_modulus: 48e9,
        poisson_ratio: 0.20,
        density: 2800.0,
        radius: 0.010,
        speed: 10.0,
        wall: false,
        damping,
    }
}

// ---------------------------------------------------------------------------------------
// Helpers for the contact-model tests (friction, rolling resistance, JKR adhesion).

pub fn angular_velocity(sim: &Simulation, id: u32) -> [f64; 3] {
    let i = row(sim, id);
    let p = sim.world.resource::<Particles>();
    [
        p.angular_velocity[0][i],
        p.angular_velocity[1][i],
        p.angular_velocity[2][i],
    ]
}

/// Contact force on particle `id` of the last step (body forces excluded).
pub fn contact_force(sim: &Simulation, id: u32) -> [f64; 3] {
    let i = row(sim, id);
    let p = sim.world.resource::<Particles>();
    [p.force[0][i], p.force[1][i], p.force[2][i]]
}

/// Simulated time, s.
pub fn sim_time(sim: &Simulation) -> f64 {
    sim.world.resource::<grainflow_components::SimClock>().time
}

/// One step; panics if the run failed.
pub fn step_ok(sim: &mut Simulation) {
    sim.step();
    if let Some(f) = sim.failure() {
        panic!("run failed at t = {:e} s: {f}", sim_time(sim));
    }
}

/// Set the body acceleration of every material to `g` during a run (scenes without
/// `[fluid]`, where it is the gravity itself): a slowly turned gravity vector is a plane
/// tilted quasi-statically.
pub fn set_gravity(sim: &mut Simulation, g: [f64; 3]) {
    let mut body = sim
        .world
        .resource_mut::<grainflow_components::BodyAcceleration>();
    for m in body.per_material.iter_mut() {
        *m = g;
    }
}

pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// A TOML float (the `{:e}` form, which TOML reads, e.g. `2.5e-3`).
pub fn toml_f(x: f64) -> String {
    format!("{x:e}")
}

pub fn toml_v(v: [f64; 3]) -> String {
    format!("[{:e}, {:e}, {:e}]", v[0], v[1], v[2])
}

/// The `[simulation]` table.
pub fn simulation_toml(dt: f64, integrator: &str, gravity: [f64; 3]) -> String {
    format!(
        "[simulation]\ndt = {}\nend_time = 1.0\nintegrator = \"{integrator}\"\ngravity = {}\n\n",
        toml_f(dt),
        toml_v(gravity)
    )
}

/// A `[[materials]]` table; `extra` holds further lines (damping law, friction, ...).
pub fn material_toml(
    name: &str,
    density: f64,
    youngs_modulus: f64,
    nu: f64,
    extra: &str,
) -> String {
    format!(
        "[[materials]]\nname = \"{name}\"\ndensity = {}\nyoungs_modulus = {}\npoisson_ratio = {nu}\n{extra}\n\n",
        toml_f(density),
        toml_f(youngs_modulus)
    )
}

/// A rigid wall material: E = 1e25 Pa makes its (1-nu^2)/E and (2-nu)/G terms 1e-14 or
/// less of any sphere's here, so E* and G* are the sphere's alone. `extra` must give the
/// same damping kind as the spheres' material.
pub fn rigid_material_toml(name: &str, extra: &str) -> String {
    material_toml(name, 1.0, 1e25, 0.0, extra)
}

/// A plane wall through `point` with unit `normal`.
pub fn plane_toml(material: &str, point: [f64; 3], normal: [f64; 3]) -> String {
    format!(
        "[[walls]]\ntype = \"plane\"\nmaterial = \"{material}\"\npoint = {}\nnormal = {}\n\n",
        toml_v(point),
        toml_v(normal)
    )
}

/// A `[[spheres]]` entry.
pub fn sphere_toml(
    material: &str,
    radius: f64,
    position: [f64; 3],
    velocity: [f64; 3],
    angular_velocity: [f64; 3],
    fixed: bool,
) -> String {
    format!(
        "[[spheres]]\nmaterial = \"{material}\"\nradius = {}\nposition = {}\nvelocity = {}\n\
         angular_velocity = {}\nfixed = {fixed}\n\n",
        toml_f(radius),
        toml_v(position),
        toml_v(velocity),
        toml_v(angular_velocity)
    )
}

/// Static Hertz overlap of a sphere pressed by `load` against a rigid plane:
/// load = (4/3) E* sqrt(R) delta^(3/2).
pub fn hertz_static_overlap(e_star: f64, radius: f64, load: f64) -> f64 {
    (load / (4.0 / 3.0 * e_star * radius.sqrt())).powf(2.0 / 3.0)
}

/// Mindlin's tangential stiffness 8 G* a of a sphere (E, nu) on a rigid plane at overlap
/// `delta`: 1/G* = (2 - nu)/G, G = E/(2(1+nu)), a = sqrt(R delta).
pub fn mindlin_stiffness_on_rigid(e: f64, nu: f64, radius: f64, delta: f64) -> f64 {
    let g = e / (2.0 * (1.0 + nu));
    8.0 * g / (2.0 - nu) * (radius * delta).sqrt()
}

/// A sphere on the rigid plane z = 0 (normal +z), for the friction and rolling tests.
/// Gravity may be tilted (the scene's `gravity`); the sphere starts at the static Hertz
/// overlap of the normal component `g_n` of gravity, so that no normal oscillation starts.
#[derive(Debug, Clone)]
pub struct Ball {
    pub radius: f64,
    pub density: f64,
    pub youngs_modulus: f64,
    pub poisson_ratio: f64,
    /// Contact-law lines of the ball's material and of the plane's (same damping kind).
    pub lines: String,
    pub wall_lines: String,
}

impl Ball {
    pub fn mass(&self) -> f64 {
        sphere_mass(self.density, self.radius)
    }
    /// E* against the rigid plane: E/(1 - nu^2).
    pub fn e_star(&self) -> f64 {
        self.youngs_modulus / (1.0 - self.poisson_ratio * self.poisson_ratio)
    }
    pub fn rest_overlap(&self, g_n: f64) -> f64 {
        hertz_static_overlap(self.e_star(), self.radius, self.mass() * g_n)
    }
    /// Normal contact stiffness at rest: dF/d delta = 2 E* a = (3/2) m g_n / delta.
    pub fn normal_stiffness(&self, g_n: f64) -> f64 {
        1.5 * self.mass() * g_n / self.rest_overlap(g_n)
    }
    /// Mindlin's c_s = 8 G* a at rest.
    pub fn tangential_stiffness(&self, g_n: f64) -> f64 {
        mindlin_stiffness_on_rigid(
            self.youngs_modulus,
            self.poisson_ratio,
            self.radius,
            self.rest_overlap(g_n),
        )
    }
    /// Critical damping of the contact point's tangential oscillation at rest: a sphere
    /// that rolls on its contact point has the tangential mass m / (1 + m R^2/I) = 2m/7.
    pub fn critical_tangential_damping(&self, g_n: f64) -> f64 {
        2.0 * (self.tangential_stiffness(g_n) * 2.0 / 7.0 * self.mass()).sqrt()
    }
    /// The shorter of the normal period 2 pi sqrt(m/k_n) and the contact point's
    /// tangential period 2 pi sqrt(2m/(7 c_s)) at rest.
    pub fn shortest_period(&self, g_n: f64) -> f64 {
        let m = self.mass();
        let normal = 2.0 * std::f64::consts::PI * (m / self.normal_stiffness(g_n)).sqrt();
        let tangential =
            2.0 * std::f64::consts::PI * (2.0 / 7.0 * m / self.tangential_stiffness(g_n)).sqrt();
        normal.min(tangential)
    }
    /// The ball resting on the plane at x = 0 with `velocity` and `spin`.
    pub fn scene(
        &self,
        dt: f64,
        integrator: &str,
        gravity: [f64; 3],
        g_n: f64,
        velocity: [f64; 3],
        spin: [f64; 3],
    ) -> Simulation {
        let text = simulation_toml(dt, integrator, gravity)
            + &material_toml(
                "ball",
                self.density,
                self.youngs_modulus,
                self.poisson_ratio,
                &self.lines,
            )
            + &rigid_material_toml("rigid", &self.wall_lines)
            + &plane_toml("rigid", [0.0; 3], [0.0, 0.0, 1.0])
            + &sphere_toml(
                "ball",
                self.radius,
                [0.0, 0.0, self.radius - self.rest_overlap(g_n)],
                velocity,
                spin,
                false,
            );
        simulation(&text, "ball_on_plane.toml")
    }
}

/// Scene text: fluid box `[0,1]^3` of `cells`^3 coarse cells at `level`, viscosity `nu`,
/// fluid time step `dt_f`, `boundaries` (TOML lines), one sphere (TOML lines), the
/// coupling section and extra fluid lines.
pub fn unit_box_scene(
    cells: usize,
    level: u32,
    nu: f64,
    dt_f: f64,
    boundaries: &str,
    sphere: &str,
) -> String {
    format!(
        r#"
[simulation]
dt = {dt_f}
end_time = 1.0
gravity = [0.0, 0.0, 0.0]
output_interval = 0.0
# one sphere and no walls: no contact to resolve
allow_unstable_dt = true

[fluid]
density = 1.0
viscosity = {nu}
min = [0.0, 0.0, 0.0]
max = [1.0, 1.0, 1.0]
cells = [{cells}, {cells}, {cells}]
level = {level}
dt = {dt_f}
scheme = "backward_euler"

[fluid.boundaries]
{boundaries}

[[materials]]
name = "s"
density = 1.0
youngs_modulus = 100.0
poisson_ratio = 0.3

[[spheres]]
material = "s"
{sphere}
"#
    )
}

/// Periodic y and z sides (TOML lines of `[fluid.boundaries]`).
pub const PERIODIC_YZ: &str = r#"ymin = { type = "periodic" }
ymax = { type = "periodic" }
zmin = { type = "periodic" }
zmax = { type = "periodic" }"#;

/// Run until `fluid_steps` fluid steps are done.
pub fn run_fluid_steps(sim: &mut Simulation, fluid_steps: u64) {
    while sim
        .world
        .resource::<grainflow_systems::fluid::FluidFlow>()
        .stats
        .steps
        < fluid_steps
    {
        sim.step();
        assert!(sim.failure().is_none(), "{:?}", sim.failure());
    }
    // the forces of the last fluid step are sampled in the step that ran it
}

/// Hasimoto's Stokes drag factor of a simple cubic array of spheres (Hasimoto 1959, J.
/// Fluid Mech. 5:317; coefficients as quoted by Sangani & Acrivos 1982, Int. J.
/// Multiphase Flow 8:343): `F = 6 pi mu a U K`,
/// `1/K = 1 - 1.7601 c^(1/3) + c - 1.5593 c^2 + O(c^(8/3))` with the solid fraction `c`
/// and the superficial velocity `U`.
pub fn hasimoto_factor(c: f64) -> f64 {
    1.0 / (1.0 - 1.7601 * c.cbrt() + c - 1.5593 * c * c)
}

/// The drag of a fixed sphere in a periodic array, as measured by [`periodic_array_drag`].
#[derive(Debug, Clone, Copy)]
pub struct ArrayDrag {
    /// `F_x / (6 pi mu a U)` with the coupling's force `F` and the superficial velocity
    /// `U` (the volume mean of `u_x`, zero in the solid).
    pub k: f64,
    /// The drag over the body force on the fluid (1 in a steady state).
    pub balance: f64,
}

/// A fixed sphere of radius `a` = 1/8 at `centre` in the periodic unit box, `cells`^3
/// coarse cells at `level`, nu = 1, driven along x by the body force 0.5 (Stokes flow: Re ~
/// 0.02), with the coupling lines `coupling` and the further fluid lines `fluid` (TOML), after `steps` backward-Euler steps of
/// 0.25 from rest: the drag factor of [`hasimoto_factor`] and the momentum balance. The
/// flow approaches its steady state slowly, and not faster with longer steps (on 32^3
/// the drag carries 81 % of the body force after 30 steps, 97 % after 60 and 99.4 % after
/// 90; with 8 times longer steps, 63 % after 20): take 90 steps for a steady drag.
pub fn periodic_array_drag(
    cells: usize,
    level: u32,
    centre: [f64; 3],
    coupling: &str,
    fluid: &str,
    steps: u64,
) -> ArrayDrag {
    let (a, nu, f) = (0.125, 1.0, 0.5);
    let mut text = unit_box_scene(
        cells,
        level,
        nu,
        0.25,
        &format!(
            "xmin = {{ type = \"periodic\" }}\nxmax = {{ type = \"periodic\" }}\n{PERIODIC_YZ}"
        ),
        &format!("radius = {a}\nposition = {centre:?}\nfixed = true"),
    )
    .replace(
        "scheme = \"backward_euler\"",
        &format!("scheme = \"backward_euler\"\nbody_force = [{f}, 0.0, 0.0]\n{fluid}"),
    );
    text.push_str(&format!("\n[coupling]\n{coupling}\n"));
    let mut sim = simulation(&text, "periodic-array.toml");
    run_fluid_steps(&mut sim, steps);
    let drag = sim
        .world
        .resource::<grainflow_components::HydroForces>()
        .force[0][0];
    let flow = sim.world.resource::<grainflow_systems::fluid::FluidFlow>();
    let (ml, mask) = (flow.solver.lumped_mass(), flow.solver.mask());
    let volume: f64 = ml.iter().sum();
    let u_s = flow.solver.u[0]
        .iter()
        .zip(ml)
        .map(|(u, m)| u * m)
        .sum::<f64>()
        / volume;
    let free: f64 = ml
        .iter()
        .zip(mask)
        .filter(|(_, &m)| !m)
        .map(|(m, _)| m)
        .sum();
    ArrayDrag {
        k: drag / (6.0 * std::f64::consts::PI * nu * a * u_s),
        balance: drag / (f * free),
    }
}
