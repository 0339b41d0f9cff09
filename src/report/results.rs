//! Everything `penumbra bench` measures, as plain data: printed as a table,
//! written as JSON (`--json`), drawn as a chart (`--plot`).

use super::machine::Machine;
use super::stats::Spread;
use serde::{Deserialize, Serialize};

/// Bumped when a field changes meaning, so old JSON files are not misread.
pub const JSON_FORMAT: u32 = 1;

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BenchReport {
    pub format: u32,
    pub penumbra_version: String,
    pub git_revision: String,
    pub machine: Machine,
    /// Seconds since the Unix epoch when the run started.
    pub started_unix: u64,
    pub settings: Settings,
    pub scenes: Vec<SceneReport>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Settings {
    pub width: u32,
    pub height: u32,
    /// Worker threads of the main measurements (all cores).
    pub threads: usize,
    /// Frames rendered before measuring, then frames measured.
    pub warmup_frames: u32,
    pub measured_frames: u32,
    pub reference_spp: u32,
    pub quick: bool,
    /// How the error of each configuration is taken.
    pub error_method: String,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SceneReport {
    pub scene: String,
    pub triangles: usize,
    pub lights: usize,
    pub reference: ReferenceInfo,
    pub configs: Vec<ConfigReport>,
    /// Embree alone, per shadow-ray count (spp 0: camera rays only).
    pub ceilings: Vec<CeilingReport>,
    pub scaling: Scaling,
    /// relMSE of denoised `ratio` and denoised `stochastic` at the same ms per frame.
    pub equal_time: Vec<EqualTime>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ReferenceInfo {
    pub spp: u32,
    pub seed: u32,
    pub cache_file: String,
    pub reused: bool,
    pub render_seconds: f64,
}

#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize)]
pub struct Stages {
    /// Thread time per stage divided by the thread count (the stages run
    /// fused per band); `denoise` is wall time.
    pub primary: f64,
    pub u: f64,
    pub shadow: f64,
    pub denoise: f64,
    pub composite: f64,
    /// Wall time of the temporal resolve (absent in runs saved before it).
    #[serde(default)]
    pub resolve: f64,
    /// Wall time of upsampling reduced-rate visibility (0 at full rate).
    #[serde(default)]
    pub upsample: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ConfigReport {
    /// Mode, `+dn` when denoised.
    pub label: String,
    /// Which pixels drew visibility samples (`full`, `quarter`).
    #[serde(default = "full_rate")]
    pub visibility: String,
    /// Render size over output size, per side (1: rendered at the output's
    /// size; below 1, upscaled to it, `render::upscaled`).
    #[serde(default = "unit_scale")]
    pub render_scale: f32,
    pub mode: String,
    pub denoise: bool,
    pub spp: u32,
    pub threads: usize,
    /// Frames rendered before the measured ones: 1, or more for the rows
    /// of a camera held still for long (`still`, `settled`).
    #[serde(default = "one_frame")]
    pub warmup_frames: u32,
    pub frame_ms: Spread,
    /// 1000 / median frame ms.
    pub fps: f64,
    /// Medians, milliseconds.
    pub stages_ms: Stages,
    pub camera_rays: u64,
    /// Median shadow rays per frame.
    pub shadow_rays: u64,
    /// (camera + shadow rays) / median frame time.
    pub mrays_per_s: f64,
    /// Against the reference, every pixel (see `Settings::error_method`).
    pub rel_mse: f64,
    /// The same away from geometric edges.
    pub rel_mse_interior: f64,
    /// Denoised only: the first frame's error (no temporal history).
    pub rel_mse_first_frame: Option<f64>,
    /// Share of the lit interior pixels off the reference's luminance by
    /// more than 2x either way (`compare::speckles`), after the last frame.
    #[serde(default)]
    pub speckles: Option<f64>,
    /// Denoised only: the same after the first frame.
    #[serde(default)]
    pub speckles_first_frame: Option<f64>,
    /// Median Embree-alone time for the same camera and shadow rays.
    pub ceiling_ms: f64,
    /// Median frame time / `ceiling_ms`.
    pub over_ceiling: f64,
    /// Lights the `U` stage evaluated per surface pixel, both lobes and
    /// the Lambert lobe only (the rest culled), median over frames.
    #[serde(default)]
    pub u_lights: [f64; 2],
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CeilingReport {
    /// Shadow rays per surface pixel.
    pub spp: u32,
    pub threads: usize,
    pub total_ms: Spread,
    pub primary_ms: f64,
    pub shadow_ms: f64,
    pub camera_rays: u64,
    pub shadow_rays: u64,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ThreadPoint {
    pub threads: usize,
    pub frame_ms: Spread,
    pub ceiling_ms: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ResolutionPoint {
    pub width: u32,
    pub height: u32,
    pub frame_ms: Spread,
    /// Median frame time per pixel, all threads.
    pub ns_per_pixel: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Scaling {
    /// The configuration scaled (denoised ratio, 1 spp).
    pub config: String,
    pub threads: Vec<ThreadPoint>,
    /// Median frame time at 1 thread / at all threads.
    pub thread_speedup: f64,
    /// The same for Embree alone.
    pub ceiling_speedup: f64,
    pub resolution: Vec<ResolutionPoint>,
    /// ns per pixel at the smaller size / at the larger (1 = flat).
    pub per_pixel_ratio: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct EqualTime {
    /// The measured point the comparison is anchored at.
    pub anchor: String,
    pub ms: f64,
    pub ratio_rel_mse: f64,
    /// Interpolated (log-log) on the other mode's curve at `ms`.
    pub stochastic_rel_mse: f64,
    pub stochastic_over_ratio: f64,
}

fn unit_scale() -> f32 {
    1.0
}

fn one_frame() -> u32 {
    1
}

fn full_rate() -> String {
    "full".to_string()
}
