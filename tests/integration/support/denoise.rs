//! Synthetic G-buffers for the denoiser tests: a pinhole camera at the origin
//! looking down -z at planes, and a small deterministic RNG.

use glam::{Vec2, Vec3};
use penumbra::denoise::{GuideBuffers, Lobe, luminance};

pub use super::rng::SplitMix64 as Rng;

/// The guide buffers of one frame, owned.
pub struct Frame {
    pub w: u32,
    pub h: u32,
    pub pos: Vec<Vec3>,
    pub normal: Vec<Vec3>,
    pub depth: Vec<f32>,
    pub prev_pixel: Vec<Vec2>,
    pub prev_valid: Vec<bool>,
    pub u: Vec<Vec3>,
    /// Empty: no lobe guide.
    pub lobe: Vec<Lobe>,
}

/// Which surface a pixel sees.
#[derive(Clone, Copy)]
pub enum Surface {
    /// Plane z = -d facing the camera.
    Back(f32),
    /// Wall x = x0 (normal -x), seen to the right of the crease.
    Wall(f32),
    None,
}

impl Frame {
    pub fn n(&self) -> usize {
        (self.w * self.h) as usize
    }

    /// Ray direction through pixel centre (x, y), 1/h pixel pitch at z = -1.
    pub fn dir(w: u32, h: u32, x: f32, y: f32) -> Vec3 {
        let s = 1.0 / h as f32;
        Vec3::new(
            (x + 0.5 - w as f32 / 2.0) * s,
            (h as f32 / 2.0 - y - 0.5) * s,
            -1.0,
        )
    }

    /// A frame whose pixel (x, y) sees `surface(x, y)`; static camera
    /// (every pixel reprojects onto itself), U = (1, 1, 1).
    pub fn new(w: u32, h: u32, surface: impl Fn(u32, u32) -> Surface) -> Frame {
        let n = (w * h) as usize;
        let mut f = Frame {
            w,
            h,
            pos: vec![Vec3::ZERO; n],
            normal: vec![Vec3::ZERO; n],
            depth: vec![0.0; n],
            prev_pixel: vec![Vec2::ZERO; n],
            prev_valid: vec![true; n],
            u: vec![Vec3::ONE; n],
            lobe: Vec::new(),
        };
        for y in 0..h {
            for x in 0..w {
                let i = (y * w + x) as usize;
                let d = Frame::dir(w, h, x as f32, y as f32);
                let (t, nrm) = match surface(x, y) {
                    Surface::Back(z) => (z, Vec3::Z),
                    Surface::Wall(x0) => (x0 / d.x, -Vec3::X),
                    Surface::None => (0.0, Vec3::ZERO),
                };
                let p = d * t;
                f.pos[i] = p;
                f.normal[i] = nrm;
                f.depth[i] = if t > 0.0 { p.length() } else { 0.0 };
                f.prev_pixel[i] = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            }
        }
        f
    }

    /// One plane at distance 4 filling the screen.
    pub fn plane(w: u32, h: u32) -> Frame {
        Frame::new(w, h, |_, _| Surface::Back(4.0))
    }

    pub fn guide(&self) -> GuideBuffers<'_> {
        GuideBuffers {
            width: self.w,
            height: self.h,
            position: &self.pos,
            normal: &self.normal,
            depth: &self.depth,
            prev_pixel: &self.prev_pixel,
            prev_valid: &self.prev_valid,
            u: &self.u,
            lobe: &self.lobe,
        }
    }
}

/// Denoised ratio as the composite sees it (1 where U_N carries nothing).
pub fn luminance_ratio(sn: Vec3, un: Vec3) -> f32 {
    let l = luminance(un);
    if l > 0.0 { luminance(sn) / l } else { 1.0 }
}

/// 1-spp ratio-estimator samples of a true ratio field: U_N carries BRDF-like
/// noise (independent per channel), S_N is U_N times one Bernoulli visibility.
pub fn sample(
    rng: &mut Rng,
    n: usize,
    true_ratio: impl Fn(usize) -> f32,
) -> (Vec<Vec3>, Vec<Vec3>) {
    let mut un = Vec::with_capacity(n);
    let mut sn = Vec::with_capacity(n);
    for i in 0..n {
        let u = Vec3::new(0.5 + rng.f32(), 0.5 + rng.f32(), 0.5 + rng.f32());
        let v = if rng.f32() < true_ratio(i) { 1.0 } else { 0.0 };
        un.push(u);
        sn.push(u * v);
    }
    (un, sn)
}

/// Smooth 0 -> 1 step between columns a and b.
pub fn soft_edge(x: f32, a: f32, b: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}
