//! Clumps in a scene: the `[[clump_types]]` (member spheres in the body frame, a shape of
//! `grainflow_systems::contact::shapes::SHAPES`), the `[[clumps]]` placed one by one and
//! the clumps of `[[blocks]]` with a `clump` type; their checks and the rigid bodies they
//! make.
use glam::{DQuat, DVec3};
use grainflow_components::{BodyState, ClumpType, Material};
use grainflow_systems::contact::shapes::{rigid_type, SHAPES};
use serde::Deserialize;

/// One member sphere of a clump type: offset from the body origin, radius.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MemberSpec {
    pub offset: [f64; 3],
    pub radius: f64,
}

/// A rigid particle type made of member spheres.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClumpTypeSpec {
    pub name: String,
    pub material: String,
    /// A registered shape (default `clump`).
    #[serde(default = "default_shape")]
    pub shape: String,
    pub spheres: Vec<MemberSpec>,
}

fn default_shape() -> String {
    "clump".into()
}

/// One clump placed: its type, the position of its centre of mass, the orientation of
/// its body frame (quaternion w, x, y, z; default: as the type gives the members, or
/// `random_orientation`), velocity and angular velocity.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClumpSpec {
    #[serde(rename = "type")]
    pub kind: String,
    pub position: [f64; 3],
    #[serde(default)]
    pub orientation: Option<[f64; 4]>,
    #[serde(default)]
    pub random_orientation: bool,
    #[serde(default)]
    pub velocity: [f64; 3],
    #[serde(default)]
    pub angular_velocity: [f64; 3],
}

type Invalid = (String, String);

/// The clump types' and clumps' fields: known materials and types, a shape that accepts
/// the members, finite values, unit-normalisable orientations.
pub fn validate(
    types: &[ClumpTypeSpec],
    clumps: &[ClumpSpec],
    materials: &[String],
) -> Result<(), Invalid> {
    for (k, t) in types.iter().enumerate() {
        let f = |name: &str| format!("clump_types[{k}].{name}");
        if !materials.contains(&t.material) {
            return Err((
                f("material"),
                format!(
                    "unknown material `{}`; the scene defines {materials:?}",
                    t.material
                ),
            ));
        }
        if types[..k].iter().any(|o| o.name == t.name) {
            return Err((
                f("name"),
                format!("clump type `{}` is defined twice", t.name),
            ));
        }
        shape_of(t).map_err(|m| {
            (
                f(if t.spheres.is_empty() {
                    "spheres"
                } else {
                    "shape"
                }),
                m,
            )
        })?;
    }
    for (k, c) in clumps.iter().enumerate() {
        let f = |name: &str| format!("clumps[{k}].{name}");
        type_index(types, &c.kind).map_err(|m| (f("type"), m))?;
        for (name, v) in [
            ("position", c.position),
            ("velocity", c.velocity),
            ("angular_velocity", c.angular_velocity),
        ] {
            if !v.iter().all(|x| x.is_finite()) {
                return Err((f(name), format!("expected three finite numbers, got {v:?}")));
            }
        }
        if let Some(q) = c.orientation {
            let norm = q.iter().map(|x| x * x).sum::<f64>().sqrt();
            if !(norm.is_finite() && norm > 0.0) {
                return Err((
                    f("orientation"),
                    format!(
                        "expected a quaternion [w, x, y, z] of finite non-zero length, got {q:?}"
                    ),
                ));
            }
            if c.random_orientation {
                return Err((
                    f("random_orientation"),
                    "expected either `orientation` or `random_orientation`, not both".into(),
                ));
            }
        }
    }
    Ok(())
}

/// The index of the clump type `name`.
pub fn type_index(types: &[ClumpTypeSpec], name: &str) -> Result<usize, String> {
    types.iter().position(|t| t.name == name).ok_or_else(|| {
        let names: Vec<&str> = types.iter().map(|t| t.name.as_str()).collect();
        format!("unknown clump type `{name}`; the scene defines {names:?}")
    })
}

/// The shape of a clump type, through the shape registry.
fn shape_of(
    t: &ClumpTypeSpec,
) -> Result<Box<dyn grainflow_systems::contact::shapes::ParticleShape>, String> {
    let entry = SHAPES.iter().find(|s| s.name == t.shape).ok_or_else(|| {
        let names: Vec<&str> = SHAPES.iter().map(|s| s.name).collect();
        format!("unknown shape `{}`; expected one of {names:?}", t.shape)
    })?;
    let spheres: Vec<([f64; 3], f64)> = t.spheres.iter().map(|m| (m.offset, m.radius)).collect();
    (entry.make)(&spheres)
}

/// Bounding radius about the centre of mass and member count of the clump type `name`
/// (validated).
pub fn reach_and_members(types: &[ClumpTypeSpec], name: &str) -> (f64, usize) {
    let t = &types[type_index(types, name).expect("validated clump type")];
    let shape = shape_of(t).expect("validated clump type");
    (shape.bounding_radius(), t.spheres.len())
}

/// The rigid types of the scene's clump types (validated), with the materials' densities.
pub fn clump_types(
    types: &[ClumpTypeSpec],
    materials: &[Material],
    material_index: &dyn Fn(&str) -> u16,
) -> Vec<ClumpType> {
    types
        .iter()
        .map(|t| {
            let m = material_index(&t.material);
            let shape = shape_of(t).expect("validated clump type");
            rigid_type(&*shape, &t.name, m, materials[m as usize].density)
        })
        .collect()
}

/// The body state of a clump spec (its orientation chosen by the caller).
pub fn spec_state(c: &ClumpSpec) -> BodyState {
    BodyState {
        position: DVec3::from_array(c.position),
        velocity: DVec3::from_array(c.velocity),
        orientation: DQuat::IDENTITY,
        angular_velocity: DVec3::from_array(c.angular_velocity),
    }
}

/// The scene-frame orientation of a clump spec.
pub fn spec_orientation(c: &ClumpSpec, rng: &mut u64) -> DQuat {
    match c.orientation {
        Some([w, x, y, z]) => DQuat::from_xyzw(x, y, z, w).normalize(),
        None if c.random_orientation => {
            grainflow_systems::integrate::rigid_body::random_rotation(rng)
        }
        None => DQuat::IDENTITY,
    }
}
