//! grainflow: solid particles in viscous fluid. The library behind the `grainflow` CLI:
//! scene files, world building, schedules, run loop and output.
pub mod build;
pub mod checkpoint;
pub mod cli;
pub mod cloud;
pub mod clumps;
pub mod excavation;
pub mod fluid;
pub mod lammps;
pub mod memory;
pub mod observables;
pub mod obstacles;
pub mod outlets;
pub mod output;
pub mod plot;
pub mod run;
pub mod scene;
pub mod sinks;
pub mod stability;
