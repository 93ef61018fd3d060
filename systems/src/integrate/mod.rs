//! Time integration of the particles: the Gear predictor-corrector (`gear`), velocity
//! Verlet (`verlet`), the rotation of the spheres under torques (`rotation`) and the
//! kinematic particles put back on their path (`clamp`), and the rigid clump bodies that
//! move their member spheres (`rigid_body`).
pub mod clamp;
pub mod gear;
pub mod rigid_body;
pub mod rotation;
pub mod verlet;
