//! penumbra: a CPU real-time renderer of correct soft shadows from polygonal
//! area lights (Heitz, Hill, McGuire 2018: analytic direct light times a
//! ratio of stochastic estimates).
//!
//! A frame flows one way: scene → G-buffer (Embree packets) → analytic `U`,
//! samples, shadow rays → denoiser → composite → window or file. Each step
//! is a crate of its own under `crates/`; this crate is the application
//! around them (the window, the benchmarks, image output and comparison,
//! the LTC fit) and re-exports them under one name.

pub use penumbra_denoise as denoise;
pub use penumbra_embree as embree;
pub use penumbra_isa as isa;
pub use penumbra_kernels::{sampling, shading};
pub use penumbra_render as render;
pub use penumbra_scene as scene;
pub use penumbra_scene::color;

pub mod compare;
pub mod display;
pub mod fit_ltc;
pub mod nelder_mead;
pub mod output;
pub mod report;
pub mod view;
