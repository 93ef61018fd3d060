//! The distance penalty of the fictitious boundary (`coupling.boundary =
//! "distance_penalty"`, `systems/src/coupling/distance_penalty.rs`): an implicit reaction
//! `-nu (h - s) / (s h^2) (u - U)` on the faces within a cell outside a sphere, which puts
//! the no-slip wall at the sphere's surface instead of the staircase of faces inside it.
//! Checked against Hasimoto's periodic-array Stokes drag and for translation invariance
//! on the fixed grid (the targets of issue 37).
mod common;

use std::f64::consts::PI;

use common::{hasimoto_factor, periodic_array_drag};

const PENALTY: &str = "boundary = \"distance_penalty\"";
const FACE_CENTRE: &str = "boundary = \"face_centre\"";
const NORMAL_FORCE: &str = "pressure_force = \"normal\"";

/// `K` at the shifts `shifts` (fractions of the fine cell, along the diagonal) of the
/// centre from the box centre, and their spread `max / min - 1`.
fn drag_at_shifts(
    cells: usize,
    level: u32,
    coupling: &str,
    fluid: &str,
    shifts: &[f64],
) -> (Vec<f64>, f64) {
    let h = 1.0 / (cells << (level - 1)) as f64;
    let k: Vec<f64> = shifts
        .iter()
        .map(|&s| {
            let drag = periodic_array_drag(cells, level, [0.5 + s * h; 3], coupling, fluid, 90);
            assert!(drag.balance > 0.99, "not steady: {drag:?}");
            drag.k
        })
        .collect();
    let (lo, hi) = k
        .iter()
        .fold((f64::MAX, f64::MIN), |(l, u), &v| (l.min(v), u.max(v)));
    println!(
        "{coupling}, {} cells per radius: K at shifts {shifts:?} h: {k:.4?}, spread {:.3} %",
        (cells << (level - 1)) / 8,
        100.0 * (hi / lo - 1.0)
    );
    (k, hi / lo - 1.0)
}

/// Hasimoto's drag (1959, J. Fluid Mech. 5:317) of a simple cubic array, a = L/8, at 4
/// cells per radius (32^3), 90 backward-Euler steps (the setting of
/// tests/coupling.rs::periodic_array_drag_matches_hasimoto, where the face-centre rule
/// measures -6.1 %), the sphere at the box centre and moved by a quarter and a half of a
/// cell along the diagonal: within 2 % of Hasimoto at every position, and the drag
/// changes by less than 0.5 % (both targets of issue 37). With the normal pressure force
/// (`fluid.pressure_force = "normal"`), as here: measured K = 1.5604, 1.5608, 1.5588
/// against 1.5304 (+1.96, +1.99, +1.86 %), spread 0.13 %. With the shared force that
/// scenes with particles use by default the penalty's drag is 0.6 % higher: 1.5698,
/// 1.5704, 1.5712 (+2.57 to +2.67 %, spread 0.09 %), outside the 2 %.
#[test]
fn periodic_array_drag_is_within_two_percent_of_hasimoto_at_any_offset() {
    let k_ref = hasimoto_factor(4.0 / 3.0 * PI * 0.125f64.powi(3));
    let (k, spread) = drag_at_shifts(8, 3, PENALTY, NORMAL_FORCE, &[0.0, 0.25, 0.5]);
    for k in k {
        assert!((k / k_ref - 1.0).abs() < 0.02, "K = {k} vs {k_ref}");
    }
    assert!(spread < 0.005, "spread {spread}");
}

/// At 2 cells per radius (16^3) the face-centre body changes by whole faces as the sphere
/// moves by a fraction of a cell: measured K = 1.401, 1.372, 1.201 at shifts 0, h/4, h/2
/// (spread 16.7 %); the distance penalty 1.595, 1.594, 1.587 (0.50 %), both with the
/// default shared pressure force (with the normal force 18 % and 0.8 %). Bar: the penalty's
/// spread below a tenth of the face-centre rule's and below 1.5 %.
#[test]
fn the_penalty_removes_the_staircase_of_a_coarse_sphere() {
    let shifts = [0.0, 0.25, 0.5];
    let (_, penalty) = drag_at_shifts(8, 2, PENALTY, "", &shifts);
    let (_, face_centre) = drag_at_shifts(8, 2, FACE_CENTRE, "", &shifts);
    assert!(penalty < 0.015, "penalty: spread {penalty}");
    assert!(
        penalty < 0.1 * face_centre,
        "penalty {penalty} vs face centre {face_centre}"
    );
}
