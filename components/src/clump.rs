use bevy_ecs::prelude::Resource;
use glam::{DQuat, DVec3};

/// One member sphere of a clump type, in the principal body frame (origin at the centre
/// of mass, axes along the principal axes of inertia).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClumpMember {
    pub offset: DVec3,
    pub radius: f64,
}

/// A clump type: rigid union of member spheres, with the mass properties of the union.
#[derive(Debug, Clone, PartialEq)]
pub struct ClumpType {
    pub name: String,
    pub material: u16,
    pub members: Vec<ClumpMember>,
    pub mass: f64,
    /// Principal moments of inertia about the centre of mass, kg m^2.
    pub inertia: DVec3,
    /// The body frame as the scene gave it, relative to the principal frame: a point p of
    /// the scene's frame is at `frame * (p - centre)` in the principal frame. Orientations
    /// in the scene and in the output are those of the scene's frame.
    pub frame: DQuat,
    /// Centre of mass in the scene's body frame.
    pub centre: DVec3,
}

impl ClumpType {
    /// Radius about the centre of mass of the sphere holding every member.
    pub fn bounding_radius(&self) -> f64 {
        self.members
            .iter()
            .map(|m| m.offset.length() + m.radius)
            .fold(0.0, f64::max)
    }
}

/// The integrator's extra values of one clump body: Gear keeps the derivatives of the
/// centre's acceleration and of the torque (a, da/dt, d2a/dt2 and T, dT/dt, d2T/dt2, as
/// the last corrector left them) and the orientation and angular momentum at the start of
/// the step; velocity Verlet the half-step velocity and angular momentum.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct BodyAux {
    pub acc: [DVec3; 3],
    pub torque_rate: [DVec3; 3],
    pub start_orientation: DQuat,
    pub start_momentum: DVec3,
    pub half_velocity: DVec3,
    pub half_momentum: DVec3,
}

/// The rigid clump bodies of a scene, present only when it has clumps. Each body's members
/// are rows of [`crate::Particles`] (spheres for the contact pass, the walls and the
/// output) found by their stable particle ids; the bodies move them rigidly.
#[derive(Resource, Debug, Clone, Default)]
pub struct Clumps {
    pub types: Vec<ClumpType>,
    /// Per body: its type, centre of mass, velocity, orientation of the principal frame
    /// (body to world), angular momentum about the centre (world frame), the contact
    /// force and torque (about the centre) of the last step, and the integrator values.
    pub kind: Vec<u16>,
    pub position: Vec<DVec3>,
    pub velocity: Vec<DVec3>,
    pub orientation: Vec<DQuat>,
    pub angular_momentum: Vec<DVec3>,
    pub force: Vec<DVec3>,
    pub torque: Vec<DVec3>,
    pub aux: Vec<BodyAux>,
    /// Body `b`'s members are the particle ids `first_member[b] ..` (one per member of its
    /// type, in type order).
    pub first_member: Vec<u32>,
    /// The body of every particle id (`u32::MAX`: a free sphere).
    pub body_of_id: Vec<u32>,
    /// Row in [`crate::Particles`] of every member, body by body: body `b`'s members are
    /// `member_row[member_start[b] .. member_start[b + 1]]` (`member_start` has one entry
    /// more than there are bodies).
    pub member_row: Vec<u32>,
    pub member_start: Vec<u32>,
    /// Whether `member_row` must be found again (after a re-sort or an insertion).
    pub rows_stale: bool,
}

