//! The fictitious domain on the fixed fluid grid (seed, "Interaction between particle
//! and fluid phase"): level-set cell markers and the rigid-body velocity on the faces
//! inside every particle, before each fluid step.
//!
//! For every particle `p` (row + 1 of the current order) with centre `x_p`, radius `r`,
//! velocity `U` and angular velocity `w` (a body of another shape, such as a clump: its
//! owner row, centre of mass, velocity and angular velocity, its solid given by the
//! depth of its [`ParticleShape`] in place of `r - |x - x_p|`, [`super::bodies`]):
//! * markers (seed's level set): a cell whose box lies inside the sphere is inner (`-p`),
//!   one the surface may cut (centre within half a cell diagonal of the surface) is
//!   boundary (`p`), all others stay outer (0). Only the cells of the sphere's bounding box
//!   are visited, and only the marked cells are cleared before the next marking, so the
//!   cost is proportional to the cells the particles cover, not to the grid.
//! * rigid-body motion: every face whose centre lies inside the sphere gets
//!   `u(x) = U + w x (x - x_p)`. Under [`ParticleUpdate::Prescribed`] (and for fixed
//!   particles) it joins the solver's mask of prescribed faces (the fictitious boundary
//!   condition of Wan & Turek 2006; the solver keeps masked faces at their value through
//!   the step); under [`ParticleUpdate::FluidMomentum`] it only starts the step there,
//!   and the momentum of the faces that entered and left the particle since the last
//!   step is booked to it first ([`super::face_exchange`]). A face inside several particles (overlapping spheres) belongs to the one it lies
//!   deepest in.
//! * when the scene blends, the other faces of each particle's boundary cells, for the
//!   smooth transition ([`super::blending`]).
//! * under [`BoundaryRule::DistancePenalty`], the faces within a cell outside the surfaces
//!   with their penalty rates and targets, given to the flow solver
//!   ([`super::distance_penalty`]).
//!
//! Along a periodic direction of the fluid (length `L`) the DEM particles do not wrap: a
//! particle may move past the periodic side and sees the flow at its image in the box
//! ([`super::Wrap`]). Its centre is taken modulo `L`, its cell index ranges run past 0 or
//! `n` and wrap modulo `n`, and the arms `x - x_p` of cells and faces are minimum images,
//! so a sphere straddling a periodic side is marked on both sides, each face inside it
//! getting `U + w x (x - x_p)` with its arm across the side.
//!
//! A particle the grid cannot represent stops the run ([`outside_the_fluid`]): one
//! whose centre has left the fluid box through a non-periodic side (it would feel no
//! fluid), or one whose marked cells reach half way round a periodic direction (they would
//! meet their own image). A sphere may reach past a wall, inflow or outflow side: the
//! side's condition holds on its faces.
//!
//! [`ParticleShape`]: crate::contact::shapes::ParticleShape
//! [`ParticleUpdate::Prescribed`]: grainflow_components::ParticleUpdate::Prescribed
//! [`ParticleUpdate::FluidMomentum`]: grainflow_components::ParticleUpdate::FluidMomentum
use bevy_ecs::prelude::*;
use grainflow_components::{
    BodyAcceleration, BoundaryRule, CellMarkers, Clamped, Clumps, Coupling, HydroForces,
    InsideFluid, ParticleFace, Particles, RunHealth, SimClock,
};
use grainflow_fluid::{FaceLoad, Grid};

use super::bodies::Bodies;
use super::distance_penalty::penalty_faces;
use super::face_exchange::book_face_exchange;
use super::{holds_faces, rigid_velocity, Wrap};
use crate::fluid::FluidFlow;

