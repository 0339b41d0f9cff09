//! The denoiser's per-pixel guides as separate arrays, filled by the band
//! pass from the G-buffer: at full resolution for the resolve (and the
//! full-rate denoiser), at quad resolution for reduced-rate visibility.

use super::gbuffer::{GSample, PixelKind};
use glam::{Vec2, Vec3};
use penumbra_denoise::{GuideBuffers, Lobe};
use penumbra_kernels::shading::brdf::alpha_from_roughness;

pub struct Guides {
    pub width: u32,
    pub height: u32,
    pub position: Vec<Vec3>,
    pub normal: Vec<Vec3>,
    pub depth: Vec<f32>,
    pub prev_pixel: Vec<Vec2>,
    pub prev_valid: Vec<bool>,
    pub lobe: Vec<Lobe>,
}

impl Guides {
    pub fn new(width: u32, height: u32) -> Guides {
        let n = width as usize * height as usize;
        Guides {
            width,
            height,
            position: vec![Vec3::ZERO; n],
            normal: vec![Vec3::ZERO; n],
            depth: vec![0.0; n],
            prev_pixel: vec![Vec2::ZERO; n],
            prev_valid: vec![false; n],
            lobe: vec![Lobe::default(); n],
        }
    }

    /// What the denoiser and the resolve read: these guides and the `U` of
    /// the same pixels.
    pub fn buffers<'a>(&'a self, u: &'a [Vec3]) -> GuideBuffers<'a> {
        GuideBuffers {
            width: self.width,
            height: self.height,
            position: &self.position,
            normal: &self.normal,
            depth: &self.depth,
            prev_pixel: &self.prev_pixel,
            prev_valid: &self.prev_valid,
            u,
            lobe: &self.lobe,
        }
    }

    /// The same rows of every array: `rows` rows from row `band * rows`.
    pub fn bands(&mut self, rows: u32) -> impl Iterator<Item = GuideMut<'_>> {
        let n = (rows * self.width).max(1) as usize;
        self.position
            .chunks_mut(n)
            .zip(self.normal.chunks_mut(n))
            .zip(self.depth.chunks_mut(n))
            .zip(self.prev_pixel.chunks_mut(n))
            .zip(self.prev_valid.chunks_mut(n))
            .zip(self.lobe.chunks_mut(n))
            .map(
                |(((((position, normal), depth), prev_pixel), prev_valid), lobe)| GuideMut {
                    position,
                    normal,
                    depth,
                    prev_pixel,
                    prev_valid,
                    lobe,
                },
            )
    }
}

/// One band of rows of every guide array.
pub struct GuideMut<'a> {
    pub position: &'a mut [Vec3],
    pub normal: &'a mut [Vec3],
    pub depth: &'a mut [f32],
    pub prev_pixel: &'a mut [Vec2],
    pub prev_valid: &'a mut [bool],
    pub lobe: &'a mut [Lobe],
}

impl GuideMut<'_> {
    /// Only receiver surfaces are denoised; lights and misses pass through.
    /// `prev_pixel` is where the point was in the previous frame, in this
    /// buffer's own pixel coordinates.
    #[inline]
    pub fn set(&mut self, k: usize, g: &GSample, spec_share: f32, prev_pixel: Vec2) {
        let surface = g.kind == PixelKind::Surface;
        self.position[k] = g.position;
        self.normal[k] = if surface { g.ng } else { Vec3::ZERO };
        self.depth[k] = if surface { g.depth } else { 0.0 };
        self.prev_pixel[k] = prev_pixel;
        self.prev_valid[k] = g.prev_valid;
        self.lobe[k] = if surface {
            Lobe::new(g.ng, g.wo, alpha_from_roughness(g.roughness), spec_share)
        } else {
            Lobe::default()
        };
    }
}
