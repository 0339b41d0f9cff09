//! The frame pipeline: scene → G-buffer → U, samples, shadow rays → composite.

pub mod estimate;
pub mod frame;
pub mod gbuffer;
pub mod guides;
pub mod lights;
pub mod mode;
pub mod plan;
pub mod primary;
pub mod quads;
pub mod replay;
pub mod settings;
pub mod shadow;
pub mod solo;
pub mod upscaled;
pub mod world;

pub use frame::{Frame, PhaseTimes};
pub use gbuffer::{GSample, PixelKind};
pub use mode::Mode;
pub use plan::FramePlan;
pub use settings::{LIGHT_TOLERANCE, RenderSettings, VisibilityRate};
pub use upscaled::{Upscaled, render_frame, scaled_size, shown};
pub use world::World;