impl Clumps {
    pub fn len(&self) -> usize {
        self.kind.len()
    }
    pub fn is_empty(&self) -> bool {
        self.kind.is_empty()
    }
    /// The members of body `b`: (index into `member_row`, member of its type).
    pub fn members(&self, b: usize) -> impl Iterator<Item = (usize, &ClumpMember)> {
        let start = self.member_start[b] as usize;
        self.types[self.kind[b] as usize]
            .members
            .iter()
            .enumerate()
            .map(move |(k, m)| (start + k, m))
    }
    /// Angular velocity (world frame) of body `b`: w = R I^-1 R^T L.
    pub fn angular_velocity(&self, b: usize) -> DVec3 {
        let ty = &self.types[self.kind[b] as usize];
        angular_velocity(self.orientation[b], ty.inertia, self.angular_momentum[b])
    }
    /// Append a body of type `kind` (members get the ids `first_member ..`).
    pub fn push(&mut self, kind: u16, state: BodyState, first_member: u32) {
        let ty = &self.types[kind as usize];
        let n = ty.members.len() as u32;
        let body = self.kind.len() as u32;
        self.kind.push(kind);
        self.position.push(state.position);
        self.velocity.push(state.velocity);
        self.orientation.push(state.orientation);
        let w_body = state.orientation.inverse() * state.angular_velocity;
        self.angular_momentum
            .push(state.orientation * (ty.inertia * w_body));
        self.force.push(DVec3::ZERO);
        self.torque.push(DVec3::ZERO);
        self.aux.push(BodyAux {
            start_orientation: state.orientation,
            ..Default::default()
        });
        self.first_member.push(first_member);
        let end = (first_member + n) as usize;
        if self.body_of_id.len() < end {
            self.body_of_id.resize(end, u32::MAX);
        }
        for id in first_member..first_member + n {
            self.body_of_id[id as usize] = body;
        }
        if self.member_start.is_empty() {
            self.member_start.push(0);
        }
        self.member_row
            .extend(std::iter::repeat_n(u32::MAX, n as usize));
        self.member_start.push(self.member_row.len() as u32);
        self.rows_stale = true;
    }
    /// Remove the bodies `gone` (ascending body indices): the others keep their order and
    /// get the body indices `0 ..` in it; their entries of `body_of_id` and their slices
    /// of `member_row` follow, the ids of the removed bodies' members map to no body. The
    /// rows of the removed members are the caller's to drop.
    pub fn remove_bodies(&mut self, gone: &[u32]) {
        if gone.is_empty() {
            return;
        }
        let n = self.len();
        let mut keep = vec![true; n];
        for &b in gone {
            keep[b as usize] = false;
        }
        let mut member_row = Vec::with_capacity(self.member_row.len());
        let mut member_start = Vec::with_capacity(n + 1 - gone.len());
        member_start.push(0);
        let mut to = 0;
        for (b, &kept) in keep.iter().enumerate() {
            let first = self.first_member[b] as usize;
            let count = self.types[self.kind[b] as usize].members.len();
            if !kept {
                self.body_of_id[first..first + count].fill(u32::MAX);
                continue;
            }
            self.body_of_id[first..first + count].fill(to as u32);
            let range = self.member_start[b] as usize..self.member_start[b + 1] as usize;
            member_row.extend_from_slice(&self.member_row[range]);
            member_start.push(member_row.len() as u32);
            self.kind[to] = self.kind[b];
            self.position[to] = self.position[b];
            self.velocity[to] = self.velocity[b];
            self.orientation[to] = self.orientation[b];
            self.angular_momentum[to] = self.angular_momentum[b];
            self.force[to] = self.force[b];
            self.torque[to] = self.torque[b];
            self.aux[to] = self.aux[b];
            self.first_member[to] = self.first_member[b];
            to += 1;
        }
        self.kind.truncate(to);
        self.position.truncate(to);
        self.velocity.truncate(to);
        self.orientation.truncate(to);
        self.angular_momentum.truncate(to);
        self.force.truncate(to);
        self.torque.truncate(to);
        self.aux.truncate(to);
        self.first_member.truncate(to);
        self.member_row = member_row;
        self.member_start = member_start;
    }
}

/// The state of a body to place: centre, velocity, orientation of the principal frame,
/// angular velocity (world frame).
#[derive(Debug, Clone, Copy)]
pub struct BodyState {
    pub position: DVec3,
    pub velocity: DVec3,
    pub orientation: DQuat,
    pub angular_velocity: DVec3,
}

/// w = R I^-1 R^T L for orientation R, principal moments I and angular momentum L.
#[inline]
pub fn angular_velocity(orientation: DQuat, inertia: DVec3, momentum: DVec3) -> DVec3 {
    orientation * ((orientation.inverse() * momentum) / inertia)
}
