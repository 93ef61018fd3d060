//! Outlets (`[[fluid.outlets]]`, docs/scene-format.md): a disc of a box side through which
//! the flow leaves at a prescribed normal speed, the rest of the side keeping its own
//! condition (the mouth of a suction pipe in a do-nothing top). The faces of the side
//! whose centres lie in the disc are held at a normal speed that gives the disc's flux,
//! `velocity` times `pi radius^2`, exactly: `velocity` times the ratio of the disc's area
//! to its faces' ([`grainflow_fluid::NavierStokes::hold_faces`]; the faces' staircase
//! covers the disc to a few per cent). The box needs an `outflow` side for the flow to
//! come from.
use grainflow_fluid::Grid;

use crate::scene::{other_directions, FluidOutlet};

/// The faces of `o`'s side whose centres lie within its radius of its centre, ascending.
pub fn outlet_faces(o: &FluidOutlet, grid: &Grid) -> Vec<u32> {
    let (d, side) = o.side.direction_and_side();
    let [s, t] = other_directions(d);
    let lay = grid.layout();
    let n = grid.n();
    let mut faces = Vec::new();
    for j in 0..n[t] {
        for i in 0..n[s] {
            let mut f = [0; 3];
            f[d] = side * n[d];
            f[s] = i;
            f[t] = j;
            let x = grid.face_centre(d, f);
            if (x[s] - o.center[0]).powi(2) + (x[t] - o.center[1]).powi(2) <= o.radius * o.radius {
                faces.push(lay.face(d, f) as u32);
            }
        }
    }
    faces.sort_unstable();
    faces
}

/// The velocity of the `faces` faces of `o` on `grid`: along the outward normal of its
/// side, `velocity` times the disc's area over the faces' (none: zero).
pub fn outlet_velocity(o: &FluidOutlet, grid: &Grid, faces: usize) -> [f64; 3] {
    let (d, side) = o.side.direction_and_side();
    let area = faces as f64 * grid.face_area(d);
    let speed = if faces == 0 {
        0.0
    } else {
        o.velocity * std::f64::consts::PI * o.radius * o.radius / area
    };
    let mut v = [0.0; 3];
    v[d] = if side == 1 { speed } else { -speed };
    v
}

/// The name of outlet `k`: its `name`, else `fluid.outlets[k]`.
pub fn outlet_name(o: &FluidOutlet, k: usize) -> String {
    o.name
        .clone()
        .unwrap_or_else(|| format!("fluid.outlets[{k}]"))
}
