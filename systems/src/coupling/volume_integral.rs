//! Hydrodynamic force on a particle by the volume integral of the fictitious boundary
//! method (Wan & Turek 2006, Int. J. Numer. Meth. Fluids 51:531, eq. for the hydrodynamic
//! force with the indicator `alpha` of the particle): `F = -int sigma . grad(alpha)`, with
//! `alpha_h` the Q1~ interpolant of the indicator (face value 1 when the face centre lies
//! inside the sphere), whose cell mean gradient is `1/|T| sum_f alpha_f n_f |f|`; so
//! `F = -sum_T sigma_T . sum_f alpha_f n_f |f|` and
//! `T = -sum_T (x_T - x_p) x (sigma_T . sum_f alpha_f n_f |f|)` over the cells where
//! `alpha_h` is not constant (those the surface cuts), with the cell stress
//! `sigma_T = rho_f (-p_T I + nu (G_T + G_T^T))` and the cell mean velocity gradient
//! `G_T = 1/|T| sum_f u_f (x) n_f |f|`. Evaluated with the solver's discrete operators,
//! this is minus its momentum residual summed over the faces inside the sphere
//! ([`volume_integral_force`]), computed at those faces only.
use grainflow_components::Coupling;
use grainflow_fluid::NavierStokes;

use super::{add_force, faces_about, Wrap};

/// Force and torque on a sphere by the volume integral of the fictitious boundary
/// method, `F = -int sigma . grad(alpha_h)`, evaluated with the discrete operators
/// (module docs): minus the momentum residual `R` of the flow solver
/// ([`NavierStokes::momentum_residual_at`], computed at the faces inside the sphere
/// only) summed over those faces, scaled by the fluid density; torque
/// `-sum (x_f - x_p) x R_f`. Along a periodic direction the centre is taken modulo the
/// box length and the faces of a sphere straddling the side are found on both sides, with
/// minimum-image arms ([`super::Wrap`]).
pub fn volume_integral_force(
    ns: &NavierStokes,
    coupling: &Coupling,
    xp: [f64; 3],
    r: f64,
) -> ([f64; 3], [f64; 3]) {
    volume_integral_over(ns, coupling, xp, r, |arm| {
        arm.iter().map(|v| v * v).sum::<f64>() < r * r
    })
}

/// The volume integral of [`volume_integral_force`] over any solid: the faces within
/// `reach` of the centre `xp` whose arm `x_f - x_p` (minimum image) `inside` holds, the
/// torque about `xp`. A body's faces are those of its fluid indicator
/// ([`super::bodies`]), each counted once however many members hold it.
pub fn volume_integral_over(
    ns: &NavierStokes,
    coupling: &Coupling,
    xp: [f64; 3],
    reach: f64,
    inside: impl Fn([f64; 3]) -> bool,
) -> ([f64; 3], [f64; 3]) {
    let grid = ns.grid();
    let wrap = Wrap::new(grid);
    let xp = wrap.image(xp);
    let mut faces = Vec::new();
    let mut arms = Vec::new();
    faces_about(grid, &wrap, xp, reach, |a, fc, arm| {
        if inside(arm) {
            faces.push((a, fc));
            arms.push(arm);
        }
    });
    let (mut f, mut t) = ([0.0; 3], [0.0; 3]);
    for (arm, res) in arms.into_iter().zip(ns.momentum_residual_at(&faces)) {
        let df = res.map(|v| -coupling.fluid_density * v);
        add_force(&mut f, &mut t, arm, df);
    }
    (f, t)
}
