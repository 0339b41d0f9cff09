//! Sampling math for the stochastic estimators `U_N` and `S_N`: low-discrepancy
//! sequences, solid-angle sampling of polygonal lights, GGX visible-normal and
//! cosine sampling of the BRDF, and MIS weights. Pure functions, no ray tracing;
//! the renderer combines them.

pub mod brdf_sample;
pub mod draw_lanes;
pub mod lanes8;
pub mod light;
pub mod mis;
pub mod sequence;
pub mod spherical_rect;
pub mod spherical_tri;
pub mod trig;

pub use brdf_sample::{
    BrdfSample, brdf_pdf, cosine_hemisphere, onb, sample_brdf, spec_lobe_probability, vndf_pdf,
    vndf_sample,
};
pub use light::{
    LightSample, LightSampler, PreparedLight, SOLID_ANGLE_AREA_FALLBACK, intersect_light,
    light_pdf, sample_light, sample_light_area_uniform,
};
pub use mis::{balance_heuristic, power_heuristic};
pub use sequence::{
    Pcg32, STREAM_LANES, StreamBatch, hash_u32, sample_1d, sample_1d_lanes, sample_2d,
    sample_2d_lanes,
};
