//! The denoiser on synthetic G-buffers and on rendered frames of the shipped scenes.

mod edges;
mod lit;
mod lobe;
mod noise;
mod quality;
mod reprojection;
mod resolve;
mod robustness;
mod same_weights;
mod tiles;
mod upscale;
