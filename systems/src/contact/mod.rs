//! Contact forces, one pipeline: narrow phase per shape (`shapes`: a shape's member
//! spheres; `walls`: wall geometry and candidate lists), the contact laws per material
//! pair (`laws`, one model per file, applied by `pipeline::interact`), and accumulation
//! in a fixed order. Its pair stage has two accumulations: `frictionless` (Hertz with
//! damping, a central force with no per-contact state: each pair force computed once,
//! its two halves summed by owner and partner) and `with_history` (friction, rolling
//! resistance, adhesion: the contact store and its scatter plan); both share the wall
//! stage (`wall_pass`).
pub mod frictionless;
pub mod laws;
pub(crate) mod pipeline;
pub mod shapes;
pub mod wall_pass;
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
