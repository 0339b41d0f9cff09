//! Shading: the BRDF, the analytic unshadowed light U (exact Lambert form
//! factor + LTC for GGX) on polygonal lights.

pub mod brdf;
pub mod far_light;
pub mod lanes;
pub mod light_bound;
pub mod ltc;
pub mod ltc_correction;

pub mod polygon;
pub mod u_batch;
pub mod unshadowed;

pub use unshadowed::{
    ShadingLight, SurfacePoint, unshadowed, unshadowed_lobes, unshadowed_lobes_prepared,
    unshadowed_prepared,
};
