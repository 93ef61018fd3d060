//! Contact forces: the wall geometry and candidate lists (`walls`), the contact laws, one
//! model per file (`laws`), and the passes that apply them to the listed pairs and wall
//! contacts: `frictionless` (Hertz with damping only, no per-contact state) and
//! `with_history` (friction, rolling resistance, adhesion, with the contact store).
pub mod frictionless;
pub mod laws;
pub mod shapes;
pub mod walls;
pub mod with_history;

/// The deeper of two (overlap ratio, particle id) records; the smaller id on ties.
#[inline(always)]
pub fn deeper(a: (f64, u32), b: (f64, u32)) -> (f64, u32) {
    if b.0 > a.0 || (b.0 == a.0 && b.1 < a.1) {
        b
    } else {
        a
    }
}
