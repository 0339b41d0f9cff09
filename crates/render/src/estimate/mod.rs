//! Per-pixel light estimates: analytic `U`, and the stochastic `U_N`, `S_N`
//! made from the SAME samples (only `S_N` multiplies by visibility).
//!
//! A sample is drawn in three steps, all from the pixel's low-discrepancy
//! stream: a light, chosen in proportion to its analytic `U` (so the shadow
//! ray budget does not grow with the number of lights); a strategy, light or
//! BRDF sampling (one-sample MIS, balance heuristic); a direction. Its
//! weight `f · L · cos / (P_light · p_mis)` goes to `U_N`, and to `S_N` once
//! its shadow ray comes back unoccluded.
//!
//! `unshadowed` computes `U` per band; `samples` draws the samples.

mod samples;
mod unshadowed;

pub use samples::*;
pub use unshadowed::*;

use crate::gbuffer::GSample;
use penumbra_kernels::shading::SurfacePoint;

/// The shading inputs of a G-buffer sample.
#[inline]
pub fn surface_point(g: &GSample) -> SurfacePoint {
    SurfacePoint {
        p: g.position,
        n: g.ns,
        wo: g.wo,
        diffuse: g.diffuse,
        specular: g.specular,
        roughness: g.roughness,
    }
}
