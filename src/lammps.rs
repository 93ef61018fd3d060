//! Reader and writer of LAMMPS `atom_style sphere` data files (as written by LAMMPS'
//! `write_data`): `Atoms # sphere` lines `id type diameter density x y z [ix iy iz]` and
//! `Velocities` lines `id vx vy vz wx wy wz`. Lets users bring their LAMMPS/LIGGGHTS
//! packings over, and a prepared bed (`grainflow run --write-data`) be reused by a scene's
//! `[[lammps]]` source.
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use grainflow_components::{Materials, Particles};

/// One atom of a data file.
#[derive(Debug, Clone, PartialEq)]
pub struct LammpsAtom {
    pub id: u64,
    pub radius: f64,
    pub density: f64,
    pub position: [f64; 3],
    pub velocity: [f64; 3],
    pub angular_velocity: [f64; 3],
}

/// Read the atoms of `path`, sorted by LAMMPS id.
pub fn read_data(path: &Path) -> Result<Vec<LammpsAtom>, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let mut atoms: Vec<LammpsAtom> = Vec::new();
    let mut index: HashMap<u64, usize> = HashMap::new();
    let mut section = "";
    for (lineno, line) in text.lines().enumerate() {
        let body = line.split('#').next().unwrap_or("").trim();
        let head = line.trim();
        if head.starts_with("Atoms") {
            if !line.contains("sphere") && line.contains('#') {
                return Err(format!(
                    "line {}: expected `Atoms # sphere`, got `{head}`",
                    lineno + 1
                ));
            }
            section = "atoms";
            continue;
        }
        if head.starts_with("Velocities") {
            section = "velocities";
            continue;
        }
        if body.is_empty() {
            continue;
        }
        if body.chars().next().is_some_and(|c| c.is_ascii_alphabetic()) {
            section = "";
            continue;
        }
        let nums: Vec<&str> = body.split_whitespace().collect();
        let parse = |k: usize| -> Result<f64, String> {
            nums.get(k)
                .and_then(|s| s.parse::<f64>().ok())
                .ok_or_else(|| {
                    format!("line {}: expected a number in column {}", lineno + 1, k + 1)
                })
        };
        match section {
            "atoms" => {
                if nums.len() != 7 && nums.len() != 10 {
                    return Err(format!(
                        "line {}: expected `id type diameter density x y z [ix iy iz]`, got {} columns",
                        lineno + 1,
                        nums.len()
                    ));
                }
                let id = parse(0)? as u64;
                let diameter = parse(2)?;
                if diameter <= 0.0 {
                    return Err(format!(
                        "line {}: atom {id} has diameter {diameter}, expected > 0",
                        lineno + 1
                    ));
                }
                index.insert(id, atoms.len());
                atoms.push(LammpsAtom {
                    id,
                    radius: 0.5 * diameter,
                    density: parse(3)?,
                    position: [parse(4)?, parse(5)?, parse(6)?],
                    velocity: [0.0; 3],
                    angular_velocity: [0.0; 3],
                });
            }
            "velocities" => {
                let id = parse(0)? as u64;
                let k = *index
                    .get(&id)
                    .ok_or_else(|| format!("line {}: velocity of unknown atom {id}", lineno + 1))?;
                atoms[k].velocity = [parse(1)?, parse(2)?, parse(3)?];
                if nums.len() >= 7 {
                    atoms[k].angular_velocity = [parse(4)?, parse(5)?, parse(6)?];
                }
            }
            _ => {}
        }
    }
    if atoms.is_empty() {
        return Err(format!(
            "{}: no `Atoms # sphere` section with atoms",
            path.display()
        ));
    }
    atoms.sort_by_key(|a| a.id);
    Ok(atoms)
}

/// Write the particles as a data file: LAMMPS atom type = material index + 1, density of
/// the material, ids in ascending order (id + 1: LAMMPS ids start at 1), box = the
/// particles' bounding box grown by the largest radius. Numbers in `{:e}` (shortest
/// round-trip form): reading the file back gives the same positions and velocities bit
/// for bit.
pub fn write_data(path: &Path, particles: &Particles, materials: &Materials) -> Result<(), String> {
    let n = particles.len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by_key(|&i| particles.id[i]);
    let [x, y, z] = &particles.position;
    let r_max = particles.radius.iter().copied().fold(0.0, f64::max);
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for i in 0..n {
        for (d, c) in [x[i], y[i], z[i]].into_iter().enumerate() {
            lo[d] = lo[d].min(c - r_max);
            hi[d] = hi[d].max(c + r_max);
        }
    }
    if n == 0 {
        (lo, hi) = ([0.0; 3], [0.0; 3]);
    }
    let mut out = String::new();
    let _ = writeln!(out, "LAMMPS data file written by grainflow\n");
    let _ = writeln!(out, "{n} atoms");
    let _ = writeln!(out, "{} atom types\n", materials.list.len().max(1));
    for (d, axis) in ["x", "y", "z"].iter().enumerate() {
        let _ = writeln!(out, "{:e} {:e} {axis}lo {axis}hi", lo[d], hi[d]);
    }
    let _ = writeln!(out, "\nAtoms # sphere\n");
    for &i in &order {
        let m = particles.material[i] as usize;
        let _ = writeln!(
            out,
            "{} {} {:e} {:e} {:e} {:e} {:e}",
            particles.id[i] as u64 + 1,
            m + 1,
            2.0 * particles.radius[i],
            materials.list[m].density,
            x[i],
            y[i],
            z[i]
        );
    }
    let _ = writeln!(out, "\nVelocities\n");
    let [vx, vy, vz] = &particles.velocity;
    let [wx, wy, wz] = &particles.angular_velocity;
    for &i in &order {
        let _ = writeln!(
            out,
            "{} {:e} {:e} {:e} {:e} {:e} {:e}",
            particles.id[i] as u64 + 1,
            vx[i],
            vy[i],
            vz[i],
            wx[i],
            wy[i],
            wz[i]
        );
    }
    std::fs::write(path, out).map_err(|e| format!("cannot write {}: {e}", path.display()))
}
