//! The contact laws, one model per file, each formula with its equation and source: the
//! Hertz normal force and its damping laws, Coulomb friction with a tangential spring,
//! rolling resistance and JKR adhesion.
pub mod friction;
pub mod hertz;
pub mod jkr;
pub mod rolling;
