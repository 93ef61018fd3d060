//! Scene files: TOML, every field documented in `docs/scene-format.md`.
//!
//! Loading is strict: unknown fields, wrong types and out-of-range values are errors that
//! name the file, the field and what was expected ([`SceneError`], exit code 2).
//! `--set KEY=VALUE` overrides are applied to the parsed TOML before it is read, so they
//! are checked exactly like the file.
use std::fmt;
use std::path::{Path, PathBuf};

use serde::Deserialize;

/// A bad scene: which file, which field, what was expected.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneError {
    pub file: PathBuf,
    pub field: String,
    pub message: String,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.field.is_empty() {
            write!(f, "{}: {}", self.file.display(), self.message)
        } else {
            write!(
                f,
                "{}: field `{}`: {}",
                self.file.display(),
                self.field,
                self.message
            )
        }
    }
}

impl std::error::Error for SceneError {}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    pub simulation: Simulation,
    #[serde(default)]
    pub fluid: Option<Fluid>,
    /// Fluid-particle coupling (a scene with a fluid grid and particles; defaults apply
    /// when the section is absent).
    #[serde(default)]
    pub coupling: Option<CouplingSpec>,
    #[serde(default)]
    pub neighbour: Neighbour,
    #[serde(default)]
    pub materials: Vec<MaterialSpec>,
    #[serde(default)]
    pub walls: Vec<WallSpec>,
    #[serde(default)]
    pub spheres: Vec<SphereSpec>,
    #[serde(default)]
    pub blocks: Vec<BlockSpec>,
    /// Rigid particle types made of member spheres.
    #[serde(default)]
    pub clump_types: Vec<crate::clumps::ClumpTypeSpec>,
    /// Clumps placed one by one.
    #[serde(default)]
    pub clumps: Vec<crate::clumps::ClumpSpec>,
    #[serde(default)]
    pub lammps: Vec<LammpsSpec>,
    #[serde(default)]
    pub inflows: Vec<InflowSpec>,
    /// Planes through which particles leave the scene (removed, counted per sink).
    #[serde(default)]
    pub sinks: Vec<SinkSpec>,
    /// Contact-law values of a material pair, overriding those mixed from both materials.
    #[serde(default)]
    pub interactions: Vec<InteractionSpec>,
    /// Set by [`parse`] for a coupled scene (fluid grid and particles): the DEM subcycles
    /// per fluid step n_s and the DEM step the file asked for; `simulation.dt` then holds
    /// the subcycle step dt_F / n_s.
    #[serde(skip)]
    pub subcycling: Option<(u32, f64)>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum IntegratorName {
    Gear,
    VelocityVerlet,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Simulation {
    /// DEM time step, s.
    pub dt: f64,
    /// Simulated end time, s.
    pub end_time: f64,
    #[serde(default = "default_integrator")]
    pub integrator: IntegratorName,
    /// Gravitational acceleration, m/s^2.
    #[serde(default = "default_gravity")]
    pub gravity: [f64; 3],
    /// Time between particle outputs, s (0: only the first and last state).
    #[serde(default)]
    pub output_interval: f64,
    /// Run even when dt exceeds the stable estimate.
    #[serde(default)]
    pub allow_unstable_dt: bool,
    /// Overlap (fraction of the smaller radius) at which a run is stopped as unstable.
    #[serde(default = "default_overlap_limit")]
    pub overlap_limit: f64,
    /// Growth of the particles' mechanical energy, as a fraction of its scale (the
    /// largest kinetic energy, at least m |a| r summed), at which a run is stopped as
    /// unstable (`energy_monitor`; enforced only without flow coupling, fixed particles
    /// or adhesion).
    #[serde(default = "default_energy_growth_limit")]
    pub energy_growth_limit: f64,
    /// Seed of the random placement (blocks, inflows).
    #[serde(default = "default_seed")]
    pub seed: u64,
}

fn default_integrator() -> IntegratorName {
    IntegratorName::Gear
}
fn default_gravity() -> [f64; 3] {
    [0.0, 0.0, -9.81]
}
fn default_overlap_limit() -> f64 {
    0.2
}
fn default_energy_growth_limit() -> f64 {
    0.1
}
fn default_seed() -> u64 {
    1
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fluid {
    /// Fluid density rho_f, kg/m^3: buoyancy (rho - rho_f) V g.
    pub density: f64,
    /// Kinematic viscosity nu, m^2/s (required with a grid).
    pub viscosity: Option<f64>,
    /// Lower corner of the fluid box (required with a grid).
    pub min: Option<[f64; 3]>,
    /// Upper corner of the fluid box (required with a grid).
    pub max: Option<[f64; 3]>,
    /// Cells per direction of the coarse grid (level 1); or give `cell_size`.
    pub cells: Option<[usize; 3]>,
    /// Edge of the coarse cells, dividing every side of the box; or give `cells`.
    pub cell_size: Option<f64>,
    /// Grid level: coarse cells x 2^(level-1) per direction.
    #[serde(default = "default_level")]
    pub level: u32,
    /// Fluid time step dt_F, s (required with a grid).
    pub dt: Option<f64>,
    #[serde(default)]
    pub scheme: FluidScheme,
    /// Form of the viscous term.
    #[serde(default)]
    pub viscous: FluidViscous,
    /// How the pressure acts on the face velocities; unset, [`parse`] chooses `shared` in
    /// scenes with particles that move in the fluid (their added mass) and `normal`
    /// otherwise.
    #[serde(default)]
    pub pressure_force: Option<FluidPressureForce>,
    /// Scale of the local Peclet numbers in the Samarskij upwind weights of the convection
    /// (1: full Samarskij upwinding; 0.1 as FEATFLOW's UPSAM adds less numerical
    /// diffusion at high cell Reynolds numbers).
    #[serde(default = "default_upwind")]
    pub upwind: f64,
    /// Upwind scale of the operator the momentum multigrid solves (deferred correction:
    /// the steady states are those of `upwind`); default: `upwind` itself.
    #[serde(default)]
    pub solve_upwind: Option<f64>,
    /// Relative residual reduction of each momentum solve; default: the solver's
    /// (`grainflow_fluid::NsConfig::new`).
    #[serde(default)]
    pub momentum_rtol: Option<f64>,
    /// Relative residual reduction of each pressure solve; default: the solver's.
    #[serde(default)]
    pub pressure_rtol: Option<f64>,
    /// Constant body force per unit mass on the fluid, m/s^2 (drives periodic flows;
    /// gravity is not applied to the fluid: its hydrostatic part is the buoyancy).
    #[serde(default)]
    pub body_force: [f64; 3],
    #[serde(default)]
    pub boundaries: FluidBoundaries,
    /// Fixed solid bodies inside the flow (`[[fluid.obstacles]]`): the faces whose centres
    /// lie in them are held at rest, as the box's walls (`src/obstacles.rs`).
    #[serde(default)]
    pub obstacles: Vec<FluidObstacle>,
    /// Discs of a box side with a prescribed normal velocity (`[[fluid.outlets]]`, e.g. a
    /// suction pipe's mouth; `src/outlets.rs`).
    #[serde(default)]
    pub outlets: Vec<FluidOutlet>,
}

/// A disc of a box side through which the flow leaves (or enters) at a prescribed speed.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FluidOutlet {
    #[serde(default)]
    pub name: Option<String>,
    pub side: FluidSide,
    /// The disc's centre in the side's two coordinates (in x, y, z order).
    pub center: [f64; 2],
    pub radius: f64,
    /// Outward normal speed, m/s (negative: inflow).
    pub velocity: f64,
}

/// A side of the fluid box.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FluidSide {
    Xmin,
    Xmax,
    Ymin,
    Ymax,
    Zmin,
    Zmax,
}

