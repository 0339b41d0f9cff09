//! The interactive window (minifb): render continuously, fly the camera,
//! switch modes.

mod controls;
mod window;

pub use window::{ViewOptions, run};
