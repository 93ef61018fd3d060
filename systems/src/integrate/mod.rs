//! Time integration of the particles: the Gear predictor-corrector (`gear`), velocity
//! Verlet (`verlet`), the rotation of the spheres under torques (`rotation`) and the
//! kinematic particles put back on their path (`clamp`).
pub mod clamp;
pub mod gear;
pub mod rotation;
pub mod verlet;