/// `cell_markers`: the markers, the faces inside the particles with their rigid-body
/// velocity, and the faces to blend, before each fluid step (see the module docs).
pub fn cell_markers(
    (clock, mut health): (Res<SimClock>, ResMut<RunHealth>),
    coupling: Res<Coupling>,
    (particles, body): (Res<Particles>, Res<BodyAcceleration>),
    (clamped, clumps): (Option<Res<Clamped>>, Option<Res<Clumps>>),
    mut markers: ResMut<CellMarkers>,
    mut flow: ResMut<FluidFlow>,
    mut hydro: ResMut<HydroForces>,
) {
    let _span = tracing::info_span!("cell_markers").entered();
    let grid = flow.solver.grid().clone();
    let lay = grid.layout();
    let wrap = Wrap::new(&grid);
    let half_diagonal = half_cell_diagonal(&grid);
    if health.failure.is_none() {
        if let Some((_, what)) = outside_the_fluid(&grid, &particles) {
            health.failure = Some(format!(
                "at step {} (t = {:.6e} s), before fluid step {}: {what}",
                clock.step,
                clock.time,
                flow.stats.steps + 1
            ));
        }
    }
    let CellMarkers {
        marker,
        marked,
        rigid_faces,
        particle_faces,
        blend_faces,
        penalty_rows,
    } = &mut *markers;
    if marker.len() != lay.num_cells() {
        *marker = vec![0; lay.num_cells()];
    }
    for &c in marked.iter() {
        marker[c as usize] = 0;
    }
    marked.clear();
    let released = std::mem::take(rigid_faces);
    let carried = std::mem::take(particle_faces);
    blend_faces.clear();
    let blending = coupling.alpha.is_some();
    // (face, depth r - |x - x_p| as ordered bits, particle row) of every face inside a
    // particle: a face inside several belongs to the one it lies deepest in
    let mut inside: Vec<(u32, u64, u32)> = Vec::new();
    let box_mask = flow.solver.box_mask();
    let bodies = Bodies::new(&particles, clumps.as_deref());
    let mut marking = Marking {
        grid: &grid,
        wrap: &wrap,
        box_mask,
        half_diagonal,
        blending,
        marker,
        marked,
        inside: &mut inside,
        blend_faces,
    };
    for i in 0..particles.len() {
        if bodies.is_member(i) {
            continue; // marked with its body below
        }
        let r = particles.radius[i];
        let xp = wrap.image([0, 1, 2].map(|d| particles.position[d][i]));
        marking.mark(
            i,
            xp,
            r,
            |rc| {
                let dist = rc.iter().map(|v| v.powi(2)).sum::<f64>().sqrt();
                if dist + half_diagonal <= r {
                    Some(true)
                } else if dist - half_diagonal < r {
                    Some(false)
                } else {
                    None
                }
            },
            |rf| {
                let d2 = rf.iter().map(|v| v.powi(2)).sum::<f64>();
                (d2 < r * r).then(|| r - d2.sqrt())
            },
        );
    }
    // the bodies of other shapes, by their fluid indicator (`ParticleShape::depth`)
    for body in &bodies.list {
        let xc = wrap.image(body.centre);
        marking.mark(
            body.owner,
            xc,
            bodies.reach[body.kind],
            |rc| {
                let depth = bodies.depth(body, rc);
                if depth >= half_diagonal {
                    Some(true)
                } else if depth > -half_diagonal {
                    Some(false)
                } else {
                    None
                }
            },
            |rf| {
                let depth = bodies.depth(body, rf);
                (depth > 0.0).then_some(depth)
            },
        );
    }
    // each face once (a cell's faces are visited from both its cells), to its deepest
    // particle (positive depths order as their bits; the complement sorts deepest first)
    inside.sort_unstable();
    inside.dedup_by_key(|&mut (face, _, _)| face);
    let free_inside: Vec<(u32, u32)> = inside
        .iter()
        .filter(|&&(_, _, i)| !holds_faces(&coupling, clamped.as_deref(), i as usize))
        .map(|&(idx, _, i)| (idx, i))
        .collect();
    book_face_exchange(
        &carried,
        &free_inside,
        &particles,
        &coupling,
        &flow,
        &mut hydro,
    );
    for &(idx, _, i) in &inside {
        let (a, f) = lay.face_of(idx as usize);
        let x = grid.face_centre(a, f);
        let v = match bodies.owned_by(i as usize) {
            Some(body) => Bodies::rigid_velocity(body, wrap.arm(x, body.centre)),
            None => {
                let xp = [0, 1, 2].map(|d| particles.position[d][i as usize]);
                rigid_velocity(&particles, i as usize, wrap.arm(x, xp))
            }
        };
        for (u, v) in flow.solver.u.iter_mut().zip(v) {
            u[idx as usize] = v;
        }
        if holds_faces(&coupling, clamped.as_deref(), i as usize) {
            rigid_faces.push(idx);
        } else {
            particle_faces.push(ParticleFace {
                face: idx,
                row: i,
                id: particles.id[i as usize],
                start: v,
                load: [0.0; 3],
            });
        }
    }
    // the old rule (`InsideFluid::Fluid`) loads no face: its solve is the one before
    let loads = if coupling.inside == InsideFluid::Particle {
        inside_loads(
            particle_faces,
            &particles,
            &bodies,
            &body,
            &hydro,
            &flow,
            coupling.fluid_density,
        );
        particle_faces
            .iter()
            .map(|pf| FaceLoad {
                face: pf.face,
                accel: pf.load,
            })
            .collect()
    } else {
        Vec::new()
    };
    flow.solver.set_loads(loads);
    flow.solver.move_mask(&released, rigid_faces);
    if coupling.boundary == BoundaryRule::DistancePenalty {
        let is_inside = |face| {
            inside
                .binary_search_by_key(&face, |&(inner, _, _)| inner)
                .is_ok()
        };
        let (penalty, rows) = penalty_faces(
            &grid,
            &particles,
            is_inside,
            flow.solver.box_mask(),
            coupling.viscosity,
        );
        flow.solver.set_penalty(penalty);
        *penalty_rows = rows;
    }
    // a face of one particle's boundary cells may lie inside another particle
    blend_faces.sort_unstable();
    blend_faces.dedup();
    blend_faces.retain(|&(face, _)| {
        inside
            .binary_search_by_key(&face, |&(inner, _, _)| inner)
            .is_err()
    });
}

