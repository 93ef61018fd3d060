//! The rigid bodies of other shapes than the sphere in the coupling: every clump body
//! (`integrate/rigid_body.rs`) is one body for the fluid, its solid the shape of its type
//! ([`crate::contact::shapes::body_shape`], the union of its member spheres) seen through
//! the [`ParticleShape`] fluid indicator: its depth marks cells and faces, its surface
//! points carry the surface force.
//!
//! Each body is coupled through one row of the particle block, its owner: the row of its
//! first member. The markers of its cells are the owner's (`row + 1`), the faces inside
//! its solid are the owner's, with the body's rigid velocity `V + w x (x - X)` about its
//! centre `X`, and its hydrodynamic force and torque are computed once, for the whole
//! solid, and held on the owner row; the body's other members get none, so nothing is
//! counted twice where members overlap. The integrator sums the members' forces and their
//! moments about `X` (`rigid_body.rs`, `gather_loads`), so the owner row holds the torque
//! about its own centre `x_o`: `T_o = T_X - (x_o - X) x F` ([`Bodies::torque_about_owner`]).
//! Free spheres are not bodies here: they keep the coupling's sphere path.
use glam::{DQuat, DVec3};
use grainflow_components::{Clumps, Particles};

use crate::contact::shapes::{body_shape, ParticleShape};

/// One body of a non-spherical shape, as the coupling sees it in this fluid step.
pub struct Body {
    /// Its owner row (its first member's).
    pub owner: usize,
    /// Its shape (index into [`Bodies::shapes`]).
    pub kind: usize,
    /// Centre of mass `X`, orientation of the body frame (body to world), velocity `V`
    /// and angular velocity `w` (world frame).
    pub centre: [f64; 3],
    pub orientation: DQuat,
    pub velocity: [f64; 3],
    pub angular_velocity: [f64; 3],
}

/// The bodies of other shapes than the sphere, with the role of every particle row.
#[derive(Default)]
pub struct Bodies {
    /// The shape of every body type, in its body frame.
    pub shapes: Vec<Box<dyn ParticleShape + Send + Sync>>,
    /// Bounding radius of every body type about its centre.
    pub reach: Vec<f64>,
    pub list: Vec<Body>,
    /// Per row: `u32::MAX` for a free sphere, else the index in `list` of its body.
    pub body_of_row: Vec<u32>,
}

impl Bodies {
    /// The bodies of `clumps` (none without), their rows in `particles`.
    pub fn new(particles: &Particles, clumps: Option<&Clumps>) -> Self {
        let mut bodies = Bodies {
            body_of_row: vec![u32::MAX; particles.len()],
            ..Default::default()
        };
        let Some(clumps) = clumps else {
            return bodies;
        };
        assert!(
            !clumps.rows_stale,
            "the clump member rows are found before the coupling"
        );
        bodies.shapes = clumps.types.iter().map(body_shape).collect();
        bodies.reach = bodies.shapes.iter().map(|s| s.bounding_radius()).collect();
        for b in 0..clumps.len() {
            let rows = &clumps.member_row
                [clumps.member_start[b] as usize..clumps.member_start[b + 1] as usize];
            for &row in rows {
                bodies.body_of_row[row as usize] = b as u32;
            }
            bodies.list.push(Body {
                owner: rows[0] as usize,
                kind: clumps.kind[b] as usize,
                centre: clumps.position[b].to_array(),
                orientation: clumps.orientation[b],
                velocity: clumps.velocity[b].to_array(),
                angular_velocity: clumps.angular_velocity(b).to_array(),
            });
        }
        bodies
    }

    /// Whether row `i` belongs to a body of another shape (is not a free sphere).
    pub fn is_member(&self, i: usize) -> bool {
        self.body_of_row[i] != u32::MAX
    }

    /// The body that row `i` owns, if it is a body's owner row.
    pub fn owned_by(&self, i: usize) -> Option<&Body> {
        let b = *self.body_of_row.get(i)?;
        (b != u32::MAX)
            .then(|| &self.list[b as usize])
            .filter(|body| body.owner == i)
    }

    /// The depth below body `body`'s surface ([`ParticleShape::depth`]) of the point at
    /// world-frame arm `arm = x - X`: the shape's depth of `R^-1 arm`.
    pub fn depth(&self, body: &Body, arm: [f64; 3]) -> f64 {
        let p = body.orientation.inverse() * DVec3::from_array(arm);
        self.shapes[body.kind].depth(p)
    }

    /// Rigid-body velocity `V + w x r` of `body` at world-frame arm `r = x - X`.
    pub fn rigid_velocity(body: &Body, r: [f64; 3]) -> [f64; 3] {
        let v = DVec3::from_array(body.velocity)
            + DVec3::from_array(body.angular_velocity).cross(DVec3::from_array(r));
        v.to_array()
    }

    /// The torque `t` about body `body`'s centre of the force `f`, as a torque about its
    /// owner row's centre `x_o` (where the coupling holds it): `t - (x_o - X) x f`, so that
    /// the integrator's sum `(x_o - X) x f + t_o` is `t` again.
    pub fn torque_about_owner(
        body: &Body,
        particles: &Particles,
        f: [f64; 3],
        t: [f64; 3],
    ) -> [f64; 3] {
        let xo = DVec3::from_array([0, 1, 2].map(|d| particles.position[d][body.owner]));
        let lever = xo - DVec3::from_array(body.centre);
        (DVec3::from_array(t) - lever.cross(DVec3::from_array(f))).to_array()
    }
}