impl FluidSide {
    /// The direction normal to the side and the side (0 lower, 1 upper).
    pub fn direction_and_side(self) -> (usize, usize) {
        let k = self as usize;
        (k / 2, k % 2)
    }

    pub fn name(self) -> &'static str {
        ["xmin", "xmax", "ymin", "ymax", "zmin", "zmax"][self as usize]
    }
}

/// A fixed solid body the flow goes around (`[[fluid.obstacles]]`).
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum FluidObstacle {
    /// A cylindrical shell open at both ends: `inner_radius <= |x - axis| <= outer_radius`
    /// for `bottom <= x_axis <= top`.
    Pipe {
        #[serde(default)]
        name: Option<String>,
        axis: Axis,
        /// Axis position in the two other coordinates (in x, y, z order).
        center: [f64; 2],
        inner_radius: f64,
        outer_radius: f64,
        bottom: f64,
        top: f64,
    },
    /// An axis-aligned solid box.
    Box {
        #[serde(default)]
        name: Option<String>,
        min: [f64; 3],
        max: [f64; 3],
    },
}

/// The `[coupling]` section: how particles and the flow act on each other.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CouplingSpec {
    /// Blending exponent factor alpha of phi = exp(-alpha Re_p) (Luo et al. 2007); no
    /// blending when absent.
    #[serde(default)]
    pub alpha: Option<f64>,
    /// Hydrodynamic force method of particles whose faces are held (fixed particles, or
    /// every particle with `update = "prescribed"`).
    #[serde(default)]
    pub force: ForceMethodName,
    /// How free particles follow the flow.
    #[serde(default)]
    pub update: ParticleUpdateName,
    /// How the fluid inside a free particle accelerates under `update = "fluid_momentum"`.
    #[serde(default)]
    pub inside_fluid: InsideFluidName,
    /// Where the fluid sees the particles' surfaces.
    #[serde(default)]
    pub boundary: BoundaryRuleName,
    /// Points of the Lebedev-Laikov rule of the surface force points.
    #[serde(default = "default_force_points")]
    pub points: usize,
    /// The lubrication correction between particles closer than `lubrication_range`
    /// (`grainflow_systems::coupling::lubrication`).
    #[serde(default)]
    pub lubrication: bool,
    /// Surface gap below which the lubrication correction acts (default: the fluid cell
    /// size, the smallest of its three sides).
    #[serde(default)]
    pub lubrication_range: Option<f64>,
    /// Smallest gap of the lubrication correction (default: 1 % of the smallest radius).
    #[serde(default)]
    pub lubrication_roughness: Option<f64>,
}

impl Default for CouplingSpec {
    fn default() -> Self {
        CouplingSpec {
            alpha: None,
            force: ForceMethodName::default(),
            update: ParticleUpdateName::default(),
            inside_fluid: InsideFluidName::default(),
            boundary: BoundaryRuleName::default(),
            points: default_force_points(),
            lubrication: false,
            lubrication_range: None,
            lubrication_roughness: None,
        }
    }
}

fn default_force_points() -> usize {
    110
}

/// Boundary rule names of the scene file (`grainflow_components::BoundaryRule`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BoundaryRuleName {
    /// The default: a face belongs to a particle when its centre lies inside.
    #[default]
    FaceCentre,
    /// The face-centre rule plus an implicit penalty on the faces within a cell outside
    /// the surface, which puts the wall at the true surface
    /// (`grainflow_systems::coupling::distance_penalty`).
    DistancePenalty,
}

/// Particle update names of the scene file (`grainflow_components::ParticleUpdate`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ParticleUpdateName {
    /// The fluid inside a particle moves with the flow through a fluid step and its
    /// momentum gain is the particle's impulse (Sharma & Patankar 2005). Measured: stays
    /// stable where `prescribed` runs away (one sphere, rho/rho_f = 1.001, in a lid-driven
    /// box at U dt/h = 4); with `fluid.pressure_force = "shared"` its added mass is
    /// within 3 % of potential flow's (tests/added_mass.rs).
    FluidMomentum,
    /// The default: the faces inside a particle are held at its rigid-body velocity and
    /// the force is sampled after the step (explicit).
    #[default]
    Prescribed,
}

/// Names of the inside-fluid rules of the scene file (`grainflow_components::InsideFluid`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InsideFluidName {
    /// The default: the fluid inside accelerates with the particle (a load on its faces).
    #[default]
    Particle,
    /// The fluid inside accelerates as fluid, by the force of the fluid around it (the
    /// rule before issue 37; kept for comparison: first order in the fluid step).
    Fluid,
}

/// Hydrodynamic force method names of the scene file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ForceMethodName {
    SurfacePoints,
    /// The default: within 7 % of Hasimoto's periodic-array drag at 4 cells per radius,
    /// against +35 % for the surface points (tests/coupling.rs).
    #[default]
    VolumeIntegral,
}

fn default_upwind() -> f64 {
    1.0
}

fn default_level() -> u32 {
    1
}

/// Time stepping of the flow (backward Euler is used for the first step of the others).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FluidScheme {
    #[default]
    FractionalStep,
    CrankNicolson,
    BackwardEuler,
}

/// Form of the viscous term of the flow: `-nu Laplace u` or the seed's stress tensor
/// `-div(2 nu D(u))`; they differ at do-nothing (outflow) sides.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FluidViscous {
    #[default]
    Laplacian,
    Deformation,
}

/// How the pressure acts on the face velocities: `normal` (the Galerkin form of the
/// Q1~/P0 pair) or `shared` (see `grainflow_fluid::PressureForce`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FluidPressureForce {
    Normal,
    Shared,
}

/// Boundary conditions of the six sides of the fluid box (default: no-slip walls).
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FluidBoundaries {
    #[serde(default)]
    pub xmin: FluidBoundary,
    #[serde(default)]
    pub xmax: FluidBoundary,
    #[serde(default)]
    pub ymin: FluidBoundary,
    #[serde(default)]
    pub ymax: FluidBoundary,
    #[serde(default)]
    pub zmin: FluidBoundary,
    #[serde(default)]
    pub zmax: FluidBoundary,
}

