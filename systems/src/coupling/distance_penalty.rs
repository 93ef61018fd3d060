//! The distance penalty (`coupling.boundary = "distance_penalty"`): a fictitious boundary
//! whose no-slip wall lies at the particle's true surface, not at the staircase of the
//! faces whose centres lie inside it.
//!
//! Under the face-centre rule ([`super::markers`]) the faces inside a sphere carry its
//! rigid-body velocity `U`, and the first face outside, at a distance `s` in `(0, h)` from
//! the surface, is free: the flow sees the wall at the last face inside, up to a face
//! spacing `h` inside the surface. A sphere therefore looks smaller than it is by a
//! fraction of a cell that changes in steps as it moves (the drag of a fixed periodic array
//! is 7 % low at 4 cells per radius; a settling sphere's velocity carries a sawtooth).
//!
//! The penalty adds an implicit reaction `-k(s) (u - U)` per unit mass on every face
//! outside all particles within `h` of a surface, with the rigid-body velocity `U` of its
//! nearest particle at the face centre, and chooses the rate so that the discrete
//! equation of a face next to a held face reproduces a linear shear profile with the wall
//! at the surface. In one dimension, with the held face at `s - h` (velocity `U`), the
//! face at `s` and the free face at `s + h`, the steady viscous balance
//! `nu (u_+ - 2 u + U) / h^2 = k (u - U)` holds for `u - U = G s`, `u_+ - U = G (s + h)`
//! exactly when
//!
//! `k(s) = nu (h - s) / (s h^2)`  ([`penalty_rate`]),
//!
//! which is infinite at `s = 0` (the face is on the wall: it moves with it) and zero at
//! `s = h` (the face is a whole spacing out: the held face already is the wall's
//! neighbour). The same construction is the ghost-cell interpolation of sharp-interface
//! immersed boundaries (Fadlun et al. 2000, J. Comput. Phys. 161:35, linear
//! reconstruction along the grid line) written as a positive diagonal term, and the
//! `tau -> 1/2` limit of the partially saturated cells of Noble & Torczynski (1998, Int.
//! J. Mod. Phys. C 9:1189), whose solid weight acts as a Darcy drag
//! `3 nu phi / ((1 - phi) h^2)` rising from zero to infinity across a cell. Taken
//! backward-Euler inside the momentum solve ([`grainflow_fluid::PenaltyFace`]) it is stable
//! for any rate; it does not depend on the fluid step. In three dimensions `s` is the
//! distance of the face centre from the surface along the sphere's normal and `h` the
//! geometric mean of the cell sides (the cases use cubes).
//!
//! The particle takes the reaction, `F = rho_f sum_f k_f M_f (u_f - U_f)` over its
//! penalised faces and its moment about the centre ([`penalty_reaction`]), besides the
//! force of its held faces ([`super::volume_integral`]) or of the fluid inside it
//! ([`super::fluid_momentum`]).
use grainflow_components::Particles;
use grainflow_fluid::{Grid, NavierStokes, PenaltyFace};

use super::{add_force, faces_about, rigid_velocity, Wrap};

/// The smallest distance of [`penalty_rate`], as a fraction of the spacing: a face closer
/// to the surface gets the rate there (`999 nu / h^2`, its velocity within 0.1 % of the
/// wall's).
const MIN_DISTANCE: f64 = 1e-3;

/// Penalty rate `k(s) = nu (h - s) / (s h^2)` of a face at distance `s` in `(0, h)`
/// outside the surface, kinematic viscosity `nu`, spacing `h` (see the module docs for the
/// derivation); `s` below `MIN_DISTANCE h` counts as that.
pub fn penalty_rate(nu: f64, s: f64, h: f64) -> f64 {
    let s = s.max(MIN_DISTANCE * h);
    nu * (h - s) / (s * h * h)
}

/// The spacing `h` of the penalty: the geometric mean of the cell sides.
pub fn penalty_spacing(grid: &Grid) -> f64 {
    let h = grid.h();
    (h[0] * h[1] * h[2]).cbrt()
}

/// The penalised faces and their particle rows: every face outside all particles whose
/// centre lies within the spacing `h` ([`penalty_spacing`]) of a sphere's surface and
/// whose velocity the box sides do not prescribe, with the rate [`penalty_rate`] of its
/// nearest surface and that particle's rigid-body velocity at the face centre as target
/// (in face order). `inside` tells whether a face lies inside a particle, `box_mask` flags
/// the faces the box sides prescribe.
pub fn penalty_faces(
    grid: &Grid,
    particles: &Particles,
    inside: impl Fn(u32) -> bool,
    box_mask: &[bool],
    nu: f64,
) -> (Vec<PenaltyFace>, Vec<u32>) {
    let lay = grid.layout();
    let wrap = Wrap::new(grid);
    let h = penalty_spacing(grid);
    // (face, distance as ordered bits, row): a face near several spheres takes the nearest
    let mut near: Vec<(u32, u64, u32)> = Vec::new();
    for i in 0..particles.len() {
        let r = particles.radius[i];
        let xp = wrap.image([0, 1, 2].map(|d| particles.position[d][i]));
        faces_about(grid, &wrap, xp, r + h, |a, f, arm| {
            let s = arm.iter().map(|v| v * v).sum::<f64>().sqrt() - r;
            let idx = lay.face(a, f);
            if (0.0..h).contains(&s) && !box_mask[idx] {
                near.push((idx as u32, s.to_bits(), i as u32));
            }
        });
    }
    near.sort_unstable();
    near.dedup_by_key(|&mut (face, _, _)| face);
    near.retain(|&(face, _, _)| !inside(face));
    let mut faces = Vec::with_capacity(near.len());
    let mut rows = Vec::with_capacity(near.len());
    for (idx, s, i) in near {
        let (a, f) = lay.face_of(idx as usize);
        let xp = [0, 1, 2].map(|d| particles.position[d][i as usize]);
        let arm = wrap.arm(grid.face_centre(a, f), xp);
        faces.push(PenaltyFace {
            face: idx,
            rate: penalty_rate(nu, f64::from_bits(s), h),
            target: rigid_velocity(particles, i as usize, arm),
        });
        rows.push(i);
    }
    (faces, rows)
}

/// The reaction of the penalty on every particle after a fluid step:
/// `F = rho_f sum_f k_f M_f (u_f - U_f)` over the penalised faces `f` of its row in `rows`
/// (the solver's list, [`NavierStokes::penalty`]), with the lumped masses `M_f`, and the
/// torque of the same terms about the centre (arms by minimum image). Summed in face
/// order: independent of the thread count.
pub fn penalty_reaction(
    ns: &NavierStokes,
    rows: &[u32],
    particles: &Particles,
    fluid_density: f64,
) -> Vec<([f64; 3], [f64; 3])> {
    let grid = ns.grid();
    let lay = grid.layout();
    let wrap = Wrap::new(grid);
    let ml = ns.lumped_mass();
    let mut ft = vec![([0.0; 3], [0.0; 3]); particles.len()];
    for (pf, &i) in ns.penalty().iter().zip(rows) {
        let (idx, i) = (pf.face as usize, i as usize);
        let (a, f) = lay.face_of(idx);
        let xp = [0, 1, 2].map(|d| particles.position[d][i]);
        let arm = wrap.arm(grid.face_centre(a, f), xp);
        let k = fluid_density * pf.rate * ml[idx];
        let df = [0, 1, 2].map(|d| k * (ns.u[d][idx] - pf.target[d]));
        let (force, torque) = &mut ft[i];
        add_force(force, torque, arm, df);
    }
    ft
}
