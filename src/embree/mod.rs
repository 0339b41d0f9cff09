//! Safe binding to Embree (3 or 4). The only module with `unsafe`.
//!
//! Lifetimes carry the ownership rules: a [`Scene`] borrows its [`Device`],
//! and queries exist only on a committed [`Scene`], never on the builder.

mod context;
mod device;
mod error;
mod fpu;
mod packet;
mod scene;
pub(crate) mod sys;

pub use device::Device;
pub use error::EmbreeError;
pub use fpu::{flush_denormals_enabled, set_flush_denormals, thread_pool};
pub use glam::Vec3;
pub use packet::{Hits8, Hits16, INVALID_ID, Rays8, Rays16};
pub use scene::{GeometryRole, Hit, Scene, SceneBuilder, ShadowStrategy};
