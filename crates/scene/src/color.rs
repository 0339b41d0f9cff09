//! Colour conventions shared by the renderer, the denoiser and the samplers.

use glam::Vec3;

/// Rec. 709 luminance weights of linear RGB.
pub const LUMA: Vec3 = Vec3::new(0.2126, 0.7152, 0.0722);

/// Rec. 709 luminance: the scalar ratios, light selection and `U` edges are
/// judged on.
#[inline(always)]
pub fn luminance(c: Vec3) -> f32 {
    c.dot(LUMA)
}
