//! Particle shapes: the extension point for particle geometry (as avian's `AnyCollider`,
//! or LIGGGHTS' multisphere). A shape supplies its bounding radius (the broad phase), the
//! spheres of its narrow phase (contact points, normals and overlaps against another
//! shape and against every wall type come from them, in the one contact pipeline of
//! `contact/`), its mass properties and its fluid indicator for the coupling
//! (`coupling/`): the inside test, the depth below the surface that marks cells and
//! faces, and the surface force points.
//!
//! Spheres are the particles of the contact pass themselves; any other shape becomes a
//! rigid body ([`rigid_type`]) whose member spheres move with it. Adding a shape is one
//! file with a [`ParticleShape`] and one row in [`SHAPES`].
use glam::{DMat3, DQuat, DVec3};
use grainflow_components::{ClumpMember, ClumpType, SphereRule};

pub mod clump;
pub mod sphere;

/// Volume, centre and inertia tensor (about the centre, for unit density) of a body.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassProperties {
    pub volume: f64,
    pub centre: DVec3,
    pub inertia: DMat3,
}

/// The geometry of one particle shape, in its body frame.
pub trait ParticleShape {
    /// Radius about the centre of mass of a sphere holding the shape.
    fn bounding_radius(&self) -> f64 {
        let c = self.mass_properties().centre;
        self.contact_spheres()
            .iter()
            .map(|m| (m.offset - c).length() + m.radius)
            .fold(0.0, f64::max)
    }
    /// The narrow phase: spheres in the body frame whose contacts are the shape's.
    fn contact_spheres(&self) -> Vec<ClumpMember>;
    /// Mass properties for unit density.
    fn mass_properties(&self) -> MassProperties;
    /// Fluid indicator: whether the point `p` (body frame) is inside the solid.
    fn contains(&self, p: DVec3) -> bool;
    /// Fluid indicator as a level set: the depth of `p` (body frame) below the surface,
    /// positive inside, zero on the surface and minus the distance to the solid outside;
    /// inside it may be a lower bound of the distance to the surface. The coupling marks
    /// a cell inner when its centre lies deeper than half a cell diagonal, boundary when
    /// it lies less than that outside, and gives a face inside several bodies to the one
    /// it lies deepest in (`coupling/markers.rs`).
    fn depth(&self, p: DVec3) -> f64;
    /// Surface force points of the quadrature `rule` on the unit sphere (directions
    /// `n_i`, weights `w_i` summing to 1), in the body frame: the shape's surface, and
    /// only it, covered by points with outward normals and area weights, so that
    /// `sum_i a_i t(x_i)` approximates the surface integral of a traction `t`
    /// (`coupling/surface_points.rs`).
    fn surface_points(&self, rule: &SphereRule) -> Vec<SurfacePoint>;
}

/// One surface force point of a shape, in its body frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// Position relative to the body's centre (the origin of the body frame).
    pub position: DVec3,
    /// Outward unit normal.
    pub normal: DVec3,
    /// The area the point stands for.
    pub area: f64,
}

/// The shape of a rigid-body type in its principal frame (origin at the centre of mass):
/// the union of its member spheres, what the coupling sees of a clump body.
pub fn body_shape(ty: &ClumpType) -> Box<dyn ParticleShape + Send + Sync> {
    Box::new(clump::Clump {
        members: ty.members.clone(),
    })
}

/// Makes a shape from its parameters (the member spheres: offsets and radii in the body
/// frame), or says what is wrong with them.
pub type MakeShape = fn(&[([f64; 3], f64)]) -> Result<Box<dyn ParticleShape>, String>;

/// One registered shape: the name a scene's `shape` field gives and how it is made.
pub struct ShapeEntry {
    pub name: &'static str,
    pub make: MakeShape,
}

/// The shapes a scene's rigid particle types may take.
pub const SHAPES: &[ShapeEntry] = &[ShapeEntry {
    name: "clump",
    make: clump::Clump::from_spheres,
}];

/// The rigid-body type of `shape` of material density `density`: members in the
/// principal frame, mass, principal moments, the scene frame relative to the principal
/// one and the centre of mass in the scene frame.
pub fn rigid_type(shape: &dyn ParticleShape, name: &str, material: u16, density: f64) -> ClumpType {
    let props = shape.mass_properties();
    let (moments, axes) = principal_axes(props.inertia);
    // axes' columns: the principal axes in the scene frame; p' = axes^T (p - c).
    let frame = DQuat::from_mat3(&axes.transpose()).normalize();
    let members = shape
        .contact_spheres()
        .into_iter()
        .map(|m| ClumpMember {
            offset: frame * (m.offset - props.centre),
            radius: m.radius,
        })
        .collect();
    ClumpType {
        name: name.to_string(),
        material,
        members,
        mass: density * props.volume,
        inertia: moments * density,
        frame,
        centre: props.centre,
    }
}

/// Eigenvalues and a right-handed matrix of unit eigenvectors (columns) of the symmetric
/// matrix `a`, by cyclic Jacobi rotations (Golub & Van Loan, Matrix Computations, 8.5),
/// in ascending order of the eigenvalues.
pub fn principal_axes(a: DMat3) -> (DVec3, DMat3) {
    let mut m = a.to_cols_array_2d();
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let scale = (0..3)
        .map(|i| m[i][i].abs())
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    for _sweep in 0..50 {
        let off = m[0][1].abs() + m[0][2].abs() + m[1][2].abs();
        if off <= 1e-15 * scale {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if m[p][q] == 0.0 {
                continue;
            }
            let theta = (m[q][q] - m[p][p]) / (2.0 * m[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // m <- J^T m J with the rotation J in the (p, q) plane; v <- v J.
            for row in &mut m {
                let (mkp, mkq) = (row[p], row[q]);
                row[p] = c * mkp - s * mkq;
                row[q] = s * mkp + c * mkq;
            }
            let (row_p, row_q) = (m[p], m[q]);
            for k in 0..3 {
                m[p][k] = c * row_p[k] - s * row_q[k];
                m[q][k] = s * row_p[k] + c * row_q[k];
            }
            for row in &mut v {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let mut order = [0, 1, 2];
    order.sort_by(|&i, &j| m[i][i].total_cmp(&m[j][j]));
    let values = DVec3::from_array(order.map(|i| m[i][i]));
    let column = |i: usize| DVec3::new(v[0][i], v[1][i], v[2][i]);
    let (e0, e1) = (column(order[0]), column(order[1]));
    // Right-handed: the third axis is the cross product of the first two.
    (values, DMat3::from_cols(e0, e1, e0.cross(e1)))
}
