//! penumbra: a CPU real-time renderer of correct soft shadows from polygonal
//! area lights (Heitz, Hill, McGuire 2018: analytic direct light times a
//! ratio of stochastic estimates).
//!
//! A frame flows one way: scene → G-buffer (Embree packets) → analytic `U`,
//! samples, shadow rays → denoiser → composite → window or file.

pub mod color;
pub mod compare;
pub mod denoise;
pub mod display;
pub mod embree;
pub mod isa;
pub mod output;
pub mod render;
pub mod report;
pub mod sampling;
pub mod scene;
pub mod shading;
pub mod view;