/// The marking of one fluid step: the cells' markers, the faces inside the particles and
/// the faces to blend, filled particle by particle ([`Marking::mark`]).
struct Marking<'a> {
    grid: &'a Grid,
    wrap: &'a Wrap,
    box_mask: &'a [bool],
    half_diagonal: f64,
    blending: bool,
    marker: &'a mut Vec<i32>,
    marked: &'a mut Vec<u32>,
    /// (face, depth as ordered bits, complemented, row) of every face inside a particle
    inside: &'a mut Vec<(u32, u64, u32)>,
    blend_faces: &'a mut Vec<(u32, u32)>,
}

impl Marking<'_> {
    /// Marks the cells within `reach` plus half a cell diagonal of the centre `xp` (the
    /// image in the box) for row `i` (marker `i + 1`): `cell(arm)` says of a cell by its
    /// centre's arm whether it is inner (`Some(true)`), boundary (`Some(false)`) or
    /// neither; `face(arm)` gives the depth of a face centre inside the solid, if inside.
    /// The faces of the marked cells inside the solid go to `inside`, the others of the
    /// boundary cells, when blending, to `blend_faces`.
    fn mark(
        &mut self,
        i: usize,
        xp: [f64; 3],
        reach: f64,
        cell: impl Fn([f64; 3]) -> Option<bool>,
        face: impl Fn([f64; 3]) -> Option<f64>,
    ) {
        let (grid, wrap) = (self.grid, self.wrap);
        let lay = grid.layout();
        let p = i as i32 + 1;
        let range = wrap.cells(xp, reach + self.half_diagonal);
        for k in range[2].0..range[2].1 {
            for j in range[1].0..range[1].1 {
                for ci in range[0].0..range[0].1 {
                    let c = wrap.index([ci, j, k]);
                    let m = match cell(wrap.arm(grid.cell_centre(c), xp)) {
                        Some(true) => -p,
                        Some(false) => p,
                        None => continue,
                    };
                    let cell = lay.cell(c);
                    let old = self.marker[cell];
                    if old == 0 {
                        self.marked.push(cell as u32);
                    }
                    if old == 0 || (old > 0 && m < 0) {
                        self.marker[cell] = m;
                    }
                    for a in 0..3 {
                        for f in [c, lay.upper(a, c)] {
                            let rf = wrap.arm(grid.face_centre(a, f), xp);
                            let idx = lay.face(a, f);
                            if self.box_mask[idx] {
                                continue; // the box's boundary condition holds
                            }
                            if let Some(depth) = face(rf) {
                                self.inside.push((idx as u32, !depth.to_bits(), i as u32));
                            } else if self.blending && m > 0 {
                                self.blend_faces.push((idx as u32, i as u32));
                            }
                        }
                    }
                }
            }
        }
    }
}