impl FluidBoundaries {
    /// The sides as `[[lower, upper]; 3]` with their names.
    pub fn sides(&self) -> [[(&'static str, &FluidBoundary); 2]; 3] {
        [
            [("xmin", &self.xmin), ("xmax", &self.xmax)],
            [("ymin", &self.ymin), ("ymax", &self.ymax)],
            [("zmin", &self.zmin), ("zmax", &self.zmax)],
        ]
    }
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum FluidBoundary {
    /// No-slip wall, or a moving wall (lid) with the given tangential velocity.
    Wall {
        #[serde(default)]
        velocity: [f64; 3],
    },
    /// Prescribed inflow: `velocity` uniform over the side, or its peak of a parabolic
    /// profile vanishing on the side's edges.
    Inflow {
        velocity: [f64; 3],
        #[serde(default)]
        profile: InflowProfile,
    },
    /// Do-nothing outflow.
    Outflow,
    /// Periodic with the opposite side (both sides must say so).
    Periodic,
}

impl Default for FluidBoundary {
    fn default() -> Self {
        FluidBoundary::Wall { velocity: [0.0; 3] }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InflowProfile {
    #[default]
    Uniform,
    Parabolic,
}

impl Fluid {
    /// Whether the scene solves the flow (it gives a grid), or only uses the fluid
    /// density for buoyancy.
    pub fn has_grid(&self) -> bool {
        self.cells.is_some() || self.cell_size.is_some()
    }
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Neighbour {
    /// Verlet skin, m (default 0.1 x the largest diameter).
    pub skin: Option<f64>,
    /// Re-sort particles in cell order every this many list rebuilds (0: never).
    pub sort_every: Option<u32>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    pub name: String,
    pub density: f64,
    pub youngs_modulus: f64,
    #[serde(default)]
    pub poisson_ratio: f64,
    /// Constant normal damping d_n, N s/m (the seed's law).
    pub normal_damping: Option<f64>,
    /// Coefficient of restitution (alternative to `normal_damping`).
    pub restitution: Option<f64>,
    /// Static friction coefficient mu_s (Coulomb friction with a tangential spring).
    pub friction: Option<f64>,
    /// Dynamic friction coefficient mu_d (default: mu_s).
    pub dynamic_friction: Option<f64>,
    /// Tangential spring stiffness c_s, N/m (default: Mindlin 8 G* a).
    pub tangential_stiffness: Option<f64>,
    /// Tangential damping d_s, N s/m (default 0).
    pub tangential_damping: Option<f64>,
    /// Rolling friction coefficient mu_r: rolling torque capped at mu_r R* F_n.
    pub rolling_friction: Option<f64>,
    /// Rolling stiffness c_r, N/m (default 2.25 mu_r^2 k_n, k_n = 2 E* a).
    pub rolling_stiffness: Option<f64>,
    /// Rolling damping d_r, N s/m (default 0).
    pub rolling_damping: Option<f64>,
    /// Work of adhesion W, J/m^2 (JKR adhesion).
    pub work_of_adhesion: Option<f64>,
}

/// The contact-law fields of a material or of an interaction.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SurfaceSpec {
    pub friction: Option<f64>,
    pub dynamic_friction: Option<f64>,
    pub tangential_stiffness: Option<f64>,
    pub tangential_damping: Option<f64>,
    pub rolling_friction: Option<f64>,
    pub rolling_stiffness: Option<f64>,
    pub rolling_damping: Option<f64>,
    pub work_of_adhesion: Option<f64>,
}

impl SurfaceSpec {
    /// Names and values, in scene-file order.
    pub fn fields(&self) -> [(&'static str, Option<f64>); 8] {
        [
            ("friction", self.friction),
            ("dynamic_friction", self.dynamic_friction),
            ("tangential_stiffness", self.tangential_stiffness),
            ("tangential_damping", self.tangential_damping),
            ("rolling_friction", self.rolling_friction),
            ("rolling_stiffness", self.rolling_stiffness),
            ("rolling_damping", self.rolling_damping),
            ("work_of_adhesion", self.work_of_adhesion),
        ]
    }
}

macro_rules! surface_of {
    ($s:expr) => {
        SurfaceSpec {
            friction: $s.friction,
            dynamic_friction: $s.dynamic_friction,
            tangential_stiffness: $s.tangential_stiffness,
            tangential_damping: $s.tangential_damping,
            rolling_friction: $s.rolling_friction,
            rolling_stiffness: $s.rolling_stiffness,
            rolling_damping: $s.rolling_damping,
            work_of_adhesion: $s.work_of_adhesion,
        }
    };
}

impl MaterialSpec {
    pub fn surface(&self) -> SurfaceSpec {
        surface_of!(self)
    }
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InteractionSpec {
    /// The two materials of the pair (in either order; the same name twice for a
    /// material with itself).
    pub materials: [String; 2],
    /// Static friction coefficient mu_s (Coulomb friction with a tangential spring).
    pub friction: Option<f64>,
    /// Dynamic friction coefficient mu_d (default: mu_s).
    pub dynamic_friction: Option<f64>,
    /// Tangential spring stiffness c_s, N/m (default: Mindlin 8 G* a).
    pub tangential_stiffness: Option<f64>,
    /// Tangential damping d_s, N s/m (default 0).
    pub tangential_damping: Option<f64>,
    /// Rolling friction coefficient mu_r: rolling torque capped at mu_r R* F_n.
    pub rolling_friction: Option<f64>,
    /// Rolling stiffness c_r, N/m (default 2.25 mu_r^2 k_n, k_n = 2 E* a).
    pub rolling_stiffness: Option<f64>,
    /// Rolling damping d_r, N s/m (default 0).
    pub rolling_damping: Option<f64>,
    /// Work of adhesion W, J/m^2 (JKR adhesion).
    pub work_of_adhesion: Option<f64>,
}

impl InteractionSpec {
    pub fn surface(&self) -> SurfaceSpec {
        surface_of!(self)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    pub fn index(self) -> usize {
        self as usize
    }

    /// The two other directions, in x, y, z order (the order of a `center`).
    pub fn others(self) -> [usize; 2] {
        other_directions(self.index())
    }
}

/// The two directions other than `d`, in x, y, z order.
pub fn other_directions(d: usize) -> [usize; 2] {
    match d {
        0 => [1, 2],
        1 => [0, 2],
        _ => [0, 1],
    }
}

#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum WallSpec {
    Plane {
        #[serde(default)]
        name: Option<String>,
        material: String,
        point: [f64; 3],
        normal: [f64; 3],
        #[serde(default)]
        remove_at: Option<f64>,
    },
    Box {
        #[serde(default)]
        name: Option<String>,
        material: String,
        min: [f64; 3],
        max: [f64; 3],
    },
    Cylinder {
        #[serde(default)]
        name: Option<String>,
        material: String,
        axis: Axis,
        /// Axis position in the two other coordinates (in x, y, z order).
        center: [f64; 2],
        radius: f64,
        #[serde(default)]
        bottom: Option<f64>,
        #[serde(default)]
        top: Option<f64>,
    },
    Cone {
        #[serde(default)]
        name: Option<String>,
        material: String,
        axis: Axis,
        center: [f64; 2],
        radius_bottom: f64,
        radius_top: f64,
        bottom: f64,
        top: f64,
    },
    /// A solid cylindrical shell open at both ends (a suction pipe): particles meet its
    /// bore, its outside and its rims (rounded, of radius half the wall thickness). With
    /// `fluid_obstacle = true` it is also an obstacle of the flow, the
    /// `[[fluid.obstacles]]` pipe of the same geometry (with square rims).
    Pipe {
        #[serde(default)]
        name: Option<String>,
        material: String,
        axis: Axis,
        /// Axis position in the two other coordinates (in x, y, z order).
        center: [f64; 2],
        inner_radius: f64,
        outer_radius: f64,
        bottom: f64,
        top: f64,
        #[serde(default)]
        fluid_obstacle: bool,
    },
}

impl WallSpec {
    /// The obstacle of the flow of the same geometry, for a pipe (named as the wall, or
    /// `walls[k]`).
    pub fn as_obstacle(&self, k: usize) -> Option<FluidObstacle> {
        match *self {
            WallSpec::Pipe {
                ref name,
                axis,
                center,
                inner_radius,
                outer_radius,
                bottom,
                top,
                ..
            } => Some(FluidObstacle::Pipe {
                name: Some(name.clone().unwrap_or_else(|| format!("walls[{k}]"))),
                axis,
                center,
                inner_radius,
                outer_radius,
                bottom,
                top,
            }),
            _ => None,
        }
    }
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereSpec {
    pub material: String,
    pub radius: f64,
    pub position: [f64; 3],
    #[serde(default)]
    pub velocity: [f64; 3],
    #[serde(default)]
    pub angular_velocity: [f64; 3],
    /// Kinematic particle: moves with its constant `velocity`, never rotates, whatever the
    /// forces.
    #[serde(default)]
    pub fixed: bool,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BlockSpec {
    /// Material and radius of the spheres (a block of spheres).
    #[serde(default)]
    pub material: Option<String>,
    #[serde(default)]
    pub radius: Option<f64>,
    /// A clump type instead: every site gets a clump of this type, randomly oriented.
    #[serde(default)]
    pub clump: Option<String>,
    pub min: [f64; 3],
    pub max: [f64; 3],
    /// Lattice spacing, m (default 2.1 radius; for clumps 2.1 times their bounding
    /// radius).
    #[serde(default)]
    pub spacing: Option<f64>,
    /// Random displacement of each site, as a fraction of (spacing - 2 radius)/2.
    #[serde(default)]
    pub jitter: f64,
    #[serde(default)]
    pub velocity: [f64; 3],
    /// Keep at most this many particles (sites in lattice order).
    #[serde(default)]
    pub count: Option<u64>,
    /// Drop sites whose sphere would cut a wall (for blocks inside a hopper).
    #[serde(default)]
    pub inside_walls: bool,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LammpsSpec {
    /// LAMMPS `atom_style sphere` data file (relative to the scene file).
    pub file: PathBuf,
    pub material: String,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum RegionSpec {
    Box {
        min: [f64; 3],
        max: [f64; 3],
    },
    Cylinder {
        center: [f64; 2],
        radius: f64,
        bottom: f64,
        top: f64,
    },
}

/// A particle sink: every particle whose centre is on the far side of the plane through
/// `point` from `normal` (which points into the kept space) is removed; with a `radius`,
/// only within that distance of the line through `point` along `normal` (a pipe's bore).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SinkSpec {
    #[serde(default)]
    pub name: Option<String>,
    pub point: [f64; 3],
    pub normal: [f64; 3],
    #[serde(default)]
    pub radius: Option<f64>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InflowSpec {
    /// Material of the spheres (an inflow of spheres).
    #[serde(default)]
    pub material: Option<String>,
    /// A clump type instead: clumps of this type, randomly oriented.
    #[serde(default)]
    pub clump: Option<String>,
    /// Particles per second.
    pub rate: f64,
    /// Total number of particles to insert.
    pub total: u64,
    #[serde(default)]
    pub start: f64,
    #[serde(default)]
    pub stop: Option<f64>,
    /// Time between insertion batches, s (default 0.01).
    #[serde(default)]
    pub interval: Option<f64>,
    pub region: RegionSpec,
    /// Radii table and their number fractions (summing to 1), for spheres.
    #[serde(default)]
    pub radii: Vec<f64>,
    #[serde(default)]
    pub fractions: Vec<f64>,
    #[serde(default)]
    pub velocity: [f64; 3],
    #[serde(default)]
    pub velocity_jitter: f64,
}

impl Scene {
    /// Whether the scene has particles (placed or inflowing) or walls: the DEM part.
    pub fn has_particles(&self) -> bool {
        !(self.spheres.is_empty()
            && self.blocks.is_empty()
            && self.clumps.is_empty()
            && self.lammps.is_empty()
            && self.inflows.is_empty()
            && self.walls.is_empty())
    }
}

/// Read a scene file and apply `overrides` (`KEY=VALUE`, dotted keys, numeric parts index
/// arrays: `walls.0.remove_at=1.5`).
pub fn load(path: &Path, overrides: &[String]) -> Result<Scene, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|e| SceneError {
        file: path.to_path_buf(),
        field: String::new(),
        message: format!("cannot read the scene file: {e}"),
    })?;
    parse(&text, path, overrides)
}

/// Read a scene from `text`; `path` names it in errors and anchors relative file names.
pub fn parse(text: &str, path: &Path, overrides: &[String]) -> Result<Scene, SceneError> {
    let err = |field: &str, message: String| SceneError {
        file: path.to_path_buf(),
        field: field.into(),
        message,
    };
    let mut table: toml::Table = text
        .parse()
        .map_err(|e: toml::de::Error| err("", format!("not valid TOML: {e}")))?;
    for item in overrides {
        apply_override(&mut table, item)
            .map_err(|(field, m)| err(&field, format!("in --set {item}: {m}")))?;
    }
    let scene: Scene =
        serde_path_to_error::deserialize(toml::Value::Table(table)).map_err(|e| {
            let field = e.path().to_string();
            // The TOML deserializer appends an "in `path`" line: the field is named already.
            let message = e.into_inner().to_string();
            let message = message
                .lines()
                .next()
                .unwrap_or_default()
                .trim()
                .to_string();
            err(if field == "." { "" } else { &field }, message)
        })?;
    let mut scene = scene;
    let base = path.parent().unwrap_or(Path::new("."));
    for l in scene.lammps.iter_mut() {
        if l.file.is_relative() {
            l.file = base.join(&l.file);
        }
    }
    validate(&scene).map_err(|(field, m)| err(&field, m))?;
    // Pipe walls that are also obstacles of the flow join `fluid.obstacles`.
    let shared: Vec<(usize, FluidObstacle)> = scene
        .walls
        .iter()
        .enumerate()
        .filter(|(_, w)| {
            matches!(
                w,
                WallSpec::Pipe {
                    fluid_obstacle: true,
                    ..
                }
            )
        })
        .filter_map(|(k, w)| w.as_obstacle(k).map(|o| (k, o)))
        .collect();
    if let Some((k, _)) = shared.first() {
        let Some(f) = scene.fluid.as_mut() else {
            return Err(err(
                &format!("walls[{k}].fluid_obstacle"),
                "expected a [fluid] section: the wall is an obstacle of the flow".into(),
            ));
        };
        f.obstacles.extend(shared.into_iter().map(|(_, o)| o));
    }
    if let Some(dt_f) = scene
        .fluid
        .as_ref()
        .filter(|f| f.has_grid())
        .and_then(|f| f.dt)
    {
        if scene.has_particles() {
            let dt_d = scene.simulation.dt;
            let n_s = grainflow_systems::coupling::subcycles(dt_f, dt_d);
            scene.subcycling = Some((n_s, dt_d));
            scene.simulation.dt = dt_f / n_s as f64;
        }
    }
    let coupled = scene.has_particles();
    if let Some(f) = scene.fluid.as_mut() {
        // the shared force gives a moving particle its added mass (tests/added_mass.rs) and
        // a fixed one its drag at finite Re (docs/coupling.md); without particles the
        // Galerkin form keeps the cavity figures it was validated with
        f.pressure_force.get_or_insert(if coupled {
            FluidPressureForce::Shared
        } else {
            FluidPressureForce::Normal
        });
    }
    Ok(scene)
}

fn apply_override(table: &mut toml::Table, item: &str) -> Result<(), (String, String)> {
    let (key, raw) = item
        .split_once('=')
        .ok_or_else(|| (String::new(), "expected KEY=VALUE".to_string()))?;
    let value: toml::Value = match format!("v = {raw}").parse::<toml::Table>() {
        Ok(mut t) => t.remove("v").expect("parsed key"),
        Err(_) => toml::Value::String(raw.to_string()),
    };
    let parts: Vec<&str> = key.split('.').collect();
    let mut node = &mut *table;
    let mut path = String::new();
    for (k, part) in parts.iter().enumerate() {
        let last = k + 1 == parts.len();
        if !path.is_empty() {
            path.push('.');
        }
        path.push_str(part);
        // An array element: `walls.0.x`.
        if let Ok(index) = parts
            .get(k + 1)
            .map_or(Err(()), |p| p.parse::<usize>().map_err(|_| ()))
        {
            let arr = node
                .get_mut(*part)
                .and_then(|v| v.as_array_mut())
                .ok_or_else(|| (path.clone(), "is not an array in the scene".to_string()))?;
            let len = arr.len();
            let elem = arr.get_mut(index).ok_or_else(|| {
                (
                    format!("{path}.{index}"),
                    format!("index out of range ({len} entries)"),
                )
            })?;
            if k + 2 == parts.len() {
                *elem = value;
                return Ok(());
            }
            let rest = parts[k + 2..].join(".");
            let sub = elem
                .as_table_mut()
                .ok_or_else(|| (format!("{path}.{index}"), "is not a table".to_string()))?;
            return apply_override(sub, &format!("{rest}={raw}"))
                .map_err(|(f, m)| (format!("{path}.{index}.{f}"), m));
        }
        if last {
            node.insert(part.to_string(), value);
            return Ok(());
        }
        node = node
            .entry(part.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()))
            .as_table_mut()
            .ok_or_else(|| (path.clone(), "is not a table".to_string()))?;
    }
    Ok(())
}

type Invalid = (String, String);

fn positive(field: String, v: f64) -> Result<(), Invalid> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err((field, format!("expected a finite number > 0, got {v}")))
    }
}

fn finite3(field: String, v: [f64; 3]) -> Result<(), Invalid> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err((field, format!("expected three finite numbers, got {v:?}")))
    }
}

fn finite2(field: String, v: [f64; 2]) -> Result<(), Invalid> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err((field, format!("expected two finite numbers, got {v:?}")))
    }
}

fn finite_opt(field: String, v: Option<f64>) -> Result<(), Invalid> {
    match v {
        Some(x) if !x.is_finite() => Err((field, format!("expected a finite number, got {x}"))),
        _ => Ok(()),
    }
}

fn known_material(scene: &Scene, field: String, name: &str) -> Result<(), Invalid> {
    if scene.materials.iter().any(|m| m.name == name) {
        Ok(())
    } else {
        let names: Vec<&str> = scene.materials.iter().map(|m| m.name.as_str()).collect();
        Err((
            field,
            format!("unknown material `{name}`; the scene defines {names:?}"),
        ))
    }
}

/// The fluid grid: a box divided into whole cells, a positive viscosity and time step,
/// solver tolerances in (0, 1), consistent periodic sides; without a grid, none of the
/// fields that only a grid uses.
fn validate_fluid_grid(f: &Fluid) -> Result<(), Invalid> {
    if !f.has_grid() {
        for (name, given) in [
            ("viscosity", f.viscosity.is_some()),
            ("min", f.min.is_some()),
            ("max", f.max.is_some()),
            ("dt", f.dt.is_some()),
            ("momentum_rtol", f.momentum_rtol.is_some()),
            ("pressure_rtol", f.pressure_rtol.is_some()),
            ("obstacles", !f.obstacles.is_empty()),
            ("outlets", !f.outlets.is_empty()),
        ] {
            if given {
                return Err((
                    format!("fluid.{name}"),
                    "has no effect without a grid: give `cells` or `cell_size` too".into(),
                ));
            }
        }
        return Ok(());
    }
    let need = |name: &str| {
        (
            format!("fluid.{name}"),
            "expected with a fluid grid".to_string(),
        )
    };
    let nu = f.viscosity.ok_or_else(|| need("viscosity"))?;
    positive("fluid.viscosity".into(), nu)?;
    let dt = f.dt.ok_or_else(|| need("dt"))?;
    positive("fluid.dt".into(), dt)?;
    positive("fluid.upwind".into(), f.upwind)?;
    if let Some(s) = f.solve_upwind {
        positive("fluid.solve_upwind".into(), s)?;
    }
    for (name, rtol) in [
        ("momentum_rtol", f.momentum_rtol),
        ("pressure_rtol", f.pressure_rtol),
    ] {
        if let Some(r) = rtol {
            if !(r > 0.0 && r < 1.0) {
                return Err((
                    format!("fluid.{name}"),
                    format!("expected a number in (0, 1), got {r}"),
                ));
            }
        }
    }
    let min = f.min.ok_or_else(|| need("min"))?;
    let max = f.max.ok_or_else(|| need("max"))?;
    finite3("fluid.min".into(), min)?;
    finite3("fluid.max".into(), max)?;
    if (0..3).any(|d| max[d] <= min[d]) {
        return Err((
            "fluid.max".into(),
            format!("expected max > min in every coordinate, got min {min:?} max {max:?}"),
        ));
    }
    if !(1..=8).contains(&f.level) {
        return Err((
            "fluid.level".into(),
            format!("expected a level from 1 to 8, got {}", f.level),
        ));
    }
    match (f.cells, f.cell_size) {
        (Some(_), Some(_)) => {
            return Err((
                "fluid.cell_size".into(),
                "give either cells or cell_size, not both".into(),
            ))
        }
        (Some(cells), None) => {
            if cells.contains(&0) {
                return Err((
                    "fluid.cells".into(),
                    format!("expected at least one cell per direction, got {cells:?}"),
                ));
            }
        }
        (None, Some(h)) => {
            positive("fluid.cell_size".into(), h)?;
            for d in 0..3 {
                let n = (max[d] - min[d]) / h;
                if (n - n.round()).abs() > 1e-9 * n.max(1.0) || n.round() < 1.0 {
                    return Err((
                        "fluid.cell_size".into(),
                        format!(
                            "{h} does not divide the box side {} (length {}) into whole cells: {n} cells",
                            ["x", "y", "z"][d],
                            max[d] - min[d]
                        ),
                    ));
                }
            }
        }
        (None, None) => unreachable!("has_grid"),
    }
    for (d, [(lo_name, lo), (hi_name, hi)]) in f.boundaries.sides().into_iter().enumerate() {
        let periodic = [lo, hi].map(|b| *b == FluidBoundary::Periodic);
        if periodic[0] != periodic[1] {
            return Err((
                format!(
                    "fluid.boundaries.{}",
                    if periodic[0] { hi_name } else { lo_name }
                ),
                format!(
                    "expected `periodic` on both {} sides: a periodic side needs its opposite",
                    ["x", "y", "z"][d]
                ),
            ));
        }
        for (name, side) in [(lo_name, lo), (hi_name, hi)] {
            if let FluidBoundary::Wall { velocity } | FluidBoundary::Inflow { velocity, .. } = side
            {
                finite3(format!("fluid.boundaries.{name}.velocity"), *velocity)?;
            }
        }
    }
    for (k, o) in f.obstacles.iter().enumerate() {
        validate_obstacle(o, &format!("fluid.obstacles[{k}]"))?;
    }
    for (k, o) in f.outlets.iter().enumerate() {
        let at = |name: &str| format!("fluid.outlets[{k}].{name}");
        finite2(at("center"), o.center)?;
        positive(at("radius"), o.radius)?;
        if !o.velocity.is_finite() {
            return Err((
                at("velocity"),
                format!("expected a finite number, got {}", o.velocity),
            ));
        }
        let (d, side) = o.side.direction_and_side();
        if f.boundaries.sides()[d][side].1 == &FluidBoundary::Periodic {
            return Err((
                at("side"),
                format!(
                    "expected a wall, inflow or outflow side, got the periodic {}",
                    o.side.name()
                ),
            ));
        }
    }
    if !f.outlets.is_empty()
        && !f
            .boundaries
            .sides()
            .iter()
            .flatten()
            .any(|(_, b)| **b == FluidBoundary::Outflow)
    {
        return Err((
            "fluid.outlets".into(),
            "expected an `outflow` side somewhere in the box: the flow an outlet draws has to come from a side that lets it in".into(),
        ));
    }
    Ok(())
}

/// Finite coordinates, positive sizes and ordered bounds of an obstacle.
fn validate_obstacle(o: &FluidObstacle, at: &str) -> Result<(), Invalid> {
    let f = |name: &str| format!("{at}.{name}");
    match *o {
        FluidObstacle::Pipe {
            center,
            inner_radius,
            outer_radius,
            bottom,
            top,
            ..
        } => {
            finite2(f("center"), center)?;
            positive(f("inner_radius"), inner_radius)?;
            positive(f("outer_radius"), outer_radius)?;
            if outer_radius <= inner_radius {
                return Err((
                    f("outer_radius"),
                    format!(
                        "expected outer_radius > inner_radius = {inner_radius}, got {outer_radius}"
                    ),
                ));
            }
            for (name, v) in [("bottom", bottom), ("top", top)] {
                if !v.is_finite() {
                    return Err((f(name), format!("expected a finite number, got {v}")));
                }
            }
            if top <= bottom {
                return Err((
                    f("top"),
                    format!("expected top > bottom = {bottom}, got {top}"),
                ));
            }
        }
        FluidObstacle::Box { min, max, .. } => {
            finite3(f("min"), min)?;
            finite3(f("max"), max)?;
            if (0..3).any(|d| max[d] <= min[d]) {
                return Err((
                    f("max"),
                    format!("expected max > min in every coordinate, got min {min:?} max {max:?}"),
                ));
            }
        }
    }
    Ok(())
}

/// Contact-law fields: ranges, and no model parameter without its model.
fn validate_surface(v: &SurfaceSpec, at: &str) -> Result<(), Invalid> {
    let f = |name: &str| format!("{at}.{name}");
    for (name, value) in v.fields() {
        match value {
            Some(x) if !(x.is_finite() && x >= 0.0) => {
                return Err((f(name), format!("expected a finite number >= 0, got {x}")))
            }
            _ => {}
        }
    }
    for (name, value) in [
        ("tangential_stiffness", v.tangential_stiffness),
        ("rolling_stiffness", v.rolling_stiffness),
        ("work_of_adhesion", v.work_of_adhesion),
    ] {
        if let Some(x) = value {
            positive(f(name), x)?;
        }
    }
    let needs = |name: &str, value: Option<f64>, model: Option<f64>, model_name: &str| {
        if value.is_some() && model.is_none() {
            Err((
                f(name),
                format!("has no effect without `{model_name}`: give `{model_name}` too"),
            ))
        } else {
            Ok(())
        }
    };
    for (name, value) in [
        ("dynamic_friction", v.dynamic_friction),
        ("tangential_stiffness", v.tangential_stiffness),
        ("tangential_damping", v.tangential_damping),
    ] {
        needs(name, value, v.friction, "friction")?;
    }
    for (name, value) in [
        ("rolling_stiffness", v.rolling_stiffness),
        ("rolling_damping", v.rolling_damping),
    ] {
        needs(name, value, v.rolling_friction, "rolling_friction")?;
    }
    if let (Some(mu_s), Some(mu_d)) = (v.friction, v.dynamic_friction) {
        if mu_d > mu_s {
            return Err((
                f("dynamic_friction"),
                format!("expected mu_d <= mu_s = {mu_s}, got {mu_d}"),
            ));
        }
    }
    Ok(())
}

/// Range and consistency checks that the types cannot express.
fn validate(s: &Scene) -> Result<(), Invalid> {
    let sim = &s.simulation;
    positive("simulation.dt".into(), sim.dt)?;
    positive("simulation.end_time".into(), sim.end_time)?;
    finite3("simulation.gravity".into(), sim.gravity)?;
    if !(sim.output_interval.is_finite() && sim.output_interval >= 0.0) {
        return Err((
            "simulation.output_interval".into(),
            format!("expected a number >= 0, got {}", sim.output_interval),
        ));
    }
    positive("simulation.overlap_limit".into(), sim.overlap_limit)?;
    positive(
        "simulation.energy_growth_limit".into(),
        sim.energy_growth_limit,
    )?;
    if let Some(f) = &s.fluid {
        if !(f.density.is_finite() && f.density >= 0.0) {
            return Err((
                "fluid.density".into(),
                format!("expected a number >= 0, got {}", f.density),
            ));
        }
        validate_fluid_grid(f)?;
        finite3("fluid.body_force".into(), f.body_force)?;
    }
    if let Some(c) = &s.coupling {
        if !s.fluid.as_ref().is_some_and(|f| f.has_grid()) || !s.has_particles() {
            return Err((
                "coupling".into(),
                "expected a scene with a [fluid] grid and particles for a [coupling] section"
                    .into(),
            ));
        }
        if let Some(alpha) = c.alpha.filter(|a| !(a.is_finite() && *a >= 0.0)) {
            return Err((
                "coupling.alpha".into(),
                format!("expected a number >= 0, got {alpha}"),
            ));
        }
        if c.boundary == BoundaryRuleName::DistancePenalty {
            if c.force == ForceMethodName::SurfacePoints {
                return Err((
                    "coupling.boundary".into(),
                    "expected force = \"volume_integral\" with the distance penalty (the surface points sample the stress at the surface, which the penalty's reaction would count again)".into(),
                ));
            }
            if c.alpha.is_some() {
                return Err((
                    "coupling.boundary".into(),
                    "expected no `alpha` with the distance penalty (the blending and the penalty would both act on the faces outside the surface)".into(),
                ));
            }
        }
        for (field, value) in [
            ("coupling.lubrication_range", c.lubrication_range),
            ("coupling.lubrication_roughness", c.lubrication_roughness),
        ] {
            let Some(v) = value else { continue };
            if !c.lubrication {
                return Err((
                    field.into(),
                    "has no effect without `lubrication = true`".into(),
                ));
            }
            positive(field.into(), v)?;
        }
        if let (Some(range), Some(rough)) = (c.lubrication_range, c.lubrication_roughness) {
            if rough >= range {
                return Err((
                    "coupling.lubrication_roughness".into(),
                    format!("expected a gap below lubrication_range = {range}, got {rough}"),
                ));
            }
        }
        if grainflow_systems::coupling::lebedev::rule_degree(c.points).is_none() {
            let counts: Vec<usize> = grainflow_systems::coupling::lebedev::RULES
                .iter()
                .map(|r| r.0)
                .collect();
            return Err((
                "coupling.points".into(),
                format!(
                    "expected the point count of a Lebedev-Laikov rule, one of {counts:?}; got {}",
                    c.points
                ),
            ));
        }
    }
    if let Some(skin) = s.neighbour.skin {
        positive("neighbour.skin".into(), skin)?;
    }
    if s.materials.is_empty() && s.has_particles() {
        return Err((
            "materials".into(),
            "expected at least one [[materials]] entry".into(),
        ));
    }
    for (k, m) in s.materials.iter().enumerate() {
        let f = |name: &str| format!("materials[{k}].{name}");
        positive(f("density"), m.density)?;
        positive(f("youngs_modulus"), m.youngs_modulus)?;
        if !(m.poisson_ratio > -1.0 && m.poisson_ratio < 0.5) {
            return Err((
                f("poisson_ratio"),
                format!("expected -1 < nu < 0.5, got {}", m.poisson_ratio),
            ));
        }
        match (m.normal_damping, m.restitution) {
            (Some(_), Some(_)) => {
                return Err((
                    f("restitution"),
                    "give either normal_damping or restitution, not both".into(),
                ))
            }
            (Some(d), None) if !(d.is_finite() && d >= 0.0) => {
                return Err((
                    f("normal_damping"),
                    format!("expected a number >= 0 (N s/m), got {d}"),
                ))
            }
            (None, Some(e)) if !(0.0..=1.0).contains(&e) => {
                return Err((f("restitution"), format!("expected 0 <= e <= 1, got {e}")))
            }
            _ => {}
        }
        validate_surface(&m.surface(), &format!("materials[{k}]"))?;
        if s.materials[..k].iter().any(|o| o.name == m.name) {
            return Err((f("name"), format!("material `{}` is defined twice", m.name)));
        }
    }
    for (k, i) in s.interactions.iter().enumerate() {
        for (n, name) in i.materials.iter().enumerate() {
            known_material(s, format!("interactions[{k}].materials[{n}]"), name)?;
        }
        let surface = i.surface();
        if surface.fields().iter().all(|(_, v)| v.is_none()) {
            return Err((
                format!("interactions[{k}]"),
                "expected at least one contact-law field (friction, rolling_friction, work_of_adhesion, ...)".into(),
            ));
        }
        validate_surface(&surface, &format!("interactions[{k}]"))?;
    }
    for (k, w) in s.walls.iter().enumerate() {
        let f = |name: &str| format!("walls[{k}].{name}");
        match w {
            WallSpec::Plane {
                material,
                point,
                normal,
                remove_at,
                ..
            } => {
                known_material(s, f("material"), material)?;
                finite3(f("point"), *point)?;
                finite3(f("normal"), *normal)?;
                if normal.iter().map(|x| x * x).sum::<f64>() == 0.0 {
                    return Err((f("normal"), "expected a non-zero vector".into()));
                }
                if let Some(t) = remove_at {
                    if !(t.is_finite() && *t >= 0.0) {
                        return Err((f("remove_at"), format!("expected a time >= 0, got {t}")));
                    }
                }
            }
            WallSpec::Box {
                material, min, max, ..
            } => {
                known_material(s, f("material"), material)?;
                finite3(f("min"), *min)?;
                finite3(f("max"), *max)?;
                if (0..3).any(|d| max[d] <= min[d]) {
                    return Err((
                        f("max"),
                        format!(
                            "expected max > min in every coordinate, got min {min:?} max {max:?}"
                        ),
                    ));
                }
            }
            WallSpec::Cylinder {
                material,
                center,
                radius,
                bottom,
                top,
                ..
            } => {
                known_material(s, f("material"), material)?;
                finite2(f("center"), *center)?;
                positive(f("radius"), *radius)?;
                finite_opt(f("bottom"), *bottom)?;
                finite_opt(f("top"), *top)?;
                if let (Some(b), Some(t)) = (bottom, top) {
                    if t <= b {
                        return Err((f("top"), format!("expected top > bottom, got {t} <= {b}")));
                    }
                }
            }
            WallSpec::Pipe { material, .. } => {
                known_material(s, f("material"), material)?;
                if let Some(o) = w.as_obstacle(k) {
                    validate_obstacle(&o, &format!("walls[{k}]"))?;
                }
            }
            WallSpec::Cone {
                material,
                center,
                radius_bottom,
                radius_top,
                bottom,
                top,
                ..
            } => {
                known_material(s, f("material"), material)?;
                finite2(f("center"), *center)?;
                finite_opt(f("bottom"), Some(*bottom))?;
                finite_opt(f("top"), Some(*top))?;
                if !(*radius_bottom >= 0.0
                    && *radius_top >= 0.0
                    && radius_bottom.max(*radius_top) > 0.0)
                {
                    return Err((
                        f("radius_bottom"),
                        "expected radii >= 0, not both zero".into(),
                    ));
                }
                if top.partial_cmp(bottom) != Some(std::cmp::Ordering::Greater) {
                    return Err((
                        f("top"),
                        format!("expected top > bottom, got {top} <= {bottom}"),
                    ));
                }
            }
        }
    }
    for (k, p) in s.spheres.iter().enumerate() {
        let f = |name: &str| format!("spheres[{k}].{name}");
        known_material(s, f("material"), &p.material)?;
        positive(f("radius"), p.radius)?;
        finite3(f("position"), p.position)?;
        finite3(f("velocity"), p.velocity)?;
        finite3(f("angular_velocity"), p.angular_velocity)?;
    }
    let material_names: Vec<String> = s.materials.iter().map(|m| m.name.clone()).collect();
    crate::clumps::validate(&s.clump_types, &s.clumps, &material_names)?;
    let has_clumps = !s.clumps.is_empty()
        || s.blocks.iter().any(|b| b.clump.is_some())
        || s.inflows.iter().any(|i| i.clump.is_some());
    if has_clumps
        && s.coupling
            .as_ref()
            .is_some_and(|c| c.boundary == BoundaryRuleName::DistancePenalty)
    {
        return Err((
            "coupling.boundary".into(),
            "the distance penalty is not built for clumps yet: expected boundary = \"face_centre\" in a scene with clumps".into(),
        ));
    }
    for (k, b) in s.blocks.iter().enumerate() {
        let f = |name: &str| format!("blocks[{k}].{name}");
        let radius = match (&b.clump, &b.material, b.radius) {
            (Some(c), None, None) => {
                crate::clumps::type_index(&s.clump_types, c).map_err(|m| (f("clump"), m))?;
                None
            }
            (Some(_), _, _) => {
                let field = if b.material.is_some() {
                    "material"
                } else {
                    "radius"
                };
                return Err((
                    f(field),
                    "expected no material or radius in a block of clumps (its clump type gives them)".into(),
                ));
            }
            (None, Some(material), Some(radius)) => {
                known_material(s, f("material"), material)?;
                positive(f("radius"), radius)?;
                Some(radius)
            }
            (None, None, _) => {
                return Err((
                    f("material"),
                    "expected the spheres' `material` and `radius`, or a `clump` type".into(),
                ))
            }
            (None, Some(_), None) => {
                return Err((f("radius"), "expected the spheres' radius".into()))
            }
        };
        finite3(f("min"), b.min)?;
        finite3(f("max"), b.max)?;
        if (0..3).any(|d| b.max[d] < b.min[d]) {
            return Err((f("max"), "expected max >= min in every coordinate".into()));
        }
        if let (Some(a), Some(radius)) = (b.spacing, radius) {
            if a.partial_cmp(&(2.0 * radius))
                .is_none_or(|o| o == std::cmp::Ordering::Less)
            {
                return Err((
                    f("spacing"),
                    format!("expected a spacing >= 2 radius = {}, got {a}", 2.0 * radius),
                ));
            }
        }
        if let Some(a) = b.spacing {
            positive(f("spacing"), a)?;
        }
        finite3(f("velocity"), b.velocity)?;
        if !(0.0..=1.0).contains(&b.jitter) {
            return Err((
                f("jitter"),
                format!("expected 0 <= jitter <= 1, got {}", b.jitter),
            ));
        }
    }
    for (k, l) in s.lammps.iter().enumerate() {
        known_material(s, format!("lammps[{k}].material"), &l.material)?;
    }
    for (k, sink) in s.sinks.iter().enumerate() {
        let f = |name: &str| format!("sinks[{k}].{name}");
        finite3(f("point"), sink.point)?;
        finite3(f("normal"), sink.normal)?;
        if sink.normal.iter().map(|x| x * x).sum::<f64>() == 0.0 {
            return Err((f("normal"), "expected a non-zero vector".into()));
        }
        if let Some(r) = sink.radius {
            positive(f("radius"), r)?;
        }
    }
    for (k, i) in s.inflows.iter().enumerate() {
        let f = |name: &str| format!("inflows[{k}].{name}");
        match (&i.clump, &i.material) {
            (Some(c), None) => {
                crate::clumps::type_index(&s.clump_types, c).map_err(|m| (f("clump"), m))?;
                if !(i.radii.is_empty() && i.fractions.is_empty()) {
                    return Err((
                        f("radii"),
                        "expected no radii or fractions in an inflow of clumps (its clump type gives them)".into(),
                    ));
                }
            }
            (Some(_), Some(_)) => {
                return Err((
                    f("material"),
                    "expected no material in an inflow of clumps (its clump type gives it)".into(),
                ))
            }
            (None, Some(material)) => known_material(s, f("material"), material)?,
            (None, None) => {
                return Err((
                    f("material"),
                    "expected the spheres' `material` (with `radii` and `fractions`), or a `clump` type".into(),
                ))
            }
        }
        positive(f("rate"), i.rate)?;
        if let Some(v) = i.interval {
            positive(f("interval"), v)?;
        }
        if !(i.start.is_finite() && i.start >= 0.0) {
            return Err((f("start"), format!("expected a time >= 0, got {}", i.start)));
        }
        if let Some(stop) = i.stop {
            if !(stop.is_finite() && stop >= i.start) {
                return Err((
                    f("stop"),
                    format!("expected a time >= start = {}, got {stop}", i.start),
                ));
            }
        }
        finite3(f("velocity"), i.velocity)?;
        if !(i.velocity_jitter.is_finite() && i.velocity_jitter >= 0.0) {
            return Err((
                f("velocity_jitter"),
                format!("expected a speed >= 0, got {}", i.velocity_jitter),
            ));
        }
        // A clump inflow takes its sizes from the clump type.
        if i.clump.is_none() {
            if i.radii.is_empty() || i.radii.len() != i.fractions.len() {
                return Err((
                    f("fractions"),
                    "expected one fraction per radius, and at least one radius".into(),
                ));
            }
            for (n, r) in i.radii.iter().enumerate() {
                positive(format!("inflows[{k}].radii[{n}]"), *r)?;
            }
            let sum: f64 = i.fractions.iter().sum();
            if i.fractions.iter().any(|x| *x < 0.0) || (sum - 1.0).abs() > 1e-9 {
                return Err((
                    f("fractions"),
                    format!("expected fractions >= 0 summing to 1, got sum {sum}"),
                ));
            }
        }
        match &i.region {
            RegionSpec::Box { min, max } => {
                finite3(f("region.min"), *min)?;
                finite3(f("region.max"), *max)?;
                if (0..3).any(|d| max[d] <= min[d]) {
                    return Err((
                        f("region.max"),
                        "expected max > min in every coordinate".into(),
                    ));
                }
            }
            RegionSpec::Cylinder {
                center,
                radius,
                bottom,
                top,
            } => {
                finite2(f("region.center"), *center)?;
                positive(f("region.radius"), *radius)?;
                let r_max = i.radii.iter().copied().fold(0.0, f64::max);
                if *radius <= r_max {
                    return Err((
                        f("region.radius"),
                        format!(
                            "expected a radius > the largest particle radius {r_max}, got {radius}"
                        ),
                    ));
                }
                finite_opt(f("region.bottom"), Some(*bottom))?;
                if top.partial_cmp(bottom) != Some(std::cmp::Ordering::Greater) {
                    return Err((f("region.top"), "expected top > bottom".into()));
                }
            }
        }
    }
    Ok(())
}
