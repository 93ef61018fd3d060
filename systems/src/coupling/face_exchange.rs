//! The momentum that fluid faces carry into and out of a free particle as it moves over
//! the fixed grid, under the fluid-momentum update: booked to the particle, so that
//! particle and fluid together conserve momentum (tests/momentum_exchange.rs; its effect
//! on a settling sphere: docs/coupling.md).
use grainflow_components::{Coupling, HydroForces, ParticleFace, Particles};

use super::{add_force, rigid_velocity, Wrap};
use crate::fluid::FluidFlow;

/// The momentum that the faces entering and leaving the free particles carry across
/// their surfaces, booked as a force over the coming fluid step
/// (`HydroForces::exchange_force`, zeroed here for every particle).
///
/// The fluid-momentum update moves the fluid inside a free particle with the particle:
/// the momentum `m_p U + rho_f sum_(f outside) M_f u_f` of particle and real fluid changes
/// only by the forces on both. When the particle has moved, faces that were outside lie
/// inside it (entering: their momentum `rho_f M_f u_f` leaves the real fluid) and faces
/// that were inside lie outside (leaving: `rho_f M_f u_f` joins it); the particle takes
/// the difference. Of each face's momentum the part of the particle's rigid motion,
/// `rho_f M_f (U + w x (x_f - x_p))`, is the momentum flux through the moving surface that
/// [`super::fluid_momentum`] books as the convective term `rho_f V w x U` (Reynolds
/// transport); here the rest: `m_p dU = rho_f (sum_enter - sum_leave) M_f (u_f - U - w x
/// (x_f - x_p))`, and its moment about the centre. It is the fluid's deviation from the
/// rigid motion half a cell outside the surface, which the particle would otherwise push
/// ahead of it for free (a settling sphere falls too fast, more so on coarse grids).
/// The first faces of a particle (a new one, or the first fluid step) replace the fluid
/// there and book nothing. `carried` holds the free particles' faces of the last step
/// (sorted by face; their particles found by id, as the rows may have been reordered
/// since), `inside` those of this one (face, row; sorted by face); a face that changes
/// particle leaves the one and enters the other.
pub fn book_face_exchange(
    carried: &[ParticleFace],
    inside: &[(u32, u32)],
    particles: &Particles,
    coupling: &Coupling,
    flow: &FluidFlow,
    hydro: &mut HydroForces,
) {
    let HydroForces {
        exchange_force,
        exchange_torque,
        ..
    } = hydro;
    for col in exchange_force.iter_mut().chain(exchange_torque.iter_mut()) {
        col.fill(0.0);
    }
    if carried.is_empty() {
        return; // no free particle had faces: nothing entered or left one
    }
    let grid = flow.solver.grid();
    let lay = grid.layout();
    let wrap = Wrap::new(grid);
    let ml = flow.solver.lumped_mass();
    let u = &flow.solver.u;
    let rate = coupling.fluid_density / flow.dt;
    let mut row_of = vec![u32::MAX; particles.id.iter().max().map_or(0, |&m| m as usize + 1)];
    for (row, &id) in particles.id.iter().enumerate() {
        row_of[id as usize] = row as u32;
    }
    // the current row of a carried face's particle (none if it has left the run)
    let old_row = |o: &ParticleFace| {
        row_of
            .get(o.id as usize)
            .copied()
            .filter(|&r| r != u32::MAX)
    };
    // particles that had faces in the last step: the first faces of a particle (a new one,
    // or the first step) replace the fluid there, they do not enter it
    let mut had = vec![false; particles.len()];
    for o in carried {
        if let Some(r) = old_row(o) {
            had[r as usize] = true;
        }
    }
    let mut book = |idx: u32, row: u32, sign: f64| {
        let (idx, i) = (idx as usize, row as usize);
        if !had[i] {
            return;
        }
        let (a, f) = lay.face_of(idx);
        let xp = [0, 1, 2].map(|d| particles.position[d][i]);
        let arm = wrap.arm(grid.face_centre(a, f), xp);
        let rigid = rigid_velocity(particles, i, arm);
        let df = [0, 1, 2].map(|d| sign * rate * ml[idx] * (u[d][idx] - rigid[d]));
        let (mut force, mut torque) = ([0.0; 3], [0.0; 3]);
        add_force(&mut force, &mut torque, arm, df);
        for d in 0..3 {
            exchange_force[d][i] += force[d];
            exchange_torque[d][i] += torque[d];
        }
    };
    // merge the two face-sorted lists
    let (mut k, mut l) = (0, 0);
    loop {
        match (carried.get(k), inside.get(l)) {
            (None, None) => break,
            (Some(o), Some(&(face, row))) if o.face == face => {
                let before = old_row(o);
                if before != Some(row) {
                    if let Some(r) = before {
                        book(face, r, -1.0);
                    }
                    book(face, row, 1.0);
                }
                (k, l) = (k + 1, l + 1);
            }
            (Some(o), Some(&(face, row))) if face < o.face => {
                book(face, row, 1.0);
                l += 1;
            }
            (None, Some(&(face, row))) => {
                book(face, row, 1.0);
                l += 1;
            }
            // a face of the last step that lies before the next face of this one
            (Some(o), _) => {
                if let Some(r) = old_row(o) {
                    book(o.face, r, -1.0);
                }
                k += 1;
            }
        }
    }
}