/// The load of the faces inside the free particles: the body force per unit mass that
/// makes the fluid inside a particle accelerate with the particle through the fluid step.
///
/// Without it the fluid inside accelerates as fluid, by the force of the fluid around,
/// `F_in / (rho_f V)`, while the particle accelerates by
/// `a_p = g (1 - rho_f / rho_p) + (F_c + F_h) / m_p` (contacts and the whole hydrodynamic
/// force). A settling sphere at its terminal velocity then slows within every step by
/// `(rho_p / rho_f - 1) g dt_F`, and the flow sees a body slower than the particle: a
/// first-order time error that makes it fall too fast. The load is the difference of the
/// two, predicted from the last fluid step: `b = a_p - F_in / (rho_f sum_f M_f)` with
/// `F_h` and `F_in` of the last step and `F_c` of this substep (at the fixed point of a
/// particle accelerating from rest in still fluid it gives the added-mass force
/// exactly). [`super::fluid_momentum`] takes the load's impulse out of the force again.
fn inside_loads(
    faces: &mut [ParticleFace],
    particles: &Particles,
    bodies: &Bodies,
    body: &BodyAcceleration,
    hydro: &HydroForces,
    flow: &FluidFlow,
    fluid_density: f64,
) {
    let ml = flow.solver.lumped_mass();
    let mut fluid_mass = vec![0.0; particles.len()];
    for pf in faces.iter() {
        fluid_mass[pf.row as usize] += ml[pf.face as usize];
    }
    // a body's contact force is the sum over its members (its owner row holds the faces,
    // the hydrodynamic force and, as every member, the inverse mass of the whole body)
    let mut contact: Vec<[f64; 3]> = (0..particles.len())
        .map(|i| [0, 1, 2].map(|d| particles.force[d][i]))
        .collect();
    for (i, &b) in bodies.body_of_row.iter().enumerate() {
        if b != u32::MAX {
            let owner = bodies.list[b as usize].owner;
            if owner != i {
                for (c, column) in contact[owner].iter_mut().zip(&particles.force) {
                    *c += column[i];
                }
            }
        }
    }
    let load: Vec<[f64; 3]> = (0..particles.len())
        .map(|i| {
            let g = body.per_material[particles.material[i] as usize];
            [0, 1, 2].map(|d| {
                let a_p = g[d] + particles.inv_mass[i] * (contact[i][d] + hydro.force[d][i]);
                let a_in = if fluid_mass[i] > 0.0 {
                    hydro.inside_force[d][i] / (fluid_density * fluid_mass[i])
                } else {
                    0.0
                };
                a_p - a_in
            })
        })
        .collect();
    for pf in faces.iter_mut() {
        pf.load = load[pf.row as usize];
    }
}

/// Half the diagonal of a cell: how far past a sphere its marked cells reach.
fn half_cell_diagonal(grid: &Grid) -> f64 {
    let h = grid.h();
    0.5 * (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt()
}

/// The first particle (in row order) that the grid cannot represent, if any: its centre
/// outside the fluid box through a non-periodic side (`x_p < x_0` or `x_p > x_1`), or,
/// along a periodic direction of length `L`, its marked cells (the sphere plus half a cell
/// diagonal) reaching half way round the box (`r + h_diag / 2 >= L / 2`: they would meet
/// their own periodic image, and the minimum-image arms of [`super::Wrap`] would be
/// ambiguous). A centre past a periodic side is not a failure: the particle sees the flow
/// at its image in the box, and its marked cells wrap. Returns its row, and a message
/// naming it by its id, its centre and radius, and the side (or the direction).
pub fn outside_the_fluid(grid: &Grid, particles: &Particles) -> Option<(usize, String)> {
    let half_diagonal = half_cell_diagonal(grid);
    (0..particles.len()).find_map(|i| {
        let r = particles.radius[i];
        let xp = [0, 1, 2].map(|d| particles.position[d][i]);
        let what = (0..3).find_map(|d| {
            let axis = ["x", "y", "z"][d];
            if grid.periodic(d) {
                let length = grid.upper[d] - grid.lower[d];
                (r + half_diagonal >= 0.5 * length).then(|| {
                    format!(
                        "periodic direction {axis}: its marked cells reach half way round the \
                         box (radius plus half a cell diagonal {:.4e} against half the box \
                         length {:.4e}) and would meet their own periodic image",
                        r + half_diagonal,
                        0.5 * length
                    )
                })
            } else {
                let end = if xp[d] < grid.lower[d] {
                    "min"
                } else if xp[d] > grid.upper[d] {
                    "max"
                } else {
                    return None;
                };
                Some(format!(
                    "side {axis}{end}: its centre has left the fluid box (it would feel no fluid)"
                ))
            }
        })?;
        Some((
            i,
            format!(
                "particle {} (centre ({:.4e}, {:.4e}, {:.4e}), radius {:.4e}) at the fluid \
                 {what}",
                particles.id[i], xp[0], xp[1], xp[2], r
            ),
        ))
    })
}
