//! Measurements: frame time, its split and its error against a cached
//! reference, the Embree ceiling, scaling; as a table, JSON and a chart.

mod bench;
mod ceiling;
pub mod interactive;
pub mod machine;
pub mod plot;
pub mod progress;
pub mod reference;
pub mod results;
pub mod stats;
mod table;

pub use bench::{BenchOptions, equal_time, label, run};
pub use ceiling::{Ceiling, ray_ceiling};
pub use table::format_report;
