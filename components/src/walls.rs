use bevy_ecs::prelude::Resource;

/// Geometry of a wall. Particles live on the side given by the normal (plane) or inside
/// the surface of revolution (cylinder, cone).
#[derive(Debug, Clone, PartialEq)]
pub enum WallShape {
    /// Plane through `point` with unit `normal` pointing into the particle side.
    Plane { point: [f64; 3], normal: [f64; 3] },
    /// Lateral surface of revolution about the axis through `origin` along the unit vector
    /// `axis`, whose meridian is the segment from (radius `r0`, axial height `h0`) to
    /// (`r1`, `h1`), heights measured along `axis` from `origin`. A cylinder has r0 = r1,
    /// a cone or frustum r0 != r1. Infinite extent is given by large |h|. With a
    /// `thickness` > 0 the wall is the solid shell within thickness/2 of that surface, its
    /// ends rounded (a pipe: both faces and the rims touch particles); 0 is the surface.
    Revolution {
        origin: [f64; 3],
        axis: [f64; 3],
        r0: f64,
        h0: f64,
        r1: f64,
        h1: f64,
        thickness: f64,
    },
}

/// A static wall with its material; `remove_at` takes it away at that simulated time
/// (e.g. the plate closing a hopper outlet).
#[derive(Debug, Clone, PartialEq)]
pub struct Wall {
    pub name: String,
    pub shape: WallShape,
    pub material: u16,
    pub remove_at: Option<f64>,
    pub active: bool,
}

/// All walls of the scene, in scene order.
#[derive(Resource, Debug, Clone, Default)]
pub struct Walls {
    pub list: Vec<Wall>,
}
