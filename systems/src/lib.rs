//! grainflow systems: plain functions over the ECS data of `grainflow-components`.
//!
//! `schedule.rs` declares the order of one time step (one fluid step, the coupling, then
//! n_s DEM substeps) and the table of systems; reading it tells the whole step. Each
//! physical model lives in its own file; the fluid-particle coupling in `coupling/`.
//!
//! In the integrators the largest |x| of a loop is kept as `x.abs().to_bits()` under an
//! integer `max`: for non-negative floats the bit patterns order like the numbers, and the
//! integer reduction vectorises where `f64::max` (with its NaN rule) would not.

pub mod contact;
pub mod coupling;
pub mod energy;
pub mod fluid;
pub mod inflow;
pub mod integrate;
pub mod monitor;
pub mod neighbour;
pub mod real;
pub mod rows;
pub mod schedule;
pub mod sinks;
pub mod team;

pub use schedule::{build_schedule, CoupledStep, Phase, StepSet, SystemEntry, REGISTRY};

/// Rows per parallel work item. Fixed, so the work split never depends on the thread count
/// (the results do not either: every particle sums its own forces in list order).
pub const CHUNK: usize = 2048;

/// One coordinate of the body acceleration g (1 - rho_f/rho): a single value when all
/// materials share it (the loop then needs no per-particle lookup), else per material.
pub enum BodyColumn {
    Uniform(f64),
    PerMaterial(Vec<f64>),
}

pub fn body_acceleration_column(
    body: &grainflow_components::BodyAcceleration,
    d: usize,
) -> BodyColumn {
    let g: Vec<f64> = body.per_material.iter().map(|g| g[d]).collect();
    if g.iter().all(|&x| x == g[0]) {
        BodyColumn::Uniform(g[0])
    } else {
        BodyColumn::PerMaterial(g)
    }
}

/// The work items of an integrator pass that does all three coordinates at once: per chunk
/// of [`CHUNK`] rows, that chunk of each of the `K` state columns (x, y and z), of the
/// forces, of the inverse masses and of the materials.
#[allow(clippy::type_complexity)]
pub(crate) fn chunks_of_three_coordinates<'a, const K: usize>(
    state: [&'a mut [Vec<f64>; 3]; K],
    force: &'a [Vec<f64>; 3],
    inv_mass: &'a [f64],
    material: &'a [u16],
) -> Vec<(
    [[&'a mut [f64]; 3]; K],
    [&'a [f64]; 3],
    &'a [f64],
    &'a [u16],
)> {
    let mut state = state.map(|[x, y, z]| {
        x.chunks_mut(CHUNK)
            .zip(y.chunks_mut(CHUNK))
            .zip(z.chunks_mut(CHUNK))
            .map(|((x, y), z)| [x, y, z])
    });
    let [fx, fy, fz] = force;
    let mut f = fx.chunks(CHUNK).zip(fy.chunks(CHUNK)).zip(fz.chunks(CHUNK));
    inv_mass
        .chunks(CHUNK)
        .zip(material.chunks(CHUNK))
        .map(|(im, m)| {
            let ((fx, fy), fz) = f.next().expect("a force chunk per chunk");
            let rows = state
                .each_mut()
                .map(|cols| cols.next().expect("a chunk of every column"));
            (rows, [fx, fy, fz], im, m)
        })
        .collect()
}

/// The particle columns of a contact pass, each cut to the particle count `n`: a lane's
/// index checked once against `n` needs no bounds check in the gathers that follow.
#[derive(Clone, Copy)]
pub(crate) struct Rows<'a> {
    pub n: usize,
    pub position: [&'a [f64]; 3],
    pub velocity: [&'a [f64]; 3],
    pub angular_velocity: [&'a [f64]; 3],
    pub radius: &'a [f64],
    pub inv_mass: &'a [f64],
    pub material: &'a [u16],
    pub id: &'a [u32],
}

impl<'a> Rows<'a> {
    #[inline(always)]
    pub fn of(p: &'a grainflow_components::Particles) -> Self {
        let n = p.len();
        let cut = |c: &'a [Vec<f64>; 3]| [&c[0][..n], &c[1][..n], &c[2][..n]];
        Self {
            n,
            position: cut(&p.position),
            velocity: cut(&p.velocity),
            angular_velocity: cut(&p.angular_velocity),
            radius: &p.radius[..n],
            inv_mass: &p.inv_mass[..n],
            material: &p.material[..n],
            id: &p.id[..n],
        }
    }

    /// The same columns cut to `n` again: call it in the function that gathers, so that
    /// the compiler knows every column's length there.
    #[inline(always)]
    pub fn cut(&self) -> Self {
        let n = self.n;
        let cut = |c: [&'a [f64]; 3]| [&c[0][..n], &c[1][..n], &c[2][..n]];
        Self {
            n,
            position: cut(self.position),
            velocity: cut(self.velocity),
            angular_velocity: cut(self.angular_velocity),
            radius: &self.radius[..n],
            inv_mass: &self.inv_mass[..n],
            material: &self.material[..n],
            id: &self.id[..n],
        }
    }
}

/// Split `values` (`width` values per entry of a compressed-row list whose row `i` holds
/// entries `start[i]..start[i+1]`) into the ranges of consecutive chunks of `CHUNK` rows,
/// for `n` rows.
pub fn row_chunks<'a, T>(
    values: &'a mut [T],
    start: &[u32],
    n: usize,
    width: usize,
) -> Vec<&'a mut [T]> {
    let lengths = (0..n.div_ceil(CHUNK))
        .map(|c| (start[((c + 1) * CHUNK).min(n)] - start[c * CHUNK]) as usize * width);
    neighbour::compressed_rows::split_lengths(values, lengths)
}
