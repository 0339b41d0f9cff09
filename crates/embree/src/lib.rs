//! Safe binding to Embree (3 or 4). The only module with `unsafe`.
//!
//! Lifetimes carry the ownership rules: a [`Scene`] borrows its [`Device`],
//! and queries exist only on a committed [`Scene`], never on the builder.
//! Embree's errors arrive through the device's error callback and come back
//! as [`EmbreeError`] values from the call that caused them.
//!
//! # Misuse does not compile
//!
//! Each block below is a `compile_fail` doc test: `cargo test` checks that
//! the compiler refuses it, with the error code named.
//!
//! Querying a scene before it is committed (the builder has no queries):
//! ```compile_fail,E0599
//! use penumbra_embree::{Device, SceneBuilder, Vec3};
//! let device = Device::new().unwrap();
//! let builder = SceneBuilder::new(&device).unwrap();
//! builder.intersect1(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY);
//! ```
//! Changing a scene after commit (a committed scene has no setters):
//! ```compile_fail,E0599
//! use penumbra_embree::{Device, GeometryRole, SceneBuilder};
//! let device = Device::new().unwrap();
//! let mut scene = SceneBuilder::new(&device).unwrap().commit().unwrap();
//! scene.add_triangles(&[], &[], GeometryRole::Occluder);
//! ```
//! Using a scene after its device is released:
//! ```compile_fail,E0505
//! use penumbra_embree::{Device, SceneBuilder, Vec3};
//! let device = Device::new().unwrap();
//! let scene = SceneBuilder::new(&device).unwrap().commit().unwrap();
//! drop(device);
//! scene.intersect1(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY);
//! ```
//! A scene outliving its device's scope:
//! ```compile_fail,E0597
//! use penumbra_embree::{Device, SceneBuilder};
//! let scene = {
//!     let device = Device::new().unwrap();
//!     SceneBuilder::new(&device).unwrap().commit().unwrap()
//! };
//! ```
//! Using a builder after commit consumed it:
//! ```compile_fail,E0382
//! use penumbra_embree::{Device, SceneBuilder};
//! let device = Device::new().unwrap();
//! let builder = SceneBuilder::new(&device).unwrap();
//! let scene = builder.commit().unwrap();
//! let again = builder.commit();
//! ```
//! Sharing a builder between threads (it is neither `Sync` nor `Send`):
//! ```compile_fail,E0277
//! use penumbra_embree::{Device, SceneBuilder};
//! fn shared<T: Sync>(_: &T) {}
//! let device = Device::new().unwrap();
//! shared(&SceneBuilder::new(&device).unwrap());
//! ```
//! ```compile_fail,E0277
//! use penumbra_embree::{Device, SceneBuilder};
//! fn sent<T: Send>(_: T) {}
//! let device = Device::new().unwrap();
//! sent(SceneBuilder::new(&device).unwrap());
//! ```
//! Handing a scene to a thread that may outlive the device:
//! ```compile_fail,E0597
//! use penumbra_embree::{Device, SceneBuilder, Vec3};
//! let device = Device::new().unwrap();
//! let scene = SceneBuilder::new(&device).unwrap().commit().unwrap();
//! std::thread::spawn(move || scene.occluded1(Vec3::ZERO, Vec3::X, 0.0, 1.0));
//! ```
//! What is allowed: a committed scene is `Sync`, so threads that end before
//! the device (scoped threads, rayon) query it at once.
//! ```
//! use penumbra_embree::{Device, GeometryRole, SceneBuilder, Vec3};
//! let device = Device::new().unwrap();
//! let mut builder = SceneBuilder::new(&device).unwrap();
//! let tri = [Vec3::new(-1.0, -1.0, 1.0), Vec3::new(1.0, -1.0, 1.0), Vec3::new(0.0, 1.0, 1.0)];
//! builder.add_triangles(&tri, &[[0, 1, 2]], GeometryRole::Occluder).unwrap();
//! let scene = builder.commit().unwrap();
//! std::thread::scope(|s| {
//!     for _ in 0..2 {
//!         s.spawn(|| assert!(scene.occluded1(Vec3::ZERO, Vec3::Z, 0.0, 2.0)));
//!     }
//! });
//! ```
//!
//! Packets: the public [`Rays16`], [`Rays8`] have no alignment demands; each
//! query copies them into Embree's own layouts, whose 32/64-byte alignment
//! the types carry (checked by this module's unit tests), so a misaligned
//! packet cannot reach Embree.

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
