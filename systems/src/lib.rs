//! grainflow systems: plain functions over the ECS data of `grainflow-components`.
//!
//! `schedule.rs` declares the order of one time step and the table of systems; reading it
//! tells the whole step. Each physical model lives in its own file.

pub mod gear;
pub mod hertz;
pub mod inflow;
pub mod monitor;
pub mod neighbour_list;
pub mod rows;
pub mod schedule;
pub mod verlet;
pub mod walls;

pub use schedule::{build_schedule, Phase, StepSet, SystemEntry, REGISTRY};

/// Rows per parallel work item. Fixed, so the work split never depends on the thread count
/// (the results do not either: every particle sums its own forces in list order).
pub const CHUNK: usize = 2048;
