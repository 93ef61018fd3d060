//! The memory a scene needs, estimated from the scene before anything is allocated, against
//! the memory the machine has available: a scene that cannot fit is refused as bad input
//! (exit 2, naming the source and the estimate) instead of aborting in an allocation after
//! seconds of work.
//!
//! The estimate is a lower bound: the smallest state per particle and per fluid degree of
//! freedom measured on the benchmark scenes, so that a scene is refused only when it
//! cannot fit whatever its contact models.
use std::path::Path;

use crate::fluid::coarse_cells;
use crate::scene::{Scene, SceneError};

/// Bytes per particle of the smallest per-particle state: the frictionless hopper's
/// 285 bytes of blocks and neighbour list (docs/performance.md, `state_bytes_per_particle`;
/// friction and rolling raise it to 637, the peak of a run to about 1,600).
pub const PARTICLE_BYTES: f64 = 285.0;

/// Bytes per fluid degree of freedom (a velocity component of a face or a cell pressure):
/// the peak of the drag case at level 4, 5.4 GB for 26.7 M DOFs (docs/coupling.md), less
/// than the fluid alone on the sedimentation box (264 B at level 4,
/// docs/fluid-benchmarks.md).
pub const FLUID_DOF_BYTES: f64 = 200.0;

/// One part of the scene that holds memory: its scene field, how many particles or
/// degrees of freedom, and the bytes they need at least.
#[derive(Debug, Clone, PartialEq)]
pub struct MemoryItem {
    pub field: String,
    pub count: f64,
    pub unit: &'static str,
    pub bytes: f64,
}

/// The parts of `scene` that hold memory in proportion to its size: its `[[spheres]]`, every `[[blocks]]`
/// (its lattice sites, at most `count`), every inflow (its `total`) and the fluid grid (its
/// degrees of freedom on all multigrid levels); LAMMPS files are not counted (they are
/// read whole before their particles are placed). Counted in floating point, so a scene of
/// any size is estimated without overflow.
pub fn scene_memory(scene: &Scene) -> Vec<MemoryItem> {
    let particles = |field: String, count: f64| MemoryItem {
        field,
        count,
        unit: "particles",
        bytes: count * PARTICLE_BYTES,
    };
    let mut items = Vec::new();
    if !scene.spheres.is_empty() {
        items.push(particles("spheres".into(), scene.spheres.len() as f64));
    }
    for (k, c) in scene.clumps.iter().enumerate() {
        let (_, members) = crate::clumps::reach_and_members(&scene.clump_types, &c.kind);
        items.push(particles(format!("clumps[{k}]"), members as f64));
    }
    for (k, b) in scene.blocks.iter().enumerate() {
        let (reach, per_site) = match &b.clump {
            Some(c) => crate::clumps::reach_and_members(&scene.clump_types, c),
            None => (b.radius.expect("validated block"), 1),
        };
        let a = b.spacing.unwrap_or(2.1 * reach);
        let sites: f64 = (0..3)
            .map(|d| ((b.max[d] - b.min[d]) / a).floor().max(0.0) + 1.0)
            .product();
        let sites = b.count.map_or(sites, |c| sites.min(c as f64));
        items.push(particles(format!("blocks[{k}]"), sites * per_site as f64));
    }
    for (k, i) in scene.inflows.iter().enumerate() {
        items.push(particles(format!("inflows[{k}].total"), i.total as f64));
    }
    if let Some(f) = scene.fluid.as_ref().filter(|f| f.has_grid()) {
        let dofs = fluid_dofs(coarse_cells(f), f.level);
        items.push(MemoryItem {
            field: "fluid.level".into(),
            count: dofs,
            unit: "degrees of freedom",
            bytes: dofs * FLUID_DOF_BYTES,
        });
    }
    items
}

/// Degrees of freedom of the Q1~/Q0 grid of `coarse` cells at `level`, summed over the
/// multigrid levels 1..=level: three velocity components per face and one pressure per
/// cell.
pub fn fluid_dofs(coarse: [usize; 3], level: u32) -> f64 {
    (1..=level)
        .map(|l| {
            let n = coarse.map(|c| c as f64 * 2f64.powi(l as i32 - 1));
            let cells = n[0] * n[1] * n[2];
            let faces: f64 = (0..3).map(|d| cells / n[d] * (n[d] + 1.0)).sum();
            3.0 * faces + cells
        })
        .sum()
}

/// Memory available to this process, bytes: `MemAvailable` of `/proc/meminfo`, lowered to
/// what the cgroup's `memory.max` leaves when that is smaller; `None` where neither can be
/// read (the check is then skipped).
pub fn available_memory() -> Option<f64> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok();
    let host = meminfo.as_deref().and_then(|text| {
        text.lines()
            .find_map(|l| l.strip_prefix("MemAvailable:"))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
            .map(|kb| kb * 1024.0)
    });
    let read = |name: &str| {
        std::fs::read_to_string(Path::new("/sys/fs/cgroup").join(name))
            .ok()
            .and_then(|s| s.trim().parse::<f64>().ok())
    };
    let cgroup =
        read("memory.max").map(|max| (max - read("memory.current").unwrap_or(0.0)).max(0.0));
    match (host, cgroup) {
        (Some(h), Some(c)) => Some(h.min(c)),
        (h, c) => h.or(c),
    }
}

/// Refuse a scene whose parts need more than `available` bytes together: the error names
/// the largest part, its count and bytes, and the total against what is available.
pub fn check_fits(items: &[MemoryItem], available: f64, path: &Path) -> Result<(), SceneError> {
    let total = total_bytes(items);
    if total <= available {
        return Ok(());
    }
    let largest = items
        .iter()
        .max_by(|a, b| a.bytes.total_cmp(&b.bytes))
        .expect("a total above zero has an item");
    Err(SceneError {
        file: path.to_path_buf(),
        field: largest.field.clone(),
        message: format!(
            "{:.3e} {} need at least {} ({} for the whole scene), but this machine has {} available; \
             expected a smaller scene (fewer particles or a coarser fluid level)",
            largest.count,
            largest.unit,
            gigabytes(largest.bytes),
            gigabytes(total),
            gigabytes(available)
        ),
    })
}

/// The bytes of all `items` (zero for none).
pub fn total_bytes(items: &[MemoryItem]) -> f64 {
    items.iter().fold(0.0, |s, i| s + i.bytes)
}

/// Bytes as megabytes below 1 GB ("3.2 MB"), gigabytes from there ("12.3 GB"), and
/// "2.85e4 GB" from 10^4 GB on.
pub fn gigabytes(bytes: f64) -> String {
    let gb = bytes / 1e9;
    if gb >= 1e4 {
        format!("{gb:.2e} GB")
    } else if gb >= 1.0 {
        format!("{gb:.1} GB")
    } else {
        format!("{:.1} MB", bytes / 1e6)
    }
}
