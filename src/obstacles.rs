//! Fixed solid bodies in the flow (`[[fluid.obstacles]]`, docs/scene-format.md): a pipe
//! (a cylindrical shell open at both ends) or a box. The flow sees them through the same
//! face-centre rule as the particles: every face whose centre lies in the solid is held
//! at rest for the whole run ([`grainflow_fluid::NavierStokes::hold_faces`]), so no flow
//! crosses a wall at least one cell thick (a chain of cells across it passes a face
//! every cell, and one of those lies in the wall). The particles meet obstacles only
//! through DEM walls (`[[walls]]`), which the scene gives separately.
use grainflow_fluid::Grid;

use crate::scene::FluidObstacle;

/// Whether the point `x` lies in the solid of `o` (its boundary included).
pub fn obstacle_contains(o: &FluidObstacle, x: [f64; 3]) -> bool {
    match *o {
        FluidObstacle::Pipe {
            axis,
            center,
            inner_radius,
            outer_radius,
            bottom,
            top,
            ..
        } => {
            let a = axis.index();
            let [s, t] = axis.others();
            let r2 = (x[s] - center[0]).powi(2) + (x[t] - center[1]).powi(2);
            (bottom..=top).contains(&x[a])
                && r2 >= inner_radius * inner_radius
                && r2 <= outer_radius * outer_radius
        }
        FluidObstacle::Box { min, max, .. } => (0..3).all(|d| (min[d]..=max[d]).contains(&x[d])),
    }
}

/// The faces of `grid` whose centres lie in any of `obstacles`, ascending.
pub fn obstacle_faces(obstacles: &[FluidObstacle], grid: &Grid) -> Vec<u32> {
    if obstacles.is_empty() {
        return Vec::new();
    }
    let lay = grid.layout();
    (0..lay.num_faces())
        .filter(|&idx| {
            let (a, f) = lay.face_of(idx);
            let x = grid.face_centre(a, f);
            obstacles.iter().any(|o| obstacle_contains(o, x))
        })
        .map(|idx| idx as u32)
        .collect()
}

/// The thickness of the thinnest solid wall of `o` (pipe: outer minus inner radius; box:
/// its shortest edge).
pub fn wall_thickness(o: &FluidObstacle) -> f64 {
    match *o {
        FluidObstacle::Pipe {
            inner_radius,
            outer_radius,
            ..
        } => outer_radius - inner_radius,
        FluidObstacle::Box { min, max, .. } => (0..3)
            .map(|d| max[d] - min[d])
            .fold(f64::INFINITY, f64::min),
    }
}

/// The name of obstacle `k`: its `name`, else `fluid.obstacles[k]`.
pub fn obstacle_name(o: &FluidObstacle, k: usize) -> String {
    match o {
        FluidObstacle::Pipe { name, .. } | FluidObstacle::Box { name, .. } => name
            .clone()
            .unwrap_or_else(|| format!("fluid.obstacles[{k}]")),
    }
}
