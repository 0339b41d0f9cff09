//! Measurements: frame timing against the Embree ceiling.

mod bench;
mod ceiling;
pub mod stats;

pub use bench::bench_scene;
pub use ceiling::{Ceiling, ray_ceiling};
