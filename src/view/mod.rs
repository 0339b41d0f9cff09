//! The interactive window (minifb): render continuously, fly the camera,
//! switch modes, show an overlay, replay scripts.

mod controls;
pub mod font;
pub mod input;
pub mod overlay;
pub mod present;
pub mod scale;
pub mod script;
mod session;
mod window;

pub use window::{ViewOptions, run};

/// The frame rate `penumbra view` holds unless told otherwise.
pub const DEFAULT_TARGET_FPS: f32 = 30.0;
